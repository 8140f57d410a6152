"""Database URLs the store tests run against: SQLite always, PostgreSQL when one is running."""

from __future__ import annotations

import os

import pytest

from postgres_reset import reset_postgres

PG_ENV = "INERTEST_TEST_PG_URL"


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request, tmp_path):
    if request.param == "sqlite":
        return "sqlite:///" + str(tmp_path / "h.db")
    url = os.environ.get(PG_ENV)
    if not url:
        pytest.skip(f"no PostgreSQL server: set {PG_ENV} (.ci/run starts one on localhost)")
    reset_postgres(url)
    return url
