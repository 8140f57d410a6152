"""Property-based: malformed plans and data files give a clean error or a valid result.

Hypothesis mutates the polar-tumble example plan (values replaced by other TOML types, keys
dropped or misspelt, raw bytes) and generates CSV files; ``inertest fit --no-store --json``
must then exit 0 with one JSON document, or non-zero with one ``error:`` line, never a traceback.
It also builds report folders with symbolic links, manifests and the user's files around them:
writing a report into one changes nothing outside it.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from inertest.cli import main  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PLAN = (EXAMPLES / "polar_tumble" / "plan.toml").read_text()
LINES = PLAN.splitlines()
VALUES = st.sampled_from(["true", '"x"', "-1", "0", "1e308", "nan", "inf", "[]", "{}",
                          '"O-Np"', "[1, 2]", "3.5", '"\\u001b[2J"', "-90", "91"])
SETTINGS = settings(max_examples=25, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def _run(argv, capsys):
    capsys.readouterr()
    status = main(argv)
    out = capsys.readouterr()
    assert "Traceback" not in out.err and "internal error" not in out.err, out.err
    if status == 0:
        json.loads(out.out)
    else:
        lines = [ln for ln in out.err.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("error: "), out.err
    return status


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("prop")
    (d / "truth.toml").write_text("[coefficients]\nDF = 1.0\nDI = 0.5\n")
    assert main(["simulate", str(EXAMPLES / "polar_tumble" / "plan.toml"), "--truth",
                 str(d / "truth.toml"), "-o", str(d / "data.csv"), "--noise", "0.01",
                 "--seed", "3"]) == 0
    return d / "data.csv"


@SETTINGS
@given(edits=st.lists(st.tuples(st.integers(0, len(LINES) - 1),
                                st.sampled_from(["value", "drop", "misspell", "bytes"]),
                                VALUES, st.binary(max_size=8)), min_size=1, max_size=3))
def test_malformed_plans(edits, data, tmp_path, capsys):
    lines = list(LINES)
    raw = b""
    for i, how, value, junk in edits:
        line = lines[i]
        if how == "value" and "=" in line and not line.lstrip().startswith("#"):
            lines[i] = line.split("=", 1)[0] + "= " + value
        elif how == "drop":
            lines[i] = ""
        elif how == "misspell":
            lines[i] = re.sub(r"^(\s*\w)", r"\1x", line)
        else:
            raw += junk
    plan = tmp_path / "plan.toml"
    plan.write_bytes(("\n".join(lines) + "\n").encode() + raw)
    _run(["fit", str(plan), str(data), "--no-store", "--json"], capsys)


CELLS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                  st.sampled_from(["O-Np", "O-Sp", "S-Np", "S-Sp", "", "x", "0", "90", "1e400"]),
                  st.text(alphabet=st.characters(blacklist_categories=["Cs"]), max_size=4))


@SETTINGS
@given(header=st.lists(st.sampled_from(["mounting", "angle_deg", "output", "extra", "angle_deg"]),
                       min_size=0, max_size=4),
       rows=st.lists(st.lists(CELLS, min_size=0, max_size=5), max_size=12))
def test_malformed_data_files(header, rows, tmp_path, capsys):
    path = tmp_path / "d.csv"
    text = ",".join(header) + "\n" + "\n".join(",".join(r) for r in rows) + "\n"
    path.write_text(text, encoding="utf-8")
    _run(["fit", str(EXAMPLES / "polar_tumble" / "plan.toml"), str(path), "--no-store",
          "--json"], capsys)


# --- report folders with symbolic links (issue 34) ----------------------------------------------
def _tree_digest(root, skip=None):
    """SHA-256 of every file under ``root``, the target of every link, every folder (no link
    followed); ``skip`` (a folder) left out."""
    import hashlib
    import os

    out = {}
    for here, dirs, files in os.walk(root, followlinks=False):
        here_p = Path(here)
        if skip is not None and (here_p == skip or skip in here_p.parents):
            dirs[:] = []
            continue
        for name in dirs + files:
            p = here_p / name
            rel = str(p.relative_to(root))
            if skip is not None and p == skip:
                continue
            if p.is_symlink():
                out[rel] = "link:" + os.readlink(p)
            elif p.is_file():
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
            else:
                out[rel] = "dir"
    return out


NAMES = st.sampled_from(["a.txt", "b.png", "index.html", "sub", "x", "notes.md"])
REL = st.lists(NAMES, min_size=1, max_size=3).map("/".join)
ENTRY = st.one_of(REL, st.sampled_from(["../user/keep.txt", "../outside.txt", ".", "",
                                        "/etc/hostname", "sub/../a.txt", "link", "link/keep.txt",
                                        "dirlink/keep.txt", "dirlink", "dirlink/deep/x"]))
LINK_TARGETS = st.sampled_from(["../user", "../user/keep.txt", "../outside.txt", "..",
                                "../user/deep", "/nonexistent", "sub", "."])


@settings(max_examples=80, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(earlier=st.lists(REL, max_size=4, unique=True),
       links=st.lists(st.tuples(st.sampled_from(["link", "dirlink", "sub", "index.html",
                                                 "x/link", ".inertest-report"]), LINK_TARGETS),
                      max_size=3, unique_by=lambda t: t[0]),
       hostile=st.lists(ENTRY, max_size=2), listed=st.sampled_from(["none", "own", "all"]),
       new=st.lists(st.one_of(REL, st.sampled_from(["link/y.txt", "dirlink/y.txt",
                                                    "dirlink/deep/z"])),
                    min_size=1, max_size=4, unique=True))
def test_a_report_never_changes_anything_outside_its_folder(earlier, links, hostile, listed, new,
                                                            tmp_path_factory):
    """Whatever links and manifest an earlier report folder holds, writing a new report into
    it writes and removes only inside it (through real folders), or is refused having changed
    nothing; no file, link or folder outside it changes (SHA-256 before and after)."""
    import json
    import os

    from inertest.errors import OutputPathError
    from inertest.io.atomic import REPORT_MARKER, target_directory

    root = tmp_path_factory.mktemp("prop")
    user = root / "user"
    (user / "deep").mkdir(parents=True)
    for name in ("keep.txt", "a.txt", "index.html", "deep/x", "deep/z", "y.txt"):
        (user / name).write_text(f"the user's {name}")
    (root / "outside.txt").write_text("outside")
    rep = root / "rep"
    rep.mkdir()
    for rel in earlier:  # an earlier report's files (a name that is a file and a folder fails)
        try:
            (rep / rel).parent.mkdir(parents=True, exist_ok=True)
            (rep / rel).write_text("old " + rel)
        except OSError:
            pass
    for name, target in links:
        link = rep / name
        try:
            link.parent.mkdir(parents=True, exist_ok=True)
            if link.is_dir() and not link.is_symlink():
                continue
            link.unlink(missing_ok=True)
            os.symlink(target, link)
        except OSError:
            pass
    # the manifest: none, or the earlier files (as inertest wrote it) plus hostile entries
    manifest = None if listed == "none" else earlier + (hostile if listed == "all" else [])
    if manifest is not None and not (rep / REPORT_MARKER).is_symlink():
        (rep / REPORT_MARKER).write_text(json.dumps({"written_by": "inertest",
                                                     "files": manifest}))
    outside = _tree_digest(root, skip=rep)
    inside = _tree_digest(rep)
    try:
        with target_directory(rep) as tmp:
            for rel in new:
                try:
                    (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
                    (tmp / rel).write_text("new " + rel)
                except OSError:  # a name that is both a file and a folder in the new set
                    pass
    except OutputPathError:
        event("refused")
        assert _tree_digest(rep) == inside  # refused: nothing written half-way
    else:
        event("written")
        for rel in json.loads((rep / REPORT_MARKER).read_text())["files"]:
            p = rep / rel
            assert p.read_text() == "new " + rel
            assert p.resolve().is_relative_to(rep.resolve())
    assert _tree_digest(root, skip=rep) == outside
    assert [p.name for p in root.iterdir() if ".inertest-tmp-" in p.name] == []
