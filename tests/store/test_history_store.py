"""The history database: round trip, errors, migrations, concurrent writers."""

import contextlib
import sqlite3
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
import sqlalchemy as sa
from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext

from child_processes import barrier, processes, queue
from history_database import database_at_revision
from inertest.store import HistoryStore, RunRecord, StoreError
from inertest.store.schema import Base

IDENTIFICATION = {
    "coefficients": {"DI": {"value": 0.85, "std": 0.002, "unit": "deg/h/g"}},
    "combinations": [{"name": "DOO - DII", "terms": {"DOO": 1.0, "DII": -1.0}, "value": -0.07,
                      "std": 0.008, "unit": "deg/h/g^2"}],
    "noise": {"sigma": 0.02, "unit": "deg/h", "source": "residuals"},
    "residual_rms": {"value": 0.0016, "unit": "mA"},
    "dof": 311,
    "n_observations": 320,
}
RESULT = {
    "kind": "polar-tumble",
    "schema_version": 2,
    "site": {"latitude_deg": 34.246, "gravity_m_s2": 9.7966},
    "instrument": None,
    "identification": IDENTIFICATION,
    "result": {},
    "checks": [],
    "messages": [],
}


def record(serial="FG-1", days=0, di=0.85):
    ident = dict(IDENTIFICATION, coefficients={"DI": {"value": di, "std": 0.002,
                                                      "unit": "deg/h/g"}})
    res = dict(RESULT, identification=ident)
    return RunRecord.from_result(
        res, serial=serial, instrument_kind="sdf-gyro", plan_text="[site]\n",
        data_sha256="ab" * 32, software_version="0.1.0",
        tested_at=datetime(2026, 1, 1, tzinfo=UTC) + timedelta(days=days))


def bad_record(days=0):
    """A record whose one estimate has no name: the database refuses its estimate row."""
    r = record(days=days)
    return RunRecord(**{**r.__dict__, "estimates": (
        type(r.estimates[0])(**{**r.estimates[0].__dict__, "name": None}),)})


def test_round_trip_in_time_order(db_url):
    store = HistoryStore(db_url)
    store.add(record(days=10, di=0.86))
    store.add(record(days=0, di=0.85))
    store.add(record(serial="FG-2"))
    runs = store.runs("FG-1")
    assert [r.tested_at.day for r in runs] == [1, 11]
    assert runs[0].estimates[0].value == 0.85 and runs[0].estimates[0].unit == "deg/h/g"
    assert runs[0].estimates[1].terms == {"DOO": 1.0, "DII": -1.0}
    assert runs[1].result["identification"]["dof"] == 311 and runs[1].noise_sigma == 0.02
    assert store.serials() == ["FG-1", "FG-2"]
    with pytest.raises(StoreError, match='no runs stored for serial "FG-9".*FG-1, FG-2'):
        store.runs("FG-9")
    store.close()


def test_migrations_build_exactly_the_orm_schema(db_url):
    store = HistoryStore(db_url, create=True)
    with store.engine.connect() as conn:
        diffs = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    assert diffs == []
    store.close()


def test_newer_schema_is_refused(db_url):
    HistoryStore(db_url, create=True).close()
    engine = sa.create_engine(db_url)
    with engine.begin() as conn:
        conn.execute(sa.text("UPDATE alembic_version SET version_num = '9999'"))
    engine.dispose()
    with pytest.raises(StoreError, match="schema revision 9999, newer than this inertest"):
        HistoryStore(db_url)


def test_unreachable_database_names_the_url_without_password():
    with pytest.raises(StoreError, match=r"cannot open.*u:\*\*\*@127\.0\.0\.1:1/db") as exc:
        HistoryStore("postgresql+psycopg://u:secret@127.0.0.1:1/db")
    assert "secret" not in str(exc.value)
    with pytest.raises(StoreError, match="cannot open"):
        HistoryStore("sqlite:////nonexistent-dir/sub/h.db")


def test_missing_serial_cannot_be_stored():
    with pytest.raises(StoreError, match="no \\[instrument\\] serial"):
        RunRecord.from_result(RESULT, serial="", instrument_kind="sdf-gyro", plan_text="",
                              data_sha256="", software_version="0")


def test_a_run_whose_estimates_fail_stores_nothing(db_url):
    """One run, one transaction: the runs row goes when an estimate row is refused."""
    store = HistoryStore(db_url)
    store.add(record(days=0))
    with pytest.raises(StoreError, match="could not store the run"):
        store.add(bad_record(days=1))
    # the same run refused as a duplicate, then filed: the pooled connection still works
    assert store.add(record(days=0), refuse_same_data=True) == store.runs("FG-1")[0].run_uuid
    store.add(record(days=2))
    runs = store.runs("FG-1")
    assert [r.tested_at.day for r in runs] == [1, 3]
    assert all(len(r.estimates) == 2 for r in runs)
    store.close()


