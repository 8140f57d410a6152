"""A model that does not fit is shown at the top of the result, with the noise model used.

Issue 15 review: the polar tumble with the Sp angles read 180 deg off warned on stderr and said
"model does not fit" in ``checks``, but ``messages`` was empty and the report showed nothing
prominent; neither terminal nor report named the noise model behind the uncertainties.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import inertest
from inertest.app.run import run
from inertest.cli import main
from inertest.io.data_file import write_table
from inertest.store import HistoryStore


@pytest.fixture
def sp180(examples_dir, tmp_path):
    """The reviewer's ``mislabel_polar.sp180``: every Sp mounting's angle read 180 deg off."""
    plan = examples_dir / "polar_tumble" / "plan.toml"
    d = {k: np.asarray(v) for k, v in inertest.simulate(
        plan, examples_dir / "polar_tumble" / "truth.toml", noise=0.002, rng=1).items()}
    sp = np.char.endswith(d["mounting"].astype(str), "Sp")
    d["angle_deg"] = np.where(sp, (d["angle_deg"] + 180.0) % 360.0, d["angle_deg"])
    path = tmp_path / "sp180.csv"
    write_table(path, d)
    return plan, path


def test_misfit_in_messages_report_and_stored_run(sp180, tmp_path):
    plan, data = sp180
    db = tmp_path / "h.db"
    out = run(plan, data, store=str(db), report_dir=tmp_path / "rep")
    doc = out.to_dict()
    (check,) = doc["checks"]
    assert check["message"] in out.warnings  # the terminal's warning
    assert check["verdict"] == "model does not fit"
    assert check["message"] in doc["messages"]
    store = HistoryStore(str(db))
    try:
        (stored,) = store.runs(store.serials()[0])
        assert check["message"] in stored.result["messages"]
    finally:
        store.close()
    html = (tmp_path / "rep" / "index.html").read_text(encoding="utf-8")
    result = html[html.index("<h2>Result"):]
    first = re.search(r"<p[^>]*>", result)
    assert first is not None and 'class="warning"' in first.group(0)  # first thing shown
    assert "does not fit the data" in result[:result.index("</p>")]
    assert re.search(r"Noise model: \w[\w-]*", result)


def test_terminal_names_the_noise_model_and_its_components(examples_dir, tmp_path, capsys):
    plan = examples_dir / "polar_tumble" / "plan.toml"
    data = tmp_path / "d.csv"
    main(["simulate", str(plan), "--truth", str(examples_dir / "polar_tumble" / "truth.toml"),
          "-o", str(data), "--noise", "0.002", "--seed", "3"])
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--no-store",
                 "--noise-model", "position-offsets"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("noise model:"))
    assert "position-offsets" in line
    assert re.search(r"white noise per reading [\d.e+-]+ deg/h", line)
    assert re.search(r"offset per position [\d.e+-]+ deg/h", line)
    assert main(["fit", str(plan), str(data), "--no-store"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("noise model:"))
    assert "(auto, Akaike weight" in line
