"""Calibration history database (SQLAlchemy; SQLite by default, any SQLAlchemy URL works).

Every ``inertest fit`` stores its result unless ``--no-store``. The database location is, in order:
``--db URL_OR_PATH``, the environment variable ``INERTEST_DB``, else
``$XDG_DATA_HOME/inertest/history.db`` (``~/.local/share/inertest/history.db``). The schema is
managed with Alembic migrations (``inertest/store/migrations``), applied automatically on open.
"""

from inertest.store.history import (
    HistoryStore,
    RunRecord,
    StoredEstimate,
    StoreError,
    check_label,
    default_database_url,
    resolve_database_url,
)

__all__ = [
    "HistoryStore",
    "RunRecord",
    "StoreError",
    "StoredEstimate",
    "check_label",
    "default_database_url",
    "resolve_database_url",
]