def test_a_failed_first_run_never_removes_a_database_another_process_made(tmp_path,
                                                                          monkeypatch):
    """Two stores meet at a new file: the one whose first run fails takes nobody's runs with it.

    The other store creates the file and files a run while the first is still making its own
    database; that first run then fails (or is stored, into the other's file).
    """
    import inertest.store.history as h

    path = tmp_path / "new.db"
    real = h._migrate_engine
    other = HistoryStore(str(path))

    busy = []

    def meanwhile(engine, shown):  # while this store makes its file, another makes it first
        real(engine, shown)
        if not path.exists() and not busy:
            busy.append(1)  # the other's own making of the file comes through here too
            other.add(record(serial="THEIRS"))

    monkeypatch.setattr(h, "_migrate_engine", meanwhile)
    with pytest.raises(StoreError, match="could not store the run"):
        HistoryStore(str(path)).add(bad_record(days=1))
    assert [r.serial for r in HistoryStore(str(path)).runs("THEIRS")] == ["THEIRS"]
    path.unlink()
    for suffix in ("-wal", "-shm"):
        Path(str(path) + suffix).unlink(missing_ok=True)
    other.close()
    busy.clear()
    other = HistoryStore(str(path))
    mine = HistoryStore(str(path))
    assert mine.add(record()) is None  # stored in the other's file, not lost with its own
    assert len(mine.runs("FG-1")) == 1 and len(mine.runs("THEIRS")) == 1
    assert not list(tmp_path.glob(".*inertest-tmp*"))
    other.close()
    mine.close()


def _racer(url: str, bad: bool, n: int, start) -> None:
    start.wait(120)
    store = HistoryStore(url)
    if bad:
        with contextlib.suppress(StoreError):
            store.add(bad_record(days=999))
    else:
        for i in range(n):
            store.add(record(days=i))
    store.close()


@pytest.mark.slow
def test_racing_first_writers_of_a_new_file_lose_no_acknowledged_run(tmp_path):
    """Real processes: two file 10 runs each into a new file while a third's first run fails."""
    for k in range(4):
        url = "sqlite:///" + str(tmp_path / f"race{k}.db")
        start = barrier(3)
        with processes(_racer, [(url, bad, 10, start) for bad in (True, False, False)]) as procs:
            pass
        assert [p.exitcode for p in procs] == [0, 0, 0]
        store = HistoryStore(url)
        assert len(store.runs("FG-1")) == 20, k
        store.close()


def _same_data_writer(url: str, data_sha256: str, start, out) -> None:
    store = HistoryStore(url)
    store.serials()  # connected before the start
    start.wait(120)  # open and connected: all add at once
    out.put(store.add(RunRecord(**{**record().__dict__, "data_sha256": data_sha256}),
                      refuse_same_data=True))
    store.close()


@pytest.mark.slow
def test_writers_of_the_same_data_at_once_store_it_once(db_url):
    """Six processes file the same run with refuse_same_data: one stores it, five are told."""
    HistoryStore(db_url, create=True).close()
    for k in range(3):
        start, out, sha = barrier(6), queue(), f"{k:02d}" * 32
        with processes(_same_data_writer, [(db_url, sha, start, out)] * 6):
            got = [out.get(timeout=120) for _ in range(6)]
        store = HistoryStore(db_url)
        runs = [r for r in store.runs("FG-1") if r.data_sha256 == sha]
        store.close()
        assert len(runs) == 1, (k, len(runs))
        assert sorted(got, key=lambda x: x is not None) == [None] + [runs[0].run_uuid] * 5


def _writer(url: str, start: int, n: int) -> None:
    store = HistoryStore(url)
    for i in range(n):
        store.add(record(days=start + i))
    store.close()


def test_concurrent_writers_lose_nothing(db_url):
    with processes(_writer, [(db_url, k * 100, 15) for k in range(3)]) as procs:
        pass
    assert [p.exitcode for p in procs] == [0, 0, 0]
    store = HistoryStore(db_url)
    runs = store.runs("FG-1")
    assert len(runs) == 45 and len({r.run_uuid for r in runs}) == 45
    assert all(len(r.estimates) == 2 for r in runs)
    store.close()


def test_a_user_file_is_never_turned_into_a_database(tmp_path):
    empty = tmp_path / "notes.txt"
    empty.write_bytes(b"")
    with pytest.raises(StoreError, match="not a SQLite database"):
        HistoryStore(str(empty))
    assert empty.read_bytes() == b""


def test_missing_driver_and_garbled_urls_are_clean_errors():
    with pytest.raises(StoreError, match="no database driver"):
        HistoryStore("mysql://carol:secret@127.0.0.1:1/x")
    with pytest.raises(StoreError) as exc:
        HistoryStore("postgresql://dave:Pa:ss@w@rd@host:notaport/x")
    assert "ss@w" not in str(exc.value)


