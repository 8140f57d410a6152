"""Storing fit results and reading an instrument's history back.

Writes are single transactions, so a failed fit or a crash stores nothing half-way. SQLite
databases use WAL journaling, a busy timeout and ``BEGIN IMMEDIATE`` so that concurrent writers
(two fits at once) queue instead of failing or losing data. The schema is migrated with Alembic
on open; a database written by a newer inertest (an unknown revision) is refused. A SQLite file
that does not exist yet is created only when the first run is stored, so a command that fails,
or only reads, leaves no empty database behind. A SQLite file on storage this process cannot
write (a read-only mount, an archive) is opened read-only, so ``inertest history`` still reads
it. Serials are checked the same way on every backend (:func:`check_label`): printable text of
at most 200 characters.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import operator
import os
import uuid
from collections.abc import Iterator, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, cast

import sqlalchemy as sa
from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import event, select
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.exc import (
    ArgumentError,
    NoSuchModuleError,
    SQLAlchemyError,
)
from sqlalchemy.orm import Session, selectinload

from inertest.errors import InputError
from inertest.results import read_envelope
from inertest.store.records import (
    RunRecord,
    StoredEstimate,
    StoreError,
    as_utc,
    check_label,
    envelope_json,
)
from inertest.store.schema import EstimateRow, Run

ENV_VAR = "INERTEST_DB"
#: Columns of ``runs`` that a :class:`RunRecord` carries under the same name.
_RUN_FIELDS = (
    "run_uuid", "serial", "instrument_kind", "procedure", "tested_at", "software_version",
    "latitude_deg", "gravity_m_s2", "plan_text", "data_sha256", "n_observations",
    "residual_rms", "residual_unit", "noise_sigma", "noise_unit", "dof",
)
_MIGRATIONS = Path(__file__).resolve().parent / "migrations"
#: Older revisions whose tables are the newest's (later migrations only added indexes): a
#: database at one of them is read as it is on read-only storage.
_READS_AS_NEWEST = frozenset({"0003"})


def default_database_url() -> str:
    """``sqlite:///`` URL of ``$XDG_DATA_HOME/inertest/history.db`` (``~/.local/share/...``)."""
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return "sqlite:///" + str(Path(base) / "inertest" / "history.db")


def resolve_database_url(db: str | None = None) -> str:
    """The database URL: ``db`` (a URL or a file path), else ``$INERTEST_DB``, else the default."""
    value = db or os.environ.get(ENV_VAR) or default_database_url()
    if "://" not in value:
        value = "sqlite:///" + str(Path(value).expanduser().resolve())
    return value


