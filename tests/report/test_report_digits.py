"""Every report kind prints numbers as JCGM 100:2008 (GUM) 7.2.6 says, and no round-off as data.

The rules, written here from the GUM and not from the code under test:

- a standard uncertainty is quoted to at most two significant digits (GUM 7.2.6), and the
  estimate beside it ends at the same decimal as the uncertainty (``10.058 ± 0.027``, never
  ``10.05762 ± 0.027`` nor ``10.06 ± 0.027``); the same for a "value" column next to a "std"
  column;
- a number without an uncertainty keeps a few significant digits (at most 7: the seven of a
  local gravity 9.806650 m/s^2), never the 9 to 17 of a binary float;
- arithmetic round-off (1e-16 of a value of order 1, an Earth rate of 1e-17 deg/h on an axis
  that is horizontal) is printed as 0, never as data.

Identity tables (hashes, dates, serials, site coordinates) are text, not measured values, and
are skipped.
"""

import html
import re
import shlex
from html.parser import HTMLParser

import pytest

NUM = r"[-+−]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
PM = re.compile(rf"(?<![\w.])({NUM})\s*±\s*({NUM})(?![\w.])")
TOKEN = re.compile(rf"(?<![\w.\-/#])({NUM})(?![\w.])")


class _Tables(HTMLParser):
    """Tables as lists of rows of cell texts, with their caption and the section heading."""

    def __init__(self):
        super().__init__()
        self.tables = []
        self.heading = ""
        self._in = None
        self._text = []

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append({"section": self.heading, "rows": []})
        elif tag == "tr" and self.tables:
            self.tables[-1]["rows"].append([])
        elif tag in ("td", "th", "h2"):
            self._in, self._text = tag, []

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._in == tag:
            self.tables[-1]["rows"][-1].append(html.unescape("".join(self._text)).strip())
            self._in = None
        elif tag == "h2" and self._in == "h2":
            self.heading = "".join(self._text)
            self._in = None

    def handle_data(self, data):
        if self._in:
            self._text.append(data)


def _last_decimal(text: str, *, std: bool = False) -> int:
    """Decimal exponent of the last digit: '10.058' -> -3, '1.2e-09' -> -10.

    An integer's trailing zeros are ambiguous: a std ('7700', '40') has two significant
    digits (GUM 7.2.6), so its last is its second digit (2, 0); a value's last is its last
    non-zero digit ('-1500' -> 2), which must not be finer than its std's.
    """
    mant, _, exp = text.lower().lstrip("+-−").partition("e")
    e = int(exp) if exp else 0
    if "." in mant:
        return e - len(mant.partition(".")[2])
    digits = mant.lstrip("0")
    if not digits:
        return e
    if std:
        return e + max(len(digits) - 2, 0)
    return e + len(digits) - len(digits.rstrip("0"))


def _consistent(v: str, u: str) -> bool:
    """``v`` ends at the decimal of ``u`` (integers: not finer than it)."""
    if "." in v.lower().partition("e")[0] or "." in u.lower().partition("e")[0]:
        return _last_decimal(v) == _last_decimal(u)
    return _last_decimal(v) >= _last_decimal(u, std=True)


def _significant(text: str) -> int:
    mant = text.lower().lstrip("+-−").partition("e")[0]
    if "." not in mant:
        mant = mant.rstrip("0")
    return len(mant.replace(".", "").lstrip("0"))


def _zero(text: str) -> bool:
    return float(text.replace("−", "-")) == 0


def _cells(page: str):
    parser = _Tables()
    parser.feed(page)
    for t in parser.tables:
        if t["section"] == "Identity" or (t["rows"] and t["rows"][0][:1] == ["item"]):
            continue
        header = t["rows"][0] if t["rows"] else []
        for row in t["rows"][1:]:
            yield header, row


