"""Report section of the nine-position centrifuge test."""

import re
import warnings

import numpy as np

import inertest
from inertest.cli import main
from inertest.earth import Site
from inertest.plan import Instrument, Plan
from inertest.procedures.centrifuge_nine_position import CentrifugeNinePositionSpec as Spec9
from inertest.report.html import page
from inertest.report.sections import result_sections

TRUTH = dict(DF=0.5, DI=0.3, DO=-0.2, DS=0.15, DIO=0.01, DOS=-0.008, DSI=0.006, DII=0.02,
             DOO=-0.012, DSS=0.009)


def _result(sigma=None, **params):
    spec = Spec9.from_mapping({"radius_m": 2.5, "revolutions": 5, **params})
    plan = Plan(Site.at(45.0, 9.8066), Instrument(output_unit="mA", scale_factor=10.0), spec)
    data = inertest.simulate(plan, TRUTH, noise=1e-4, rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return inertest.fit(plan, data, sigma=sigma)


def test_section_has_units_uncertainties_runs_and_figure():
    res = _result()
    secs = result_sections(res, TRUTH, title="FG-C04")
    assert len(secs) == 1
    html = page("t", secs)
    assert html.count("data:image/png;base64,") == 1
    for name in ("DF", "DI", "DIO", "DSS"):
        assert f">{name}<" in html
    for unit in ("deg/h", "deg/h/g", "deg/h/g^2"):
        assert f">{unit}<" in html
    # residuals in deg/h beside the drift in deg/h, never in the output unit (issue 29)
    assert "±" in html and "residual [deg/h]" in html and "residual [mA]" not in html
    # one table row per run: 9 positions x 2 rates, each naming its rate
    assert len(re.findall(r"<tr><td[^>]*>\d</td><td[^>]*>(?:4\.43|8\.85)0?</td>", html)) == 18
    # the coefficient errors against the truth are reported in units of their std
    assert "error/std" in html


def test_section_states_what_missing_positions_lose():
    res = _result(sigma=1e-4, positions=[1, 2, 3])  # 6 runs, rank 6: no dof for the noise
    html = page("t", result_sections(res, None, title="x"))
    assert "DO, DIO, DOS: their averaged regressors are zero" in html
    assert "Warning: positions 4, 5, 6, 7, 8, 9 not measured" in html


def test_cli_report(examples_dir, tmp_path, capsys):
    plan = examples_dir / "centrifuge" / "plan.toml"
    data = tmp_path / "d.csv"
    assert main(["simulate", str(plan), "--truth", str(examples_dir / "centrifuge" / "truth.toml"),
                 "-o", str(data), "--noise", "3e-8", "--seed", "1"]) == 0
    assert main(["fit", str(plan), str(data), "--no-store", "--report", str(tmp_path / "r")]) == 0
    html = (tmp_path / "r" / "index.html").read_text()
    assert "whole-cycle least squares" in html and "data:image/png;base64," in html
    assert np.isfinite(len(html))
