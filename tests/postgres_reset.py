"""Empty the PostgreSQL test database: every table the schema holds, whatever migration made it."""

from __future__ import annotations

import sqlalchemy as sa


def reset_postgres(url: str) -> None:
    """Drop every table of the database at ``url`` (reflected, so a new migration needs no edit).

    A fixed list of names went stale when migration 0003 added ``campaigns``: the next test's
    upgrade then failed on "relation already exists".
    """
    engine = sa.create_engine(url)
    try:
        with engine.begin() as conn:
            meta = sa.MetaData()
            meta.reflect(conn)
            meta.drop_all(conn)
    finally:
        engine.dispose()