class HistoryStore:
    """The calibration history at ``url`` (created and migrated on first use).

    Parameters
    ----------
    url : str
        SQLAlchemy URL (``sqlite:///path.db``, ``postgresql+psycopg://user:pw@host/db``) or a path.

    create : bool
        Create (and migrate) a new SQLite file now rather than at the first :meth:`add`.

    Notes
    -----
    A SQLite file that does not exist is not created here but by the first :meth:`add`; until
    then the store reads as empty. That first run is stored in the new file before it appears
    under its name, so a first run that fails leaves no database, and no process ever removes
    a database another process can see (when two make the same file at once, the second's
    run goes into the first's).
    """

    def __init__(self, url: str | None = None, *, create: bool = False) -> None:
        self.url = resolve_database_url(url)
        try:
            parsed = make_url(self.url)
        except (ArgumentError, ValueError):
            raise StoreError("not a database URL or path: "
                             f"{_mask(self.url)!r}") from None
        self._shown = parsed.render_as_string(hide_password=True)
        backend = parsed.get_backend_name()
        database = parsed.database or ""
        #: The SQLite file (None for other backends and in-memory databases).
        self.path: Path | None = (
            Path(database) if backend == "sqlite" and database not in ("", ":memory:")
            and not database.startswith("file:") else None)
        self._is_default = backend == "sqlite" and self.url == resolve_database_url(
            default_database_url())
        try:
            self.engine = _create_engine(self.url, backend)
        except (NoSuchModuleError, ModuleNotFoundError) as exc:
            hint = ("pip install 'inertest[postgres]'" if backend == "postgresql"
                    else "install it")
            raise StoreError(f"no database driver for {self._shown}: {_reason(exc)}; {hint}, "
                             "or use a sqlite:/// path or postgresql+psycopg:// URL") from None
        except (ArgumentError, TypeError, ValueError) as exc:
            raise StoreError(f"unusable database URL {self._shown}: {_reason(exc)}") from None
        self._ready = False
        self._read_only = False
        if (self.path is not None and not self._is_default
                and not self.path.expanduser().parent.is_dir()):
            raise StoreError(f"cannot open the history database {self._shown}: its folder "
                             f"{self.path.parent} does not exist; check --db or ${ENV_VAR}, or "
                             "use --no-store")
        if self.path is not None and self.path.exists():
            _check_sqlite_file(self.path, self._shown)
        if create or self.path is None or self.path.exists():
            self._open()

    def _open(self, first: RunRecord | None = None) -> bool:
        """Open (creating a new SQLite file); True when ``first`` was stored in the new file.

        ``first`` goes into a new file before it appears (a run that fails leaves no
        database); when the file exists, or another process made it meanwhile, it is not
        stored here.
        """
        made = False
        if self.path is not None and self._is_default:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.path is not None and not self.path.exists():
            made = self._create_sqlite_file(self.path, first=first) and first is not None
        if self.path is not None and not _writable(self.path):
            self._open_read_only(self.path)
            return made
        try:
            self._migrate()
        except SQLAlchemyError as exc:
            self.engine.dispose()
            raise StoreError(
                f"cannot open the history database {self._shown}: {_reason(exc)}; "
                f"check --db or ${ENV_VAR}, or use --no-store"
            ) from None
        except BaseException:
            self.engine.dispose()
            raise
        self._ready = True
        return made

    def _open_read_only(self, path: Path) -> None:
        """Open a SQLite file on storage this process cannot write, for reading only.

        A WAL database needs its ``-shm`` index, which read-only storage cannot hold: with no
        write-ahead log left beside it (every writer closed, so all is in the file) the file is
        opened ``immutable`` (no locks, no ``-shm``); with one it is opened ``mode=ro``, which
        SQLite can do when the ``-shm`` exists too. Nothing is migrated: a database of an older
        schema must be opened once where it can be written.
        """
        self.engine.dispose()
        wal = Path(str(path) + "-wal")
        immutable = not (wal.exists() and wal.stat().st_size > 0)
        self.engine = _create_engine("sqlite://", "sqlite",
                                     read_only=_read_only_uri(path, immutable=immutable))
        self._read_only = True
        try:
            _check_revision(self.engine, self._shown)
        except SQLAlchemyError as exc:
            self.engine.dispose()
            raise StoreError(
                f"cannot read the history database {self._shown} on read-only storage: "
                f"{_reason(exc)}; copy it (with any -wal and -shm files beside it) to writable "
                "storage and give that path with --db") from None
        self._ready = True

    def _create_sqlite_file(self, path: Path, first: RunRecord | None = None) -> bool:
        """Create a new SQLite database whole: migrated in a temporary file, then linked.

        A kill at any point leaves either no database or a complete one, never a file
        without tables. ``first``: the run to store in it before it appears, so that a first
        run that fails leaves no database and no other process ever sees one that may yet be
        removed. False when another process created the database first (``first`` is then
        not stored: store it in theirs).
        """
        # unique: two stores of one process may make the same file at once
        tmp = path.with_name(f".{path.name}.inertest-tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}.db")
        engine = _create_engine("sqlite:///" + str(tmp), "sqlite")
        try:
            _migrate_engine(engine, self._shown)
            if first is not None:
                self._add(first, False, engine)
            engine.dispose()  # closing the last connection checkpoints the WAL into the file
            try:
                os.link(tmp, path)  # never replaces a database another writer just created
            except FileExistsError:
                return False
            return True
        finally:
            engine.dispose()
            for suffix in ("", "-wal", "-shm", "-journal"):
                Path(str(tmp) + suffix).unlink(missing_ok=True)

    def _readable(self) -> bool:
        """Open the database for reading if it exists; False if there is none yet."""
        if not self._ready:
            if self.path is not None and not self.path.exists():
                return False
            self._open()
        return True

    @property
    def display_url(self) -> str:
        """The database URL with any password masked (for messages and logs)."""
        return self._shown

    def _migrate(self) -> None:
        _migrate_engine(self.engine, self._shown)

    def add(self, record: RunRecord, *, refuse_same_data: bool = False) -> str | None:
        """Store one run and its estimates in a single transaction (creating a new database).

        With ``refuse_same_data``, a run of the same serial and procedure made from the same
        data (SHA-256) already stored is looked for in that same transaction: its UUID is
        returned and nothing is stored. Returns None when the run was stored.
        """
        check_label(record.serial, "serial")
        if self._read_only:
            raise StoreError(f"the history database {self._shown} is on read-only storage; "
                             "store the run elsewhere with --db, or use --no-store")
        self._created = None
        if not self._ready and self._open(first=record):
            self._created = self.path  # the run came with the new file
            return None
        return self._add(record, refuse_same_data)

    def discard(self, run_uuid: str) -> None:
        """Undo :meth:`add` of ``run_uuid`` (a later step of the same transaction failed).

        Removes the run and its estimates; a SQLite file created by that add is removed whole
        when it holds no other run (another process may have filed into it since).
        """
        created = getattr(self, "_created", None)
        try:
            with Session(self.engine) as session, session.begin():
                run = session.scalars(select(Run).where(Run.run_uuid == run_uuid)).first()
                if run is not None:
                    session.delete(run)
                    session.flush()
                if created is not None and session.scalars(select(Run.id).limit(1)).first():
                    created = None  # another process's runs are in it now: keep the file
        except SQLAlchemyError as exc:
            raise StoreError(f"could not withdraw run {run_uuid} from {self._shown}: "
                             f"{_reason(exc)}") from None
        if created is not None:
            self._remove_new_file(created)
            self._created = None

    def _remove_new_file(self, path: Path | None) -> None:
        """Remove a SQLite file (and its WAL) that this store created for a failed first add."""
        if path is None:
            return
        self.engine.dispose()
        self._ready = False
        for suffix in ("", "-wal", "-shm", "-journal"):
            Path(str(path) + suffix).unlink(missing_ok=True)

    def _add(self, record: RunRecord, refuse_same_data: bool,
             engine: Engine | None = None) -> str | None:
        # The statements are compiled once for the engine's dialect and run on the driver's
        # own cursor, one transaction a run: a run costs the filing process about 0.2 ms (the
        # ORM's unit of work took 10 ms, SQLAlchemy Core's statement execution 0.8 ms and its
        # Connection with driver SQL 0.45 ms), so that one process keeps up with the fits of
        # many workers. The connection still comes from the engine's pool (pre-pinged on
        # PostgreSQL), so a server restart between two runs costs neither of them.
        engine = self.engine if engine is None else engine
        sql = _statements(engine.dialect)
        values = {f: getattr(record, f) for f in _RUN_FIELDS}
        values["stored_at"] = record.filed_at or datetime.now(UTC)
        values["result_json"] = record.result_json or envelope_json(record.result)
        estimates = [sql.estimate.params(
            run_id=None, name=e.name, kind=e.kind, value=e.value, std=e.std, unit=e.unit,
            terms_json=None if e.terms is None else json.dumps(dict(e.terms)))
            for e in record.estimates]
        raw: Any = None
        try:
            raw = engine.raw_connection()
            cur = raw.cursor()
            try:
                if engine.dialect.name == "sqlite":
                    # the write lock at once: concurrent writers queue (busy timeout) instead
                    # of failing on lock upgrade (pysqlite runs in autocommit mode here)
                    cur.execute("BEGIN IMMEDIATE")
                if refuse_same_data and sql.same_data_lock is not None:
                    # PostgreSQL (READ COMMITTED): two writers of the same data would both
                    # find none and both insert; a lock on the (serial, procedure, data)
                    # held to the end of the transaction makes the second wait and find it
                    cur.execute(*sql.same_data_lock(key=_data_key(
                        record.serial, record.procedure, record.data_sha256)))
                if refuse_same_data:
                    cur.execute(*sql.same_data(serial=record.serial,
                                               procedure=record.procedure,
                                               data_sha256=record.data_sha256))
                    row = cur.fetchone()
                    if row is not None:
                        raw.rollback()
                        return str(row[0])
                cur.execute(*sql.run(**values))
                run_id = cur.fetchone()[0]
                if estimates:
                    cur.executemany(sql.estimate.text, [sql.estimate.with_value(
                        p, "run_id", run_id) for p in estimates])
                raw.commit()
            except BaseException:
                with contextlib.suppress(Exception):  # the connection may be gone
                    raw.rollback()
                raise
            finally:
                with contextlib.suppress(Exception):
                    cur.close()
        except (SQLAlchemyError, _driver_error(engine)) as exc:
            raise StoreError(f"could not store the run in {self._shown}: {_reason(exc)}") from None
        finally:
            if raw is not None:
                raw.close()  # back to the pool
        return None

    def runs_with_data(self, serial: str, procedure: str, data_sha256: str) -> list[str]:
        """UUIDs of stored runs of ``serial`` and ``procedure`` made from the same data file."""
        check_label(serial, "serial")
        if not self._readable():
            return []
        stmt = select(Run.run_uuid).where(
            Run.serial == serial, Run.procedure == procedure, Run.data_sha256 == data_sha256)
        with self._reading():
            with Session(self.engine) as session:
                return list(session.scalars(stmt))

    def serials(self) -> list[str]:
        """Serial numbers with stored runs."""
        if not self._readable():
            return []
        with self._reading():
            with Session(self.engine) as session:
                return list(session.scalars(select(Run.serial).distinct().order_by(Run.serial)))

    def runs(self, serial: str, *, procedure: str | None = None) -> list[RunRecord]:
        """Stored runs of ``serial`` in time order; an unknown serial is an error."""
        check_label(serial, "serial")
        if not self._readable():
            raise StoreError(f'no runs stored for serial "{serial}": there is no history '
                             f"database at {self._shown} yet; check --db or ${ENV_VAR}")
        stmt = (
            select(Run)
            .where(Run.serial == serial)
            .options(selectinload(Run.estimates))
            .order_by(Run.tested_at, Run.id)
        )
        if procedure is not None:
            stmt = stmt.where(Run.procedure == procedure)
        with self._reading():
            with Session(self.engine) as session:
                rows = list(session.scalars(stmt))
                out = [_record(r) for r in rows]
        if not out:
            known = self.serials()
            hint = f"known serials: {', '.join(known)}" if known else "the database is empty"
            raise StoreError(f'no runs stored for serial "{serial}" in {self._shown} ({hint})')
        return out

    def close(self) -> None:
        """Release the connection pool."""
        self.engine.dispose()

    @contextlib.contextmanager
    def _reading(self) -> Iterator[None]:
        """Turn a damaged database or stored document into one :class:`StoreError`."""
        try:
            yield
        except SQLAlchemyError as exc:
            raise StoreError(f"cannot read the history database {self._shown}: {_reason(exc)}; "
                             "it may be damaged: restore it from a backup") from None
        except (ValueError, TypeError, KeyError) as exc:
            raise StoreError(f"the history database {self._shown} holds a damaged run record "
                             f"({type(exc).__name__}: {str(exc)[:100]}); restore it from a "
                             "backup") from None


