"""Ctrl-C on a running batch, as a user presses it: once, or twice in quick succession."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import time
from pathlib import Path

import pytest

from child_processes import INERTEST

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def manifest(tmp_path_factory) -> Path:
    import inertest
    from inertest.io.data_file import write_table

    folder = tmp_path_factory.mktemp("batch")
    plan, truth = EXAMPLES / "polar_tumble" / "plan.toml", EXAMPLES / "polar_tumble" / "truth.toml"
    data = folder / "d.csv"
    write_table(data, inertest.simulate(plan, truth, noise=0.002, rng=5))
    path = folder / "batch.toml"  # one file 300 times: long enough to be interrupted
    path.write_text("".join(f'[[run]]\nplan = "{plan}"\ndata = "{data}"\n' for _ in range(300)))
    return path


def _filed(db: Path) -> int:
    if not db.exists():
        return 0
    with sqlite3.connect(db) as con:
        return con.execute("SELECT count(*) FROM runs").fetchone()[0]


@pytest.mark.slow
@pytest.mark.parametrize("presses", [1, 2])
def test_ctrl_c_ends_a_pool_batch_keeping_whole_runs(manifest, tmp_path, presses):
    """Two presses 0.2 s apart hung the batch for good: the second broke into the pool's
    graceful shutdown, and Python's exit then waited on its idle workers."""
    db = tmp_path / "h.db"
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONWARNINGS": "ignore"}
    proc = subprocess.Popen([*INERTEST, "batch", str(manifest), "--workers", "2", "--db",
                             str(db), "--allow-duplicate", "--no-progress"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        for _ in range(600):  # interrupted while it files
            if _filed(db) >= 5:
                break
            time.sleep(0.1)
        for _ in range(presses):
            os.killpg(proc.pid, signal.SIGINT)  # the terminal sends it to the whole group
            time.sleep(0.2)
        err = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode in (130, -signal.SIGINT), (proc.returncode, err)
    assert "aborted" in err and "Traceback" not in err, err
    assert 5 <= _filed(db) < 300
