"""Calibration history database (SQLAlchemy; SQLite by default, any SQLAlchemy URL works).

Every ``inertest fit`` stores its result unless ``--no-store``. The database location is, in order:
``--db URL_OR_PATH``, the environment variable ``INERTEST_DB``, else
``$XDG_DATA_HOME/inertest/history.db`` (``~/.local/share/inertest/history.db``). The schema is
managed with Alembic migrations (``inertest/store/migrations``), applied automatically on open.
"""

from typing import TYPE_CHECKING, Any

# What needs no database (records, labels) comes from inertest.store.records; the store itself
# (SQLAlchemy, Alembic: 0.6 s of CPU to import) only when it is asked for, so that a batch
# worker preparing a run's record does not load it.
from inertest.store.records import RunRecord, StoredEstimate, StoreError, check_label

if TYPE_CHECKING:
    from inertest.store.history import (
        HistoryStore,
        default_database_url,
        resolve_database_url,
    )

_FROM_HISTORY = ("HistoryStore", "default_database_url", "resolve_database_url")


def __getattr__(name: str) -> Any:
    if name in _FROM_HISTORY:
        from inertest.store import history

        return getattr(history, name)
    raise AttributeError(f"module 'inertest.store' has no attribute {name!r}")


__all__ = [
    "HistoryStore",
    "RunRecord",
    "StoreError",
    "StoredEstimate",
    "check_label",
    "default_database_url",
    "resolve_database_url",
]
