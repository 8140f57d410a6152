"""Terminal tables never cut a number, at 80 and 100 columns (issue 20).

Before, rich squeezed wide tables into the terminal and cut cells: ``ins-errors --example`` showed
"8.97e-...", ``history`` lost the std, ``centrifuge-study`` at 100 columns "4.84e...". Every line
printed is parsed: no ellipsis, no number broken before its exponent, no table line wider than
the terminal.
"""

import re

import pytest

from inertest.cli import main

#: A number token cut in its exponent ("8.97e-", "4.84e").
BROKEN = re.compile(r"[-+]?\d+(?:\.\d*)?[eE][-+]?")
#: A number token: it must parse whole.
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
BOX = "│┃┏┡└┗┌├╇━─"


def _check(text: str, width: int) -> None:
    assert "…" not in text
    for line in text.splitlines():
        if line[:1] in BOX:
            assert len(line) <= width, line
        for tok in re.split(r"[\s│┃,;:()=/]+", line):
            assert not BROKEN.fullmatch(tok), line
            if NUMBER.fullmatch(tok):
                float(tok)  # every number printed parses whole


@pytest.fixture(params=[80, 100])
def width(request, monkeypatch):
    monkeypatch.setenv("COLUMNS", str(request.param))
    return request.param


def test_ins_errors_example(width, capsys):
    assert main(["ins-errors", "--example"]) == 0
    out = capsys.readouterr().out
    _check(out, width)
    # the dVN value the old table cut to "8.97e-...", whole (four significant digits)
    assert re.search(r"0\.0000897\d\b|8\.97\de-05", out)


def test_centrifuge_study(width, capsys, examples_dir):
    assert main(["centrifuge-study", str(examples_dir / "centrifuge" / "study.toml"),
                 "--monte-carlo", "0"]) == 0
    _check(capsys.readouterr().out, width)


def test_fit_identity_and_history_keep_every_std(width, capsys, tmp_path, examples_dir):
    plan = examples_dir / "polar_tumble" / "plan.toml"
    lab = examples_dir / "lab" / "equipment.toml"
    db = tmp_path / "h.db"
    for i in range(2):
        data = tmp_path / f"d{i}.csv"
        main(["simulate", str(plan), "--truth", str(plan.parent / "truth.toml"), "-o",
              str(data), "--noise", "0.002", "--seed", str(i)])
        assert main(["fit", str(plan), str(data), "--db", str(db), "--equipment", str(lab),
                     "--tested-at", f"2026-0{i + 1}-01"]) == 0
    out = capsys.readouterr().out
    _check(out, width)
    assert "FG-0417" in out and "RT-02" in out and "2027-03-01" in out  # serial, equipment, due
    assert main(["history", "FG-0417", "--db", str(db)]) == 0
    out = capsys.readouterr().out
    _check(out, width)
    # the weighted mean of every quantity is printed with its std
    assert len(re.findall(r"-?\d+\.\d+ ± \d+\.\d+", out)) >= 8
