"""Polar-axis tumble fit of a large CSV end to end through the command line (issue 18).

``inertest fit PLAN DATA --no-store --json`` in a fresh process, as a user runs it, at 1e5, 1e6
and 1e7 rows (64 positions). For each size: wall and CPU time (best of a few runs; the CPU time
is steadier on a shared machine), peak RSS of the process, and that peak less the RSS of the
same command on a 64-row file (start-up: Python, numpy, scipy, pyarrow) per row. The scaling
exponent is the slope of log time against log rows between the sizes.

Targets (issue 18): 1e6 rows under 1.5 s and under 200 B/row (beyond start-up), time linear in
rows (exponent <= 1.1) up to 1e7.

Run: ``python benchmarks/bench_fit_csv.py [MAX_ROWS]`` (default 1e7; 1e6 for a quicker run).
"""

from __future__ import annotations

import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TARGET_S, TARGET_B_PER_ROW, TARGET_EXPONENT = 1.5, 200.0, 1.1
POSITIONS = 64  # 4 mountings x 16 angles


def _write(folder: Path, rows: int) -> tuple[Path, Path]:
    """A plan and a simulated CSV of ``rows`` readings (numpy + pyarrow, written in chunks)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    import inertest
    from inertest.earth import Site
    from inertest.plan import Instrument, Plan
    from inertest.procedures.polar_tumble import PolarTumbleSpec

    spp = max(1, rows // POSITIONS)
    plan_path = folder / f"plan{rows}.toml"
    plan_path.write_text(
        '[site]\nlatitude_deg = 34.246\n[instrument]\nkind = "sdf-gyro"\nserial = "B"\n'
        'output_unit = "mA"\nscale_factor = 12.5\n[procedure]\nkind = "polar-tumble"\n'
        f"samples_per_position = {spp}\n")
    plan = Plan(Site.at(34.246), Instrument(output_unit="mA", scale_factor=12.5),
                PolarTumbleSpec(samples_per_position=1))
    one = inertest.simulate(plan, {"DF": 1.2, "DI": 0.85, "DO": -0.6, "DSI": 0.05})
    rng = np.random.default_rng(1)
    path = folder / f"tumble{rows}.csv"
    with pacsv.CSVWriter(path, pa.schema([("mounting", pa.string()), ("angle_deg", pa.float64()),
                                          ("output", pa.float64())])) as w:
        for k in range(POSITIONS):
            out = one["output"][k] + rng.normal(0.0, 0.01, spp)
            w.write_table(pa.table({"mounting": np.full(spp, one["mounting"][k]),
                                    "angle_deg": np.full(spp, one["angle_deg"][k]),
                                    "output": out}))
    return plan_path, path


def _run(plan: Path, data: Path, repeats: int) -> tuple[float, float, float]:
    """Best wall time, best CPU time [s] and largest peak RSS [bytes] of the CLI fit."""
    exe = str(Path(sys.executable).parent / "inertest")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    wall = cpu = math.inf
    peak = 0.0
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        done = subprocess.run([exe, "fit", str(plan), str(data), "--no-store", "--json"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
        wall = min(wall, time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            raise RuntimeError(done.stderr.decode()[-500:])
        cpu = min(cpu, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
        peak = max(peak, after.ru_maxrss * 1024.0)  # largest child so far (Linux: kB)
    return wall, cpu, peak


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    top = int(float(argv[0])) if argv else 10_000_000
    sizes = [n for n in (100_000, 1_000_000, 10_000_000) if n <= top]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        plan, small = _write(folder, POSITIONS * 2)
        _, _, base = _run(plan, small, 3)
        print(f"start-up (64-position file): peak RSS {base / 1e6:.0f} MB")
        print(f"{'rows':>12} {'wall [s]':>9} {'cpu [s]':>8} {'peak RSS':>9} "
              f"{'B/row all':>10} {'B/row beyond start-up':>22}")
        times = []
        for n in sizes:
            plan, data = _write(folder, n)
            wall, cpu, peak = _run(plan, data, 3 if n <= 1_000_000 else 1)
            data.unlink()
            times.append(cpu)
            print(f"{n:12,d} {wall:9.2f} {cpu:8.2f} {peak / 1e6:7.0f} MB {peak / n:10.0f} "
                  f"{max(peak - base, 0) / n:22.0f}")
            if n == 1_000_000:
                print(f"  1e6 rows: time {'PASS' if wall < TARGET_S else 'MISS'} "
                      f"({wall:.2f} s wall vs {TARGET_S} s), memory "
                      f"{'PASS' if (peak - base) / n < TARGET_B_PER_ROW else 'MISS'} "
                      f"({(peak - base) / n:.0f} B/row vs {TARGET_B_PER_ROW:.0f})")
    if len(sizes) > 1:
        slope = (math.log(times[-1]) - math.log(times[0])) / (math.log(sizes[-1])
                                                              - math.log(sizes[0]))
        print(f"scaling exponent of CPU time {sizes[0]:.0e}..{sizes[-1]:.0e} rows: {slope:.2f} "
              f"({'PASS' if slope <= TARGET_EXPONENT else 'MISS'}, target <= {TARGET_EXPONENT})")


if __name__ == "__main__":
    main()
