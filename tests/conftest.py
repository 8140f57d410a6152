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
    """Every test stores into its own database, never into the user's home."""
    monkeypatch.setenv("INERTEST_DB", str(tmp_path / "history.db"))