class _DriverStatement:
    """A Core statement compiled once for a dialect, with the columns' bind conversions."""

    def __init__(self, stmt: Any, dialect: Any, columns: Mapping[str, Any]) -> None:
        compiled = stmt.compile(dialect=dialect, column_keys=list(columns))
        self.text = str(compiled)
        self.order = compiled.positiontup if dialect.positional else None
        self._ordered = None if self.order is None else operator.itemgetter(*self.order)
        self.fixed = {k: v for k, v in compiled.params.items() if k not in columns}  # LIMIT
        self.convert = {k: c.type.bind_processor(dialect) for k, c in columns.items()}
        self.convert = {k: f for k, f in self.convert.items() if f is not None}

    def params(self, **values: Any) -> Any:
        """The values in the driver's parameter style (a tuple, or a mapping), converted."""
        for k, f in self.convert.items():
            if k in values:
                values[k] = f(values[k])
        values.update(self.fixed)
        if self._ordered is None:
            return values
        got = self._ordered(values)
        return got if isinstance(got, tuple) else (got,)  # itemgetter of one key: no tuple

    def __call__(self, **values: Any) -> tuple[str, Any]:
        return self.text, self.params(**values)

    def with_value(self, params: Any, key: str, value: Any) -> Any:
        """``params`` (from :meth:`params`) with ``key`` set to ``value`` (no conversion)."""
        if self.order is None:
            return {**params, key: value}
        k = self.order.index(key)
        return (*params[:k], value, *params[k + 1:])


