"""Start-up time of the command line, as a ratio against ``python -c "import numpy"``.

Target (issue "one chain"): ``inertest --help`` and ``inertest fit --help`` well under half a
second, i.e. within a small multiple of importing numpy; plotting, databases, scikit-learn and
numba load only in the commands that use them. Best of several runs of fresh processes.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

REPEATS = 7


def _best(argv: Sequence[str]) -> float:
    best = float("inf")
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv: Sequence[str] = ()) -> None:
    py = sys.executable
    floor = _best([py, "-c", "import numpy"])
    print(f"python -c 'import numpy': {floor * 1e3:.0f} ms (the floor)")
    for label, args in (("inertest --help", ["--help"]), ("inertest fit --help", ["fit", "--help"]),
                        ("inertest allan --help", ["allan", "--help"])):
        t = _best([str(Path(py).parent / "inertest"), *args])
        print(f"{label:24s} {t * 1e3:6.0f} ms   ratio to import numpy: {t / floor:4.1f}x"
              f"   {'OK' if t < 0.5 else 'SLOW'} (target < 500 ms)")


if __name__ == "__main__":
    main(sys.argv[1:])
