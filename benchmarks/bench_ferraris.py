"""Ferraris calibration of imucal's real session: inertest against imucal in the same run.

Both read the same CSV and compute the calibration; inertest also propagates the uncertainties
(a 54-input numerical Jacobian) and runs the label checks. Prints the times and the ratio.

Run: ``python benchmarks/bench_ferraris.py [REPEATS]`` (default 20).
"""

from __future__ import annotations

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
    t0 = time.perf_counter()
    for _ in range(repeats):
        inertest.fit(plan, inertest.load_data(DATA))
    t_ours = (time.perf_counter() - t0) / repeats
    t0 = time.perf_counter()
    for _ in range(repeats):
        df = pd.read_csv(DATA).set_index("part")
        FerrarisCalibration(grav=9.81, expected_angle=360.0).compute(
            ferraris_regions_from_df(df), 204.8, "a.u.", "a.u.")
    t_peer = (time.perf_counter() - t0) / repeats
    print(f"session: {DATA.name}, {repeats} repeats")
    print(f"inertest fit (read + checks + calibration + uncertainty): {t_ours * 1e3:.1f} ms")
    print(f"imucal FerrarisCalibration (pandas read + compute):       {t_peer * 1e3:.1f} ms")
    print(f"ratio inertest / imucal: {t_ours / t_peer:.2f}")


if __name__ == "__main__":
    main()
