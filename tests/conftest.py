"""Shared fixtures: paths to the examples and to ../shared/realdata."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def examples_dir() -> Path:
    return REPO / "examples"


@pytest.fixture
def realdata_dir() -> Path:
    path = REPO.parent / "shared" / "realdata"
    if not path.is_dir():
        pytest.skip(f"real data folder {path} not present (CI has ../shared beside the checkout)")
    return path


@pytest.fixture(autouse=True)
def _private_history_db(tmp_path, monkeypatch):
    """Every test stores into its own database, never into the user's home; and sees no
    terminal size (pytest-xdist's workers set COLUMNS=80: the tables then stacked)."""
    monkeypatch.setenv("INERTEST_DB", str(tmp_path / "history.db"))
    monkeypatch.delenv("COLUMNS", raising=False)
    monkeypatch.delenv("LINES", raising=False)


#: Modules whose tests share an expensive module- or session-scoped fixture: under
#: pytest-xdist each runs on one worker (else every worker builds the fixture again: the report
#: kinds for the browser tests took 200 s).
SHARED_FIXTURE_GROUPS = {
    "tests/report/": "reports",
    "tests/test_bad_inputs.py": "postgresql",  # also holds PostgreSQL cases
    "tests/procedures/test_orientation_free.py": "orientation-free",
    "tests/procedures/test_systematic.py": "systematic",
    "tests/procedures/test_ferraris.py": "ferraris",
    "tests/io/recordings/test_rosbag.py": "rosbag",
}


def _xdist_group(nodeid: str) -> str | None:
    """The group a test runs in under pytest-xdist, or None (any worker)."""
    path = nodeid.split("::", 1)[0]
    if "postgresql" in nodeid:
        return "postgresql"
    if "dask" in path:
        return "dask"
    return next((g for prefix, g in SHARED_FIXTURE_GROUPS.items() if path.startswith(prefix)),
                None)


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist, when installed
def pytest_xdist_make_scheduler(config, log):
    """Under pytest-xdist (``make test`` runs two workers) the tests of the one PostgreSQL test
    database run on one worker, one after another (each empties that database first), so do
    the tests that start Dask clusters (each of several processes) and the tests of a module
    with a shared expensive fixture (:data:`SHARED_FIXTURE_GROUPS`); every other test goes
    where there is room. (xdist's own ``loadgroup`` marks do not group under pytest 9: it
    renames the items' node ids, which pytest 9 no longer lets it do.)"""
    if config.getvalue("dist") == "each":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class Grouped(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return _xdist_group(nodeid) or nodeid

    return Grouped(config, log)
