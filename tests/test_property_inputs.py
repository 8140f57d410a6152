"""Property-based: malformed plans and data files give a clean error or a valid result.

Hypothesis mutates the polar-tumble example plan (values replaced by other TOML types, keys
dropped or misspelt, raw bytes) and generates CSV files; ``inertest fit --no-store --json``
must then exit 0 with one JSON document, or non-zero with one ``error:`` line, never a traceback.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
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
