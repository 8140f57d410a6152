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
    for entry in ["../victim.txt", str(tmp_path / "victim.txt")]:
        (rep / REPORT_MARKER).write_text(json.dumps(
            {"written_by": "inertest", "files": ["index.html", entry]}))
        with pytest.raises(OutputPathError, match="not a path inside the folder"):
            _write(rep, {"index.html": "2"})
        assert (tmp_path / "victim.txt").read_text() == "keep"
        assert (rep / "index.html").read_text() == "1"


def _earlier_report_with_link(tmp_path, listed):
    """``rep/`` an earlier report whose manifest lists ``listed``; ``rep/sub -> ../user``."""
    rep, user = tmp_path / "rep", tmp_path / "user"
    _write(rep, {"index.html": "1"})
    user.mkdir()
    (user / "keep.txt").write_text("the user's")
    (rep / "sub").symlink_to("../user")
    (rep / REPORT_MARKER).write_text(json.dumps({"written_by": "inertest", "files": listed}))
    return rep, user


def test_a_listed_file_behind_a_symlink_is_refused_not_removed(tmp_path):
    """Issue 34: ``rep/sub -> ../user`` and a manifest listing sub/keep.txt removed
    user/keep.txt; now refused before anything is written."""
    rep, user = _earlier_report_with_link(tmp_path, ["index.html", "sub/keep.txt"])
    with pytest.raises(OutputPathError, match="behind the symbolic link .*sub"):
        _write(rep, {"index.html": "2"})
    assert (user / "keep.txt").read_text() == "the user's"
    assert (rep / "index.html").read_text() == "1"


def test_a_report_file_is_never_written_through_a_symlinked_folder(tmp_path):
    rep, user = _earlier_report_with_link(tmp_path, ["index.html"])
    with pytest.raises(OutputPathError, match="the report writes sub/keep.txt, which lies "
                       "behind the symbolic link"):
        _write(rep, {"index.html": "2", "sub/keep.txt": "overwritten"})
    assert (user / "keep.txt").read_text() == "the user's"
    assert (rep / "index.html").read_text() == "1"  # nothing replaced half-way


def test_a_symlinked_or_damaged_manifest_is_refused(tmp_path):
    rep, user = _earlier_report_with_link(tmp_path, ["index.html"])
    (user / "m.json").write_text(json.dumps({"written_by": "inertest", "files": ["keep.txt"]}))
    (rep / REPORT_MARKER).unlink()
    (rep / REPORT_MARKER).symlink_to(user / "m.json")
    with pytest.raises(OutputPathError, match="manifest .inertest-report is a symbolic link"):
        _write(rep, {"index.html": "2"})
    (rep / REPORT_MARKER).unlink()
    (rep / REPORT_MARKER).write_text('{"written_by": "inertest", "files": [1, null]}')
    with pytest.raises(OutputPathError, match="manifest .inertest-report is damaged"):
        _write(rep, {"index.html": "2"})
    assert (user / "keep.txt").read_text() == "the user's"


def test_a_link_made_while_the_report_is_built_is_refused_at_the_end(tmp_path):
    """The folder changes between the first check and the renames: checked again, refused."""
    from inertest.errors import InertestWarning
    from inertest.io.atomic import _remove_stale_file

    rep = tmp_path / "rep"
    _write(rep, {"index.html": "1", "old/a.txt": "old"})
    user = tmp_path / "user"
    user.mkdir()
    (user / "a.txt").write_text("the user's")
    with pytest.raises(OutputPathError, match="behind the symbolic link"), \
            target_directory(rep) as tmp:
        (tmp / "index.html").write_text("2")
        (rep / "old" / "a.txt").unlink()
        (rep / "old").rmdir()
        (rep / "old").symlink_to(user)
    assert (user / "a.txt").read_text() == "the user's"
    assert (rep / "index.html").read_text() == "1"
    # and between that check and the removal itself: left in place, with a warning
    with pytest.warns(InertestWarning, match="left in place"):
        _remove_stale_file(rep, "old/a.txt")
    assert (user / "a.txt").read_text() == "the user's"


@pytest.mark.parametrize("where", ["create", "replace"])
def test_a_write_error_names_the_users_path_not_the_temporary(tmp_path, monkeypatch, where):
    """Issue 34: an unwritable output named ``.x.png.inertest-tmp-...``."""
    import os
    import tempfile

    from inertest.io.atomic import target_file

    def refuse(*a, **k):
        name = k["dir"] / (k["prefix"] + "abc.tmp") if where == "create" else a[0]
        raise PermissionError(13, "Permission denied", str(name))

    monkeypatch.setattr(tempfile if where == "create" else os,
                        "mkstemp" if where == "create" else "replace", refuse)
    with pytest.raises(PermissionError) as info, target_file(tmp_path / "x.png") as tmp:
        tmp.write_text("figure")
    assert info.value.filename == str(tmp_path / "x.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


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


def test_a_link_named_like_a_stale_temporary_is_left_alone(tmp_path):
    from inertest.io.atomic import _host

    (tmp_path / "user").mkdir()
    (tmp_path / "user" / "keep.txt").write_text("the user's")
    fake = tmp_path / f".rep.inertest-tmp-{_host()}-999999999-abc"
    fake.symlink_to(tmp_path / "user")
    _write(tmp_path / "rep", {"index.html": "1"})
    assert fake.is_symlink() and (tmp_path / "user" / "keep.txt").read_text() == "the user's"


def test_a_full_disk_reported_without_a_file_name_names_the_output(tmp_path):
    """Arrow and HDF5 report ENOSPC without a file name: the user's path is given."""
    import errno

    from inertest.io.atomic import target_file

    with pytest.raises(OSError) as info, target_file(tmp_path / "s.parquet"):
        raise OSError(errno.ENOSPC, "Error writing bytes to file")
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(tmp_path / "s.parquet")
    with pytest.raises(OSError) as info, target_directory(tmp_path / "rep"):
        raise OSError(errno.ENOSPC, "No space left on device")
    assert info.value.filename == str(tmp_path / "rep")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
