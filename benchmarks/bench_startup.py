"""Start-up time of the command line, as a ratio against ``python -c "import numpy"`` (issue 18).

Target (issue 18): ``inertest --help`` and every command's ``--help`` within 2x of importing
numpy (under 0.3 s): plotting, databases, pandas, scipy.stats, rich and numba load only in the
commands that use them. A ``fit --no-store --json`` of a tiny file is printed beside them with
its ratio and no verdict: it is not an issue 18 target (the issue's 3.1 s start of a 1e4-row fit
is now about 0.5 s, most of it importing scipy.linalg and scipy.special, which the fit needs).
Each line is the best of several fresh processes, wall time and the child's CPU time (user +
system, from ``resource.getrusage``), so that a loaded machine shows in the wall time
only. PASS/MISS on the CPU-time ratio (the wall ratio beside it).

Run: ``python benchmarks/bench_startup.py [REPEATS]`` (default 7).
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from inertest.cli import _COMMANDS

#: PASS when the start-up costs at most this multiple of ``python -c "import numpy"``.
TARGET_RATIO = 2.0
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "gyro_rate_table"


def _best(argv: Sequence[str], repeats: int) -> tuple[float, float]:
    """Best wall and best CPU time [s] of ``argv`` in a fresh process."""
    import time

    wall = cpu = float("inf")
    for _ in range(repeats):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = min(wall, time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = min(cpu, r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
    return wall, cpu


def main(argv: Sequence[str] = ()) -> None:
    repeats = int(argv[0]) if argv else 7
    py = sys.executable
    exe = str(Path(py).parent / "inertest")
    floor_wall, floor_cpu = _best([py, "-c", "import numpy"], repeats)
    print(f"python -c 'import numpy' (the floor): {floor_wall * 1e3:.0f} ms wall, "
          f"{floor_cpu * 1e3:.0f} ms CPU; target <= {TARGET_RATIO:g}x")
    cases: list[tuple[str, list[str]]] = [("inertest --help", ["--help"])]
    cases += [(f"inertest {name} --help", [name, "--help"]) for name in _COMMANDS]
    with tempfile.TemporaryDirectory() as tmp:
        data = str(Path(tmp) / "data.csv")
        subprocess.run([exe, "simulate", str(EXAMPLE / "plan.toml"), "--truth",
                        str(EXAMPLE / "truth.toml"), "-o", data], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        cases.append(("inertest fit --no-store --json (tiny)",
                      ["fit", str(EXAMPLE / "plan.toml"), data, "--no-store", "--json"]))
        missed = judged = 0
        for label, args in cases:
            wall, cpu = _best([exe, *args], repeats)
            target = "--help" in args
            ok = cpu <= TARGET_RATIO * floor_cpu
            missed += target and not ok
            judged += target
            verdict = ("PASS" if ok else "MISS") if target else "(not a target)"
            print(f"{label:44s} {wall * 1e3:6.0f} ms wall ({wall / floor_wall:4.1f}x)  "
                  f"{cpu * 1e3:6.0f} ms CPU ({cpu / floor_cpu:4.1f}x)  {verdict}")
    print(f"{judged - missed} of {judged} --help within {TARGET_RATIO:g}x of import numpy")


if __name__ == "__main__":
    main(sys.argv[1:])