class _Statements:
    """The statements of :meth:`HistoryStore.add`, compiled for one dialect."""

    def __init__(self, dialect: Any) -> None:
        self.dialect = dialect
        runs = cast(sa.Table, Run.__table__)
        rows = cast(sa.Table, EstimateRow.__table__)
        run_cols = {c.name: c for c in runs.columns if c.name != "id"}
        self.run = _DriverStatement(sa.insert(runs).returning(runs.c.id), dialect, run_cols)
        self.estimate = _DriverStatement(
            sa.insert(rows), dialect, {c.name: c for c in rows.columns if c.name != "id"})
        keys = ("serial", "procedure", "data_sha256")
        key = sa.bindparam("key", type_=sa.BigInteger)
        self.same_data_lock = (_DriverStatement(
            sa.select(sa.func.pg_advisory_xact_lock(key)), dialect, {"key": key})
            if dialect.name == "postgresql" else None)
        self.same_data = _DriverStatement(
            select(runs.c.run_uuid).where(*(runs.c[k] == sa.bindparam(k) for k in keys))
            .limit(1), dialect, {k: runs.c[k] for k in keys})


_COMPILED: dict[Any, _Statements] = {}


def _statements(dialect: Any) -> _Statements:
    """The statements of :meth:`HistoryStore.add`, compiled once for ``dialect``."""
    key = (type(dialect), dialect.positional, dialect.paramstyle)
    if key not in _COMPILED:
        _COMPILED[key] = _Statements(dialect)
    return _COMPILED[key]