def test_a_new_database_appears_whole(tmp_path, monkeypatch):
    """Created in a temporary file and linked into place: a crash never leaves a table-less file."""
    import inertest.store.history as h

    path = tmp_path / "new.db"
    store = HistoryStore(str(path))
    assert not path.exists()

    def crash(engine, shown):
        raise KeyboardInterrupt

    monkeypatch.setattr(h, "_migrate_engine", crash)
    with pytest.raises(KeyboardInterrupt):
        store.add(record())
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    monkeypatch.undo()
    store = HistoryStore(str(path))
    store.add(record())
    assert len(store.runs("FG-1")) == 1
    store.close()


def _read_only_storage(folder, monkeypatch):
    """Make ``folder`` unwritable: by its permissions, and for root (whom they do not stop)
    also as the store sees it."""
    import os

    from inertest.store import history

    for p in folder.iterdir():
        p.chmod(0o444)
    folder.chmod(0o555)
    if os.geteuid() == 0:
        monkeypatch.setattr(history, "_writable", lambda path: False)


@pytest.mark.parametrize("name", ["h.db", "a b#1.db"])
def test_a_database_on_read_only_storage_is_read_read_only(tmp_path, monkeypatch, name):
    """Issue 34: on read-only storage the WAL database could not be opened at all (its -shm
    index cannot be created there). It is now opened read-only: nothing written beside it."""
    folder = tmp_path / "archive"
    folder.mkdir()
    url = "sqlite:///" + str(folder / name)
    store = HistoryStore(url)
    store.add(record(days=0, di=0.85))
    store.add(record(days=3, di=0.86))
    store.close()
    before = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in folder.iterdir()}
    _read_only_storage(folder, monkeypatch)
    try:
        ro = HistoryStore(url)
        runs = ro.runs("FG-1")
        assert [r.estimates[0].value for r in runs] == [0.85, 0.86]
        assert ro.serials() == ["FG-1"] and ro.runs_with_data("FG-1", "polar-tumble", "x") == []
        with pytest.raises(StoreError, match="read-only storage; store the run elsewhere"):
            ro.add(record(days=5))
        ro.close()
        after = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in folder.iterdir()}
        assert after == before  # no -shm, no -wal, not a byte changed
    finally:
        folder.chmod(0o755)


def test_an_old_schema_on_read_only_storage_names_the_fix(tmp_path, monkeypatch):
    folder = tmp_path / "archive"
    folder.mkdir()
    url = "sqlite:///" + str(folder / "h.db")
    HistoryStore(url, create=True).close()
    engine = sa.create_engine(url)
    with engine.begin() as conn:
        conn.execute(sa.text("UPDATE alembic_version SET version_num = '0001_old'"))
    engine.dispose()
    _read_only_storage(folder, monkeypatch)
    try:
        with pytest.raises(StoreError, match="read-only storage and has schema revision "
                           "0001_old.*open it once where it can be written"):
            HistoryStore(url)
    finally:
        folder.chmod(0o755)


def test_a_database_of_revision_0003_on_read_only_storage_is_read(tmp_path, monkeypatch):
    """0004 only added an index: an archive written before it reads as it is."""
    folder = tmp_path / "archive"
    folder.mkdir()
    path = folder / "h.db"
    database_at_revision(path, "0003")
    with sqlite3.connect(path) as con:  # a run as inertest 0003 filed it
        columns = [r[1] for r in con.execute("PRAGMA table_info(runs)")]
    store = HistoryStore(str(folder / "elsewhere.db"))
    store.add(record(di=0.87))
    store.close()
    with sqlite3.connect(folder / "elsewhere.db") as src, sqlite3.connect(path) as dst:
        rows = src.execute(f"SELECT {', '.join(columns)} FROM runs").fetchall()
        dst.executemany(f"INSERT INTO runs ({', '.join(columns)}) VALUES "
                        f"({', '.join('?' * len(columns))})", rows)
        est = [r[1] for r in src.execute("PRAGMA table_info(estimates)")]
        dst.executemany(f"INSERT INTO estimates ({', '.join(est)}) VALUES "
                        f"({', '.join('?' * len(est))})",
                        src.execute(f"SELECT {', '.join(est)} FROM estimates").fetchall())
    (folder / "elsewhere.db").unlink()
    for suffix in ("-wal", "-shm"):
        Path(str(folder / "elsewhere.db") + suffix).unlink(missing_ok=True)
    _read_only_storage(folder, monkeypatch)
    try:
        ro = HistoryStore(str(path))
        assert [r.estimates[0].value for r in ro.runs("FG-1")] == [0.87]
        ro.close()
    finally:
        folder.chmod(0o755)


def test_finding_a_run_of_the_same_data_uses_its_index(tmp_path):
    """The look-up made at every filing reads the index, not every run of the serial."""
    from inertest.store.history import _statements

    store = HistoryStore(str(tmp_path / "h.db"), create=True)
    sql = _statements(store.engine.dialect)
    text, params = sql.same_data(serial="FG-1", procedure="polar-tumble", data_sha256="ab" * 32)
    with store.engine.connect() as conn:
        plan = " ".join(str(r[-1]) for r in conn.exec_driver_sql("EXPLAIN QUERY PLAN " + text,
                                                                 params))
    assert "ix_runs_same_data" in plan, plan
    store.close()
