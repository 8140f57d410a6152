"""Report folders: inertest replaces only the files its own manifest lists (issue 16)."""

from __future__ import annotations

import json

import pytest

from inertest.errors import OutputPathError
from inertest.io.atomic import REPORT_MARKER, report_manifest, target_directory


def _write(folder, files):
    with target_directory(folder) as tmp:
        for name, text in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)


def test_new_report_has_a_manifest(tmp_path):
    rep = tmp_path / "rep"
    _write(rep, {"index.html": "1", "a.csv": "x"})
    assert report_manifest(rep) == ["a.csv", "index.html"]
    assert json.loads((rep / REPORT_MARKER).read_text())["written_by"] == "inertest"


def test_user_files_in_an_earlier_report_are_never_touched(tmp_path):
    rep = tmp_path / "rep"
    _write(rep, {"index.html": "old", "old.csv": "x"})
    (rep / "notes.txt").write_text("mine")
    (rep / "sub").mkdir()
    (rep / "sub" / "z.txt").write_text("mine too")
    (rep / "history.db").write_bytes(b"SQLite format 3\0")
    _write(rep, {"index.html": "new"})
    assert (rep / "index.html").read_text() == "new"
    assert not (rep / "old.csv").exists()  # the old report's own file, no longer written
    assert (rep / "notes.txt").read_text() == "mine"
    assert (rep / "sub" / "z.txt").read_text() == "mine too"
    assert (rep / "history.db").read_bytes() == b"SQLite format 3\0"
    assert report_manifest(rep) == ["index.html"]


@pytest.mark.parametrize("marker", ["", "x", '{"files": ["index.html"]}',
                                    '{"written_by": "someone", "files": []}'])
def test_a_hand_made_marker_is_not_a_manifest(tmp_path, marker):
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / REPORT_MARKER).write_text(marker)
    (rep / "index.html").write_text("the user's page")
    with pytest.raises(OutputPathError, match="did not write"):
        _write(rep, {"index.html": "new"})
    assert (rep / "index.html").read_text() == "the user's page"


def test_manifest_cannot_reach_outside_the_folder(tmp_path):
    rep = tmp_path / "rep"
    _write(rep, {"index.html": "1"})
    (tmp_path / "victim.txt").write_text("keep")
    (rep / REPORT_MARKER).write_text(json.dumps(
        {"written_by": "inertest", "files": ["../victim.txt", str(tmp_path / "victim.txt")]}))
    _write(rep, {"index.html": "2"})
    assert (tmp_path / "victim.txt").read_text() == "keep"


def test_a_failed_report_changes_nothing(tmp_path):
    rep = tmp_path / "rep"
    _write(rep, {"index.html": "old"})
    with pytest.raises(RuntimeError), target_directory(rep) as tmp:
        (tmp / "index.html").write_text("half")
        raise RuntimeError("simulated failure while rendering")
    assert (rep / "index.html").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_temporaries_of_killed_runs_are_cleared_whatever_their_name(tmp_path):
    import socket
    import subprocess
    import sys

    from inertest.io.atomic import _host

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    stale = tmp_path / f".rep2.inertest-tmp-{_host()}-{dead}-abc"
    stale.mkdir()
    (stale / "index.html").write_text("half")
    assert socket.gethostname()  # the host part is this machine's
    _write(tmp_path / "rep7", {"index.html": "new"})
    assert not stale.exists()
