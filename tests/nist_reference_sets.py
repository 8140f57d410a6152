"""Published frequency-stability reference sets of NIST SP 1065 (Riley 2008), shared by tests.

* The 1000-point NBS set (SP 1065 section 12.1: a pseudo-random sequence) and Table 31, its
  deviations at tau = 1, 10, 100 s (7 significant digits).
* The NBS 9-point frequency set (tau0 = 1 s) and its published deviations at tau = 1 and 2 s
  (SP 1065 / Riley's handbook; allantools' tests carry the same table,
  tests/nbs14/test_nbs14_10point.py).
"""

from __future__ import annotations

import numpy as np

SP1065_TABLE31 = {
    "adev": (2.922319e-01, 9.965736e-02, 3.897804e-02),
    "oadev": (2.922319e-01, 9.159953e-02, 3.241343e-02),
    "mdev": (2.922319e-01, 6.172376e-02, 2.170921e-02),
    "tdev": (1.687202e-01, 3.563623e-01, 1.253382e00),
    "hdev": (2.943883e-01, 1.052754e-01, 3.910860e-02),
    "ohdev": (2.943883e-01, 9.581083e-02, 3.237638e-02),
    "totdev": (2.922319e-01, 9.134743e-02, 3.406530e-02),
}

NBS9 = (892.0, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0)
NBS9_PUBLISHED = {
    "adev": (91.22945, 115.8082),
    "oadev": (91.22945, 85.95287),
    "mdev": (91.22945, 74.78849),
    "totdev": (91.22945, 93.90379),
    "hdev": (70.80608, 116.7980),
    "tdev": (52.67135, 86.35831),
    "ohdev": (70.80607, 85.61487),
}


def nbs_1000() -> np.ndarray:
    """SP 1065 pseudo-random test set: n_{i+1} = 16807 n_i mod 2^31-1, seed 1234567890."""
    n = [1234567890]
    for _ in range(999):
        n.append(16807 * n[-1] % 2147483647)
    assert n[1:4] == [395529916, 1209410747, 633705974]  # first values printed in SP 1065
    return np.asarray(n, dtype=float) / 2147483647.0