def _driver_error(engine: Engine) -> type[Exception]:
    """The database driver's base exception class (PEP 249 ``Error``)."""
    dbapi: Any = getattr(engine.dialect, "loaded_dbapi", None) or engine.dialect.dbapi
    return cast(type[Exception], dbapi.Error)


def _data_key(serial: str, procedure: str, data_sha256: str) -> int:
    """A signed 64-bit key for (serial, procedure, data): PostgreSQL's advisory lock."""
    digest = hashlib.sha256(f"{serial}\0{procedure}\0{data_sha256}".encode()).digest()
    return int.from_bytes(digest[:8], "big", signed=True)


def _migrate_engine(engine: Engine, shown: str) -> None:
    """Bring the schema to the newest revision; refuse a database written by a newer inertest."""
    cfg = Config()
    cfg.set_main_option("script_location", str(_MIGRATIONS))
    script = ScriptDirectory.from_config(cfg)
    known = {rev.revision for rev in script.walk_revisions()}
    with engine.begin() as conn:
        if conn.dialect.name == "postgresql":
            # Serialise concurrent first-time migrations.
            conn.execute(sa.text("SELECT pg_advisory_xact_lock(4242001)"))
        current = MigrationContext.configure(conn).get_current_revision()
        if current is not None and current not in known:
            raise StoreError(
                f"the history database {shown} has schema revision {current}, newer "
                f"than this inertest knows ({', '.join(sorted(known))}); upgrade inertest"
            )
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "head")


def _check_revision(engine: Engine, shown: str) -> None:
    """Refuse a database that is not at this inertest's newest schema (read-only: no migration)."""
    cfg = Config()
    cfg.set_main_option("script_location", str(_MIGRATIONS))
    head = ScriptDirectory.from_config(cfg).get_current_head()
    with engine.connect() as conn:
        current = MigrationContext.configure(conn).get_current_revision()
    if current != head and current not in _READS_AS_NEWEST:
        raise StoreError(
            f"the history database {shown} is on read-only storage and has schema revision "
            f"{current}, not this inertest's {head}; open it once where it can be written (it "
            "is then migrated), or use the inertest that wrote it")


