"""``inertest centrifuge-study`` (issue 5)."""

import json
import math

import pytest

from inertest.cli import main
from inertest.earth import OMEGA_IE
from inertest.units import ARCMIN_TO_RAD

SMALL = """
name = "small"
[machine]
revolutions = 4
[errors.dgamma_200]
label = "constant dgamma = 200'"
dgamma_offset_arcmin = 200.0
[errors.parallelism]
parallelism_y_rad = 5e-6
"""


@pytest.fixture
def small_plan(tmp_path):
    p = tmp_path / "study.toml"
    p.write_text(SMALL)
    return p


def test_json_report_and_table(small_plan, tmp_path, capsys):
    html = tmp_path / "out" / "study.html"
    assert main(["centrifuge-study", str(small_plan), "--json", "--monte-carlo", "0",
                 "--report", str(html)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "centrifuge-study"
    assert out["identification"] is None  # a study predicts; it identifies nothing from data
    assert set(out["result"]["coefficients"]) == {"DF", "DI", "DO", "DS", "DIO", "DOS", "DSI",
                                                  "DII", "DOO", "DSS"}
    assert out["result"]["coefficients"]["DII"]["unit"] == "deg/h/g^2"
    dg = next(c for c in out["result"]["cases"] if c["key"] == "dgamma_200")
    # the turned Earth rate, closed form, for I = west (positions 4-6)
    expected = OMEGA_IE * math.cos(math.radians(45)) * math.sin(200 * ARCMIN_TO_RAD)
    assert dg["max_run_rate_error_rad_s"] == pytest.approx(expected, rel=1e-9)
    text = html.read_text()
    assert text.startswith("<!DOCTYPE html>") and "data:image/png;base64," in text
    assert "Compensation" in text
    assert main(["centrifuge-study", str(small_plan), "--monte-carlo", "0"]) == 0
    assert "after compensation" in capsys.readouterr().out


@pytest.mark.parametrize("text, match", [
    ("[machine]\nradius = 2.5\n", "unknown key"),
    ("[machine\n", "not valid TOML"),
    ("[errors.a]\nphase_tracking_arcmin = 2.0\n", "phase_tracking_hz"),
])
def test_bad_plans_exit_2_with_one_line_and_write_nothing(tmp_path, capsys, text, match):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    html = tmp_path / "r.html"
    assert main(["centrifuge-study", str(p), "--report", str(html)]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err
    assert not html.exists()


def test_bad_monte_carlo_count(small_plan, capsys):
    assert main(["centrifuge-study", str(small_plan), "--monte-carlo", "1"]) == 2
    assert "at least 2" in capsys.readouterr().err


def test_missing_plan_file(tmp_path, capsys):
    assert main(["centrifuge-study", str(tmp_path / "nope.toml")]) == 2
    assert "nope.toml" in capsys.readouterr().err
