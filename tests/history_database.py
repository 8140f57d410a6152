"""History databases as an older inertest left them (tests of migrations and archives)."""

from __future__ import annotations

from pathlib import Path


def database_at_revision(path: Path, revision: str) -> None:
    """Create the SQLite history database ``path`` migrated only up to ``revision``."""
    from alembic import command
    from alembic.config import Config

    from inertest.store.history import _MIGRATIONS, _create_engine

    engine = _create_engine("sqlite:///" + str(path), "sqlite")
    cfg = Config()
    cfg.set_main_option("script_location", str(_MIGRATIONS))
    try:
        with engine.begin() as conn:
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, revision)
    finally:
        engine.dispose()
