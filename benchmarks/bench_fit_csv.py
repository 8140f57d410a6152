"""Polar-axis tumble fit of a large CSV (issue 2: "a 1e6-row CSV fits in a few seconds").

There is no peer tool for the tumble fit, so the baseline is the bare minimum any tool must do
on the same machine in the same run: parse the CSV with pandas-free ``numpy.loadtxt``-class
reading (here: pyarrow) plus ``numpy.linalg.lstsq`` on the 10-column design. The ratio shows the
overhead of inertest's identifiability analysis, harmonics and closed forms over that floor.

Run: ``python benchmarks/bench_fit_csv.py [ROWS]`` (default 1e6).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import inertest
from inertest.earth import Site
from inertest.io.data_file import read_table, write_table
from inertest.models.sdf_gyro import drift_regressors
from inertest.plan import Instrument, Plan
from inertest.procedures import polar_tumble
from inertest.procedures.polar_tumble import PolarTumbleSpec


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    rows = int(float(argv[0])) if argv else 1_000_000
    spp = max(1, rows // 64)
    plan = Plan(Site.at(34.246), Instrument(output_unit="mA", scale_factor=12.5),
                PolarTumbleSpec(samples_per_position=spp))
    truth = {"DF": 1.2, "DI": 0.85, "DO": -0.6, "DSI": 0.05}
    data = inertest.simulate(plan, truth, noise=0.01, rng=1)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "tumble.csv"
        write_table(path, data)
        size_mb = path.stat().st_size / 1e6

        t0 = time.perf_counter()
        result = inertest.fit(plan, path)
        t_ours = time.perf_counter() - t0

        t0 = time.perf_counter()
        cols = read_table(path)
        f = np.zeros((cols["output"].size, 3))
        for m in polar_tumble.table.MOUNTINGS:
            sel = cols["mounting"] == m
            f[sel] = polar_tumble.table.specific_force_ios(
                m, np.radians(cols["angle_deg"][sel]), plan.site.latitude_rad,
                plan.site.gravity_m_s2)
        np.linalg.lstsq(drift_regressors(f), cols["output"], rcond=None)
        t_floor = time.perf_counter() - t0
    n = data["output"].size
    print(f"rows: {n:,} ({size_mb:.1f} MB CSV)")
    print(f"inertest fit (read + LS + identifiability + harmonics + closed form): {t_ours:.2f} s")
    print(f"floor (read + one numpy lstsq):                                      {t_floor:.2f} s")
    print(f"ratio inertest / floor: {t_ours / t_floor:.2f}")
    print(f"DI = {result.coefficients['DI'].value:.5f} ± {result.coefficients['DI'].std:.5f} "
          f"{result.coefficients['DI'].unit}")


if __name__ == "__main__":
    main()
