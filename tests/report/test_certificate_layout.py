"""A certificate's layout and numbers, unit by unit (issue 29; the browser test renders them).

References: ISO/IEC 17025:2017 7.8.2.1 (report id, page x of y, marked end, who performed and
approved), JCGM 100:2008 (GUM) 7.2.6 (u to two significant digits), the closed forms of a
rate-table pair (a scale-factor asymmetry and a second-order term are even in the pair sum),
and the round-off of whole-period integration (a constant stator drift cancels exactly).
"""

from __future__ import annotations

import re

import matplotlib.pyplot as plt
import numpy as np
import pytest

import inertest
from inertest.report.html import Approval, Section, page, report_id_of, table_html


def test_every_printed_page_carries_id_serial_and_page_x_of_y():
    html = page("T", [Section("S", [table_html(["a", "b"], [["x", 1.5]])])],
                identity=[["serial", "FG-1"]], report_id="CAL-2026-0117")
    style = re.search(r"<style>(.*)</style>", html, re.S).group(1)
    assert '@top-left { content: "Report CAL-2026-0117"' in style
    assert '@top-right { content: "Serial FG-1"' in style
    assert '"page " counter(page) " of " counter(pages)' in style
    assert html.rstrip().endswith(
        '<p class="end">End of report CAL-2026-0117 (serial FG-1): nothing follows.</p>'
        "</section></body></html>")
    # every report has serial, site and operator, stated or "not stated" with the option
    assert "not stated (give --site)" in html and "not stated (give --operator)" in html


def test_report_id_is_derived_from_what_identifies_the_report():
    a = report_id_of("allan", "input file=x.npy", "SHA-256 of x.npy=ab12")
    assert a == report_id_of("allan", "input file=x.npy", "SHA-256 of x.npy=ab12")
    assert a != report_id_of("allan", "input file=x.npy", "SHA-256 of x.npy=ab13")
    assert re.fullmatch(r"R-[0-9A-F]{10}", a)


def test_approval_block_from_given_names_and_blank_lines_otherwise():
    html = page("T", [], identity=None, approval=Approval(
        performed_by="A. Engineer", performed_on="2026-11-16", approved_by="C. QM"))
    sign = html[html.index("<h2>Approval</h2>"):]
    cells = re.findall(r"<td[^>]*>(.*?)</td>", sign)
    text = [re.sub(r"<[^>]+>", "", c) for c in cells]
    assert text == ["performed by", "A. Engineer", "2026-11-16", "",
                    "reviewed by", "", "", "",
                    "approved by", "C. QM", "", ""]


def test_plan_and_lab_file_give_the_approval_fields(examples_dir, tmp_path):
    from inertest.plan import read_test_table
    from inertest.quality.lab import identity_block, read_signatories, test_time

    c = read_test_table({"operator": "A. Engineer", "date": "2026-11-16",
                         "reviewed_by": "R. Plan", "review_date": "2026-11-18",
                         "approval_date": "2026-11-19", "certificate": "CAL-7"}, "[test]")
    sig = read_signatories(examples_dir / "lab" / "equipment.toml")
    block = identity_block(c, lab=None, tested=test_time(c), software_version="x",
                           data_sha256="0" * 64, signatories=sig)
    assert block["approval"] == {"performed_by": "A. Engineer", "performed_on": "2026-11-16",
                                 "reviewed_by": "R. Plan", "reviewed_on": "2026-11-18",
                                 "approved_by": "C. Quality-Manager",
                                 "approved_on": "2026-11-19"}
    assert block["certificate"] == "CAL-7"


def test_a_wide_table_is_stacked_where_its_box_is_narrower_than_its_least_width():
    wide = table_html([f"column number {i}" for i in range(12)],
                      [[f"-0.00285{i} ± 0.00011" for i in range(12)]])
    narrow = table_html(["a", "b"], [["x", "1.0"]])
    n_wide = int(re.search(r'class="tw m(\d+)"', wide).group(1))
    n_narrow = int(re.search(r'class="tw m(\d+)"', narrow).group(1))
    assert n_wide > 12 * len("-0.002850 ± 0.00011") and n_narrow < 20
    html = page("T", [Section("S", [wide, narrow])], identity=None)
    assert f"@container (max-width: {n_wide}ch) {{ .m{n_wide} table" in html
    # value ± std is one unbreakable unit; there are no scroll boxes left
    assert "-0.002850\u00a0±\u00a00.00011" in wide
    assert "overflow-x" not in html


def test_budget_contribution_below_one_percent_of_u_c_is_shown_as_a_bound():
    from inertest.report.conformance import budget_notes, budget_table

    budget = {"coverage_probability": 0.9545, "assumptions": [], "not_applicable": [],
              "quantities": {"DOS": {
                  "value": -0.0778, "unit": "deg/h/g^2",
                  "type_a": {"std": 0.0042, "dof": 311},
                  "type_b": [{"source": "RT-02 tilt", "u": 20.0, "u_unit": "urad",
                              "contribution": 1.6e-11},
                             {"source": "RT-02 angle", "u": 2.0, "u_unit": "arcsec",
                              "contribution": -8.6e-4}],
                  "combined_std": 0.00429, "coverage_factor": 2.01, "expanded": 0.00862}}}
    header, rows = budget_table(budget)
    row = dict(zip(header, rows[0], strict=True))
    tilt = next(v for k, v in row.items() if "tilt" in k)
    angle = next(v for k, v in row.items() if "angle" in k)
    assert tilt == "< 0.00004" and angle == "-0.00086"
    assert row["combined std"] == "0.0043" and row["U (expanded)"] == "0.0086"
    assert any("below 1 % of the combined standard uncertainty" in n for n in
               budget_notes(budget))