def _writable(path: Path) -> bool:
    """Whether this process may write the SQLite file and create its journal files beside it."""
    return os.access(path, os.W_OK) and os.access(path.parent, os.W_OK | os.X_OK)


def _read_only_uri(path: Path, *, immutable: bool) -> str:
    """SQLite URI opening ``path`` read-only (``mode=ro``, and ``immutable=1`` if asked)."""
    from urllib.parse import quote

    flags = "mode=ro" + ("&immutable=1" if immutable else "")
    return f"file:{quote(str(path.resolve()))}?{flags}"


def _check_sqlite_file(path: Path, shown: str) -> None:
    """Refuse to turn a user's file that is not a SQLite database into one."""
    try:
        with path.open("rb") as fh:
            head = fh.read(16)
    except OSError as exc:
        raise StoreError(f"cannot read the history database {shown}: {exc.strerror}") from None
    if head != b"SQLite format 3\0":
        raise StoreError(f"{path} is not a SQLite database (an empty or other file); give a new "
                         "path with --db, or use --no-store")


def _create_engine(url: str, backend: str, *, read_only: str | None = None) -> Engine:
    """An engine for ``url``; ``read_only``: a SQLite URI (``file:...?mode=ro``) opened as is."""
    if backend != "sqlite":
        return sa.create_engine(url, pool_pre_ping=True)
    if read_only is not None:
        import sqlite3

        engine = sa.create_engine("sqlite://", poolclass=sa.pool.NullPool, creator=lambda: (
            sqlite3.connect(read_only, uri=True, timeout=60, check_same_thread=False)))
    else:
        engine = sa.create_engine(url, connect_args={"timeout": 60})

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, _record: Any) -> None:
        # Let SQLAlchemy emit BEGIN itself (pysqlite's implicit transactions are not used).
        dbapi_connection.isolation_level = None
        cur = dbapi_connection.cursor()
        if read_only is None:  # setting the journal mode writes the file
            cur.execute("PRAGMA journal_mode=WAL")
            # In WAL mode NORMAL syncs the log at checkpoints, not at every commit (which cost
            # 7 ms a run): a committed run survives the process being killed, and a power cut
            # can lose the runs committed since the last checkpoint, never half of one.
            cur.execute("PRAGMA synchronous=NORMAL")
        cur.execute("PRAGMA foreign_keys=ON")
        cur.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn: Any) -> None:
        # IMMEDIATE takes the write lock at once: concurrent writers queue (busy timeout)
        # instead of failing on lock upgrade. A read-only connection only reads.
        conn.exec_driver_sql("BEGIN IMMEDIATE" if read_only is None else "BEGIN")

    return engine


def _record(r: Run) -> RunRecord:
    return RunRecord(
        **{f: getattr(r, f) for f in _RUN_FIELDS if f != "tested_at"},
        tested_at=as_utc(r.tested_at),
        filed_at=as_utc(r.stored_at),
        estimates=tuple(
            StoredEstimate(e.name, e.kind, e.value, e.std, e.unit,
                           None if e.terms_json is None else json.loads(e.terms_json))
            for e in r.estimates
        ),
        result=_stored_envelope(r),
    )


def _stored_envelope(r: Run) -> dict[str, object]:
    """The stored run's envelope, read back through the one schema check.

    Its ``test.filed_at`` is the ``stored_at`` column (runs filed before it was kept there
    only carry it in their text already).
    """
    try:
        doc = read_envelope(json.loads(r.result_json), source=f"stored run {r.run_uuid}")
    except InputError as exc:
        raise StoreError(str(exc)) from None
    test = doc.get("test")
    if isinstance(test, dict) and "filed_at" not in test:
        test["filed_at"] = as_utc(r.stored_at).isoformat(timespec="seconds")
    return doc


def _reason(exc: Exception) -> str:
    orig = getattr(exc, "orig", None)
    text = str(orig if orig is not None else exc).strip().splitlines()
    return _mask(text[0]) if text else type(exc).__name__


def _mask(text: str) -> str:
    """``text`` with the password of any ``scheme://user:password@`` URL in it masked."""
    import re

    return re.sub(r"(://[^\s:/@]*:)([^\s@/]+)(@)", r"\1***\3", text)
