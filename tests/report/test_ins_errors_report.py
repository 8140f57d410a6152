"""Report sections and figure of the INS error propagation."""

import math

import numpy as np

from inertest.ins.closed_forms import closed_forms
from inertest.ins.error_model import InsSite
from inertest.ins.propagation import characteristic_periods, source_responses
from inertest.ins.scenario import InsScenario
from inertest.report.html import page
from inertest.report.ins_errors import closed_form_rows, final_rows, ins_error_sections

DEG_H = math.pi / 180 / 3600


def _scenario():
    return InsScenario(site=InsSite(math.radians(39)), u=np.array([0, 0, 0, 0.1 * DEG_H, 0]),
                       x0=np.array([0, 0, 0, 0, 0, 0, 1e-3]), duration_s=3600, step_s=60)


def test_sections_hold_figure_periods_and_closed_forms():
    sc = _scenario()
    resp = source_responses(sc)
    forms = closed_forms(coriolis=True)
    c0, c1 = forms.evaluate(sc.site, np.r_[sc.u, sc.x0])
    table = closed_form_rows(forms, c0, c1, None, resp.active)
    secs = ins_error_sections(resp, characteristic_periods(sc.site), closed_form_table=table,
                              sigma=np.zeros((resp.t.size, 7)))
    titles = [s.title for s in secs]
    assert titles[1:] == ["Characteristic periods", "Errors at the end of the run",
                          "Constant and secular parts (final value theorem)"]
    html = page("t", secs)
    assert html.count("data:image/png;base64,") == 1
    assert "Foucault" in html and "eN*cos(L)" in html and "-eN*cos(L)" not in html
    assert "Sign convention" in html and "output errors" in html
    # 0.1 deg/h north gyro drift (output error): longitude grows at +6 cos(39 deg) arcmin/h
    row = next(r for r in table if r[0] == "dlambda" and r[1] == "eN")
    assert row[4].startswith(f"{6 * math.cos(math.radians(39)):.4g} arcmin/h")  # 4 digits


def test_final_rows_only_active_sources_in_display_units():
    resp = source_responses(_scenario())
    rows = final_rows(resp)
    assert [r[0] for r in rows] == ["eN", "phiU0", "combined"]
    # phiU in arcmin, 4 significant digits
    phiu = resp.per_source[resp.sources.index("phiU0"), -1, 6]
    assert rows[1][7] == f"{phiu * 180 / math.pi * 60:.4g}"
