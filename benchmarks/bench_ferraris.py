"""Ferraris calibration of imucal's real session: inertest against imucal in the same run.

Both read the same CSV and compute the calibration; inertest also propagates the uncertainties
(a 54-input numerical Jacobian) and runs the label checks. Prints the times and the ratio.

Run: ``python benchmarks/bench_ferraris.py [REPEATS]`` (default 20); the median of the
interleaved repeats.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import inertest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "realdata" / "imucal" / "annotated_session.csv"
PLAN = ROOT / "examples" / "ferraris" / "plan_imucal.toml"


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    repeats = int(argv[0]) if argv else 20
    import pandas as pd
    from imucal import FerrarisCalibration, ferraris_regions_from_df

    plan = inertest.load_plan(PLAN)

    data = inertest.load_data(DATA)
    frame = pd.read_csv(DATA).set_index("part")

    def ours() -> None:
        inertest.fit(plan, inertest.load_data(DATA))

    def peer() -> None:
        df = pd.read_csv(DATA).set_index("part")
        FerrarisCalibration(grav=9.81, expected_angle=360.0).compute(
            ferraris_regions_from_df(df), 204.8, "a.u.", "a.u.")

    def ours_fit() -> None:
        inertest.fit(plan, data)

    def peer_fit() -> None:
        FerrarisCalibration(grav=9.81, expected_angle=360.0).compute(
            ferraris_regions_from_df(frame), 204.8, "a.u.", "a.u.")

    fns = (ours, peer, ours_fit, peer_fit)
    for fn in fns:  # warm up (imports, caches)
        fn()
    times: list[list[float]] = [[] for _ in fns]
    for _ in range(repeats):  # interleaved: a busy machine slows all alike
        for fn, t in zip(fns, times, strict=True):
            t0 = time.perf_counter()
            fn()
            t.append(time.perf_counter() - t0)
    m_ours, m_peer, f_ours, f_peer = (statistics.median(t) for t in times)
    print(f"session: {DATA.name}, {repeats} repeats (median)")
    print(f"inertest fit (read + checks + calibration + uncertainty): {m_ours * 1e3:.1f} ms")
    print(f"imucal FerrarisCalibration (pandas read + compute):       {m_peer * 1e3:.1f} ms")
    print(f"ratio inertest / imucal: {m_ours / m_peer:.2f} (target <= 1, issue 18)")
    print(f"in memory: inertest fit {f_ours * 1e3:.1f} ms, imucal compute {f_peer * 1e3:.1f} ms, "
          f"ratio {f_ours / f_peer:.2f}")

if __name__ == "__main__":
    main()
