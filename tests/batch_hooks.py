"""Test-only pool-worker initialiser: a fit that kills or hangs its worker process.

Imported by name in forkserver pool workers (``tests/`` is on ``sys.path`` there too): runs whose
plan names the instrument serial ``DIE`` end their worker with SIGKILL, as the kernel's
out-of-memory killer would; serial ``HANG`` sleeps for ten minutes. Every other run fits as usual.
"""

from __future__ import annotations

import os
import signal
import time
from typing import Any


def deadly_fit() -> None:
    """Pool initializer: replace ``inertest.app.batch.fit`` in this worker only."""
    import inertest.app.batch as runner

    real = runner.fit

    def fit(plan: Any, data: Any, **kw: Any) -> Any:
        serial = plan.instrument.serial
        if serial == "DIE":
            os.kill(os.getpid(), signal.SIGKILL)
        if serial == "HANG":
            time.sleep(600)
        return real(plan, data, **kw)

    runner.fit = fit
