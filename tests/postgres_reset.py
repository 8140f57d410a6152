"""Empty the PostgreSQL test database: every table the schema holds, whatever migration made it."""

from __future__ import annotations

import sqlalchemy as sa

#: How long the drop waits for another session's locks before it names them and fails
#: (PostgreSQL's own default is to wait for ever: a session left in a transaction by an
#: earlier test, or by a process it started, would hang the test run with no word).
LOCK_WAIT = "60s"


def reset_postgres(url: str) -> None:
    """Drop every table of the database at ``url`` (reflected, so a new migration needs no edit).

    A fixed list of names went stale when migration 0003 added ``campaigns``: the next test's
    upgrade then failed on "relation already exists".
    """
    engine = sa.create_engine(url)
    try:
        try:
            with engine.begin() as conn:
                conn.exec_driver_sql(f"SET LOCAL lock_timeout = '{LOCK_WAIT}'")
                meta = sa.MetaData()
                meta.reflect(conn)
                meta.drop_all(conn)
        except sa.exc.OperationalError as exc:
            raise RuntimeError(f"could not empty the test database: {exc.orig}; other "
                               f"sessions: {_other_sessions(engine)}") from None
    finally:
        engine.dispose()


def _other_sessions(engine: sa.Engine) -> list[tuple]:
    """The database's other sessions: pid, state, since when in a transaction, last query."""
    with engine.connect() as conn:
        return [tuple(r) for r in conn.exec_driver_sql(
            "SELECT pid, state, xact_start, left(query, 200) FROM pg_stat_activity "
            "WHERE datname = current_database() AND pid <> pg_backend_pid()")]