def test_truth_is_printed_without_an_uncertainty_of_its_own(examples_dir):
    from inertest.io.plan_file import load_truth
    from inertest.report.identification import coefficient_rows

    plan = examples_dir / "polar_tumble" / "plan.toml"
    truth = load_truth(examples_dir / "polar_tumble" / "truth.toml")
    res = inertest.fit(plan, inertest.simulate(plan, truth, noise=0.002, rng=1))
    header, rows = coefficient_rows(res.identification, truth)
    assert header[3] == "truth"
    assert all("±" not in r[3] for r in rows) and all("±" in r[1] for r in rows)
    di = next(r for r in rows if r[0] == "DI")
    assert di[3] == f"{truth['DI']:.4f}"  # at the decimal of the std (0.0024)


def test_tdev_is_drawn_on_its_own_axis_with_its_unit():
    from inertest.noise.deviations import deviations
    from inertest.report.noise import allan_figure

    rng = np.random.default_rng(1)
    res = deviations(rng.standard_normal(4000), 10.0, ["oadev", "tdev"])
    fig = allan_figure(res, unit="1")
    labels = [ax.get_ylabel() for ax in fig.axes]
    plt.close(fig)
    assert labels == ["deviation [1]", "time deviation TDEV [s]"]
    fig = allan_figure({"tdev": res["tdev"]}, unit="deg/h")
    labels = [ax.get_ylabel() for ax in fig.axes]
    plt.close(fig)
    assert labels == ["time deviation TDEV [arcsec]"]


def test_rate_table_report_says_why_the_pair_bias_climbs(examples_dir):
    """Closed form of a pair: (E+ + E-)/(2K) = B + (K+ - K-) w/(2K) + K2 w^2 (+ noise); with the
    example's asymmetry and K2 the pair bias grows with the rate, and the report says why."""
    from inertest.report.gyro_triad import pair_bias_note

    folder = examples_dir / "gyro_rate_table"
    res = inertest.fit(folder / "plan.toml", inertest.simulate(
        folder / "plan.toml", folder / "truth.toml", noise=2.0, rng=3))
    pairs = sorted(res.pairs, key=lambda p: p["rate_deg_s"])
    assert pairs[-1]["B"] - pairs[0]["B"] > 5.0  # deg/h: the climb the issue saw
    note = pair_bias_note(res)
    assert note is not None and "asymmetry" in note and "K2 ω²" in note
    assert f"±{pairs[-1]['rate_deg_s']:g} deg/s" in note


def test_stator_modulation_round_off_is_printed_as_zero_with_a_note():
    from inertest.report.modulation import component_rows
    from inertest.studies import stator_modulation as sm
    from inertest.units import DEG_PER_H_TO_RAD_PER_S as K

    t = np.arange(0, 20.0, 1e-3)
    drift = sm.drift_scenario(t, constant=np.array([5.0, -3.0]) * K)
    house = np.zeros((t.size, 2))
    house[:, 0] = 36.0 * K
    runs = tuple(sm.run_modulation(t, house, drift, stator_rate_rad_s=2 * np.pi * f,
                                   sample_rate_hz=1000.0) for f in (1.0, 2.0))
    study = sm.ComponentStudy((1.0, 2.0), runs)
    assert all(0 < r["rms_residual_modulated_deg_h"] < 1e-8 for r in study.rows())  # round-off
    header, rows, notes = component_rows(study)
    assert [r[1] for r in rows] == ["0", "0"] and "round-off" in notes[0]
    assert study.to_dict()["result"]["runs"][0]["rms_residual_modulated_deg_h"] > 0  # JSON


@pytest.mark.parametrize("values,expected", [
    ([-1.0000000000000284, 0.3, 1.000000000000007], (-1.0, 1.0)),
    ([-40.0, 59.99999999999997], (-40.0, 60.0)),
    ([0.0, 0.0], (0.0, 0.0)),
    ([2.5e-7, 3.25e-7], (2.5e-7, 3.25e-7)),
])
def test_valid_range_keeps_no_round_off_and_every_training_point(values, expected):
    from inertest.models.thermal import RANGE_RTOL, observed_range

    lo, hi = observed_range(values)
    assert (lo, hi) == expected
    tol = RANGE_RTOL * max(hi - lo, abs(lo), abs(hi), 1e-300)
    assert min(values) >= lo - tol and max(values) <= hi + tol


def test_examples_and_reports_cite_sources_not_placeholders(examples_dir):
    """No "seed 00x" in the example plans' comments and no "Ref. [centrifuge paper]"
    placeholder in what a user reads: the sources are named by authors and title."""
    for path in examples_dir.rglob("*"):
        if path.suffix in (".toml", ".md"):
            text = path.read_text(encoding="utf-8")
            assert not re.search(r"seed 00\d", text), path
            assert "[centrifuge paper]" not in text, path
    src = examples_dir.parent / "src" / "inertest"
    for path in [*src.glob("report/*.py"), src / "studies" / "centrifuge_study.py"]:
        assert "[centrifuge paper]" not in path.read_text(encoding="utf-8"), path
