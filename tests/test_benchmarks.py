"""The benchmarks run as `make bench` runs them: each its own script, in a process of its own.

A benchmark loaded as a module from its file path could not give its functions to a process
pool (the workers cannot import it): `make bench` stopped at bench_batch.py. Run small here.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.mark.slow
def test_batch_benchmark_runs_as_a_script(tmp_path):
    """4 fits, 1 worker, the replayed machinery on 2: every figure printed, nothing judged."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, str(BENCHMARKS / "bench_batch.py"), "4", "20", "1",
                           "2"], capture_output=True, text=True, timeout=600, cwd=tmp_path,
                          env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    out = done.stdout
    assert "are not judged here" in out and "PASS" not in out and "MISS" not in out
    assert "pool, 1 workers, stored" in out
    assert "pool, 2 workers, stored:" in out  # the replayed fits
    if "dask.distributed not installed" not in out:
        assert "dask, 2 workers, stored:" in out
