"""A batch worker prepares a run for the store without loading the database libraries.

SQLAlchemy and Alembic cost each worker process about 0.6 s of CPU to import: the first stored
batch on a cluster of fresh workers paid it on every worker at once.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import inertest
from inertest.io.data_file import write_table

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "polar_tumble"

_WORKER = """
import pickle, sys
from pathlib import Path
from inertest.app.batch import BatchOptions, BatchTask, compute
prepared = compute(BatchTask(Path(sys.argv[1]), Path(sys.argv[2])), BatchOptions(store=True))
assert prepared.record is not None and prepared.record.estimates
loaded = [m for m in ("sqlalchemy", "alembic") if m in sys.modules]
assert not loaded, loaded
sys.stdout.buffer.write(pickle.dumps(prepared))
"""

_DRIVER = """
import pickle, sys
prepared = pickle.loads(sys.stdin.buffer.read())
assert prepared.record.result_json
assert "sqlalchemy" not in sys.modules
from inertest.store import HistoryStore  # the driver's store: now, and only now
assert "sqlalchemy" in sys.modules
"""


def test_a_worker_prepares_a_stored_run_without_the_database_libraries(tmp_path):
    data = tmp_path / "tumble.csv"
    write_table(data, inertest.simulate(EXAMPLES / "plan.toml", EXAMPLES / "truth.toml",
                                        noise=0.002, rng=1))
    worker = subprocess.run([sys.executable, "-c", _WORKER, str(EXAMPLES / "plan.toml"),
                             str(data)], capture_output=True, timeout=300)
    assert worker.returncode == 0, worker.stderr.decode()[-2000:]
    driver = subprocess.run([sys.executable, "-c", _DRIVER], input=worker.stdout,
                            capture_output=True, timeout=300)
    assert driver.returncode == 0, driver.stderr.decode()[-2000:]
