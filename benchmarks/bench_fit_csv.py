"""Polar-axis tumble fit of a large CSV end to end through the command line (issue 18).

``inertest fit PLAN DATA --no-store --json`` in a fresh process, as a user runs it, at 1e5, 1e6
and 1e7 rows (64 positions). For each size: wall and CPU time (best of a few runs; the CPU time
is steadier on a shared machine), peak RSS of the process, and that peak less the RSS of the
same command on a 128-row file (start-up: Python, numpy, scipy, pyarrow) per row, both printed:
"gross" is peak RSS / rows, "net" is (peak RSS - start-up RSS) / rows. The scaling exponent is
the slope of log net CPU time (CPU time less that of the 128-row fit, the fixed start-up)
against log rows over 1e6..1e7 rows (over the sizes run when fewer): fitted to the total time
it would pass by construction, the start-up hiding the growth.

Targets (issue 18): 1e6 rows under 1.5 s wall and under 200 B/row net (the memory beyond
start-up; the gross figure is printed beside it), time linear in rows (exponent <= 1.1) up to
1e7.

Run: ``python benchmarks/bench_fit_csv.py [MAX_ROWS]`` (default 1e7; 1e6 for a quicker run).
"""

from __future__ import annotations

import math
import os
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
        t0 = time.perf_counter()
        # Measured by a small Python parent of its own: a child's ru_maxrss starts from its
        # parent's RSS at fork (kept across exec), and under `make bench` this process holds
        # the arrays of the benchmarks before it (2.2 GB reported for every size).
        done = subprocess.run([sys.executable, "-c", _MEASURE, exe, "fit", str(plan), str(data),
                               "--no-store", "--json"], capture_output=True, env=env)
        wall = min(wall, time.perf_counter() - t0)
        if done.returncode != 0:
            raise RuntimeError(done.stderr.decode()[-500:])
        child_cpu, child_kib = (float(v) for v in done.stdout.split())
        cpu = min(cpu, child_cpu)
        peak = max(peak, child_kib * 1024.0)  # Linux: kB
    return wall, cpu, peak


#: Runs argv[1:] (output discarded) and prints its CPU time [s] and peak RSS [kB].
_MEASURE = (
    "import resource, subprocess, sys\n"
    "r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL)\n"
    "u = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
    "print(u.ru_utime + u.ru_stime, u.ru_maxrss)\n"
    "sys.exit(r.returncode)\n"
)


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    top = int(float(argv[0])) if argv else 10_000_000
    sizes = [n for n in (100_000, 1_000_000, 10_000_000) if n <= top]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        plan, small = _write(folder, POSITIONS * 2)
        base_wall, base_cpu, base = _run(plan, small, 3)
        print(f"start-up ({POSITIONS * 2}-row file): wall {base_wall:.2f} s, CPU {base_cpu:.2f} s, "
              f"peak RSS {base / 1e6:.0f} MB")
        print(f"{'rows':>12} {'wall [s]':>9} {'cpu [s]':>8} {'net cpu [s]':>12} {'peak RSS':>9} "
              f"{'gross B/row':>12} {'net B/row':>10}")
        net_times = []
        for n in sizes:
            plan, data = _write(folder, n)
            wall, cpu, peak = _run(plan, data, 3 if n <= 1_000_000 else 2)
            data.unlink()
            net_times.append(cpu - base_cpu)
            net = max(peak - base, 0) / n
            print(f"{n:12,d} {wall:9.2f} {cpu:8.2f} {cpu - base_cpu:12.2f} {peak / 1e6:7.0f} MB "
                  f"{peak / n:12.0f} {net:10.0f}")
            if n == 1_000_000:
                print(f"  1e6 rows: time {'PASS' if wall < TARGET_S else 'MISS'} "
                      f"({wall:.2f} s wall vs {TARGET_S} s), memory "
                      f"{'PASS' if net < TARGET_B_PER_ROW else 'MISS'} ({net:.0f} B/row net "
                      f"vs {TARGET_B_PER_ROW:.0f}; gross {peak / n:.0f} B/row)")
    fit = [(n, t) for n, t in zip(sizes, net_times, strict=True) if n >= 1_000_000]
    fit = fit if len(fit) > 1 else list(zip(sizes, net_times, strict=True))
    if len(fit) > 1 and min(t for _, t in fit) > 0:
        (n0, t0), (n1, t1) = fit[0], fit[-1]
        slope = (math.log(t1) - math.log(t0)) / (math.log(n1) - math.log(n0))
        print(f"scaling exponent of net CPU time (less the start-up's {base_cpu:.2f} s) "
              f"{n0:.0e}..{n1:.0e} rows: {slope:.2f} "
              f"({'PASS' if slope <= TARGET_EXPONENT else 'MISS'}, target <= {TARGET_EXPONENT})")
    elif len(fit) > 1:
        print("scaling exponent: not measured (a fit took no longer than the start-up)")


if __name__ == "__main__":
    main()
