"""Run every benchmark in this folder (``make bench``): each ``bench_*.py`` has a ``main()``."""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path


def main() -> int:
    here = Path(__file__).resolve().parent
    for path in sorted(here.glob("bench_*.py")):
        spec = importlib.util.spec_from_file_location(path.stem, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        print(f"\n=== {path.name} ===", flush=True)
        t0 = time.perf_counter()
        module.main([])
        print(f"({path.name}: {time.perf_counter() - t0:.1f} s in all)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