def _problems(page: str) -> list[str]:
    bad = []
    for header, row in _cells(page):
        with_std = any("std" in h or "uncertainty" in h for h in header)
        for cell in row:
            for v, u in PM.findall(cell):
                if _significant(u) > 2:
                    bad.append(f"std with more than two significant digits: {cell!r}")
                if not _zero(u) and not _zero(v) and not _consistent(v, u):
                    bad.append(f"value not at the decimal of its std: {cell!r}")
            # numbers without a std beside them (nor in a std column of their row)
            alone = [] if with_std else TOKEN.findall(PM.sub(" ", cell))
            for tok in TOKEN.findall(cell):
                if tok in alone and ("." in tok or "e" in tok.lower()) \
                        and _significant(tok) > 7:
                    bad.append(f"{_significant(tok)} significant digits: {cell!r}")
                x = float(tok.replace("−", "-"))
                if x != 0 and abs(x) < 1e-14:
                    bad.append(f"round-off printed as data: {cell!r}")
        for i, h in enumerate(header[:-1]):
            if h.startswith("value") and header[i + 1].startswith("std") and i + 1 < len(row):
                v, u = row[i], row[i + 1]
                if re.fullmatch(NUM, v) and re.fullmatch(NUM, u) and float(u) > 0:
                    if _significant(u) > 2 or not _consistent(v, u):
                        bad.append(f"value {v!r} with std {u!r}")
    return bad


def test_rules_as_written():
    """The checker itself, on the GUM's examples (7.2.2, 7.2.6) and on the issue's failures."""
    ok = "<table><tr><th>q</th></tr><tr><td>10.058 ± 0.027</td></tr>" \
         "<tr><td>100.02147 ± 0.00035</td></tr><tr><td>1.234e-09 ± 5.0e-11</td></tr>" \
         "<tr><td>0.000 ± 0.061</td></tr><tr><td>9.806650</td></tr>" \
         "<tr><td>-1500 ± 15</td></tr><tr><td>7900 ± 7700</td></tr></table>"
    assert _problems(ok) == []
    for cell in ("10.05762 ± 0.027", "10.06 ± 0.027", "7950 ± 7700", "1.0 ± 0.0271", "-5.8e-17",
                 "0.123456789", "1.23456789e-05"):
        assert _problems(f"<table><tr><th>q</th></tr><tr><td>{cell}</td></tr></table>"), cell
    assert _problems("<table><tr><th>value</th><th>std</th></tr>"
                     "<tr><td>3.14159</td><td>0.0021</td></tr></table>")


@pytest.mark.slow
def test_every_report_kind_rounds_to_its_uncertainty(reports):
    found = {name: _problems(path.read_text(encoding="utf-8")) for name, path in reports.items()}
    assert {k: v[:5] for k, v in found.items() if v} == {}


@pytest.mark.slow
def test_analysis_pages_state_their_input(reports):
    """File name and SHA-256 of each input (or what it was), the command and the serial."""
    def identity(name):
        rows = next(t for t in _identity_tables(reports[name]))
        return {r[0]: r[1] for r in rows[1:] if len(r) == 2}

    for name in ("allan", "noise", "thermal", "centrifuge-study"):
        rows = identity(name)
        assert "input file" in rows, name
        sha = [v for k, v in rows.items() if k.startswith("SHA-256")]
        assert sha and all(re.fullmatch(r"[0-9a-f]{64}", s) for s in sha), name
    # the exact command, every input by its path: the page reproduces itself (issue 29)
    allan_input = reports["allan"].parents[1] / "g.npy"
    assert identity("allan")["command"] == shlex.join([
        "inertest", "allan", str(allan_input), "--rate", "50", "--stats",
        "adev,oadev,mdev,tdev,hdev,ohdev", "--report", str(reports["allan"])])
    assert identity("allan")["input file"] == str(allan_input)
    assert identity("thermal")["serial"] == "G-17"
    # identity on every kind: serial, site, operator (stated, or "not stated" with the option)
    for name in ("allan", "noise", "thermal", "centrifuge-study", "ins-errors", "modulation",
                 "thermal triad", "history figure"):
        rows = identity(name)
        assert {"serial", "site", "operator", "command", "software", "report id"} <= set(rows), name
    triad = identity("thermal triad")
    assert triad["serial"] == "ACC3-0112" and triad["operator"] == "A. Engineer"
    assert "latitude 34.246000 deg" in triad["site"]
    assert identity("allan")["serial"] == "not stated (give --serial)"
    assert "seed 1" in identity("centrifuge-study")["input"]
    assert identity("ins-errors")["input"].startswith("built-in example")
    assert "--example" in identity("ins-errors")["command"]
    assert identity("modulation")["input"].startswith("simulated")
    assert "--compare" in identity("modulation")["command"]


def _identity_tables(path):
    parser = _Tables()
    parser.feed(path.read_text(encoding="utf-8"))
    return [t["rows"] for t in parser.tables if t["section"] == "Identity"]
