"""Run every benchmark in this folder (``make bench``), each as its own ``python bench_*.py``.

Each runs in a process of its own, as a script: its process pools can then import the
functions they are given (a module loaded from a file path cannot be found by a pool's
workers), and one benchmark's memory and threads do not weigh on the next's figures.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path


def main() -> int:
    here = Path(__file__).resolve().parent
    failed = []
    for path in sorted(here.glob("bench_*.py")):
        print(f"\n=== {path.name} ===", flush=True)
        t0 = time.perf_counter()
        rc = subprocess.call([sys.executable, str(path)])
        if rc:
            failed.append(path.name)
        print(f"({path.name}: {time.perf_counter() - t0:.1f} s in all"
              f"{'' if rc == 0 else f', FAILED with exit status {rc}'})", flush=True)
    if failed:
        print(f"\nfailed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
