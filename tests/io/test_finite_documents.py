"""Every file inertest reads back refuses a NaN or infinite number, naming file and key (issue 34).

TOML reads ``nan``/``inf`` and Python's JSON reads ``NaN``/``Infinity``: a thermal model with a
NaN coefficient made ``apply`` write an all-NaN column and report success.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from inertest.app.batch import read_manifest
from inertest.errors import InertestError, InputError, PlanError
from inertest.io.calibration_file import load_calibration
from inertest.io.plan_file import load_plan, load_truth
from inertest.io.thermal_model import (
    load_thermal_model,
    load_triad_thermal_model,
    write_thermal_model,
)
from inertest.plan import check_finite_document
from inertest.quality.conformance import read_spec
from inertest.quality.lab import read_equipment

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "+nan"])
@pytest.mark.parametrize("loader, example, key, path", [
    (load_plan, "polar_tumble/plan.toml", "latitude_deg = ", "site.latitude_deg"),
    (load_truth, "polar_tumble/truth.toml", "DI = ", "coefficients.DI"),
    (read_equipment, "lab/equipment.toml", "rate_ppm = ", "equipment[0].type_b.rate_ppm"),
    (read_spec, "specs/floated_gyro.toml", "max_abs = ", "limit[0].max_abs"),
])
def test_a_toml_file_with_nan_or_inf_names_the_key(tmp_path, bad, loader, example, key, path):
    text = (EXAMPLES / example).read_text()
    start = text.index(key) + len(key)
    end = min(i for i in (text.find("\n", start), text.find(" ", start)) if i > 0)
    (tmp_path / "f.toml").write_text(text[:start] + bad + text[end:])
    with pytest.raises(InertestError, match=f"f.toml: {re.escape(path)}.* is -?(nan|inf), not a "
                       "finite number; give a finite number"):
        loader(tmp_path / "f.toml")


def test_a_batch_manifest_with_a_nan_sigma_is_refused(tmp_path):
    (tmp_path / "m.toml").write_text('[[run]]\nplan = "p.toml"\ndata = "d.csv"\nsigma = nan\n')
    with pytest.raises(PlanError, match=r"run\[0\].sigma is nan"):
        read_manifest(tmp_path / "m.toml")


def test_nested_keys_and_allowed_diagnostics():
    doc = {"a": [1.0, {"b": float("inf")}], "fit": {"p_value": float("nan")}}
    with pytest.raises(InputError, match=r"^src: a\[1\].b is inf, not a finite number; fix$"):
        check_finite_document(doc, "src", fix="fix", error=InputError)
    check_finite_document({"fit": {"p_value": float("nan")}, "x": [1, 2.5, "nan"]}, "src",
                          fix="fix", may_be_nan=("p_value",))


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """A thermal model and a triad thermal model, written by the command line."""
    import numpy as np

    from inertest.cli import main
    from inertest.io.data_file import write_table

    d = tmp_path_factory.mktemp("models")
    t = np.arange(0, 4 * 12000.0, 60.0)
    temp = 10 - 50 * np.cos(2 * np.pi * t / 12000)
    rng = np.random.default_rng(4)
    write_table(d / "train.csv", {"cycle": (t // 12000) + 1, "time_s": t, "temperature_c": temp,
                                  "bias_deg_h": 0.5 + 0.004 * temp + rng.normal(0, .01, t.size)})
    assert main(["thermal", "fit", str(d / "train.csv"), "--quantity", "bias", "--model-out",
                 str(d / "bias.json")]) == 0
    shutil.copy(EXAMPLES / "thermal_triad" / "plan.toml", d / "plan.toml")
    assert main(["thermal", "triad-simulate", str(d / "plan.toml"),
                 str(EXAMPLES / "thermal_triad" / "laws.toml"), "-o", str(d / "ch.csv"),
                 "--noise", "2", "--seed", "1"]) == 0
    assert main(["thermal", "triad", str(d / "plan.toml"), str(d / "ch.csv"), "--model-out",
                 str(d / "triad.json")]) == 0
    return d


def _poison(doc, path):
    *head, last = path
    for k in head:
        doc = doc[k]
    doc[last] = float("nan")


@pytest.mark.parametrize("path", [("terms", 1, "value"), ("covariance", "matrix", 0, 0),
                                  ("valid_range", "temperature_c", 1), ("reference",)])
def test_a_thermal_model_with_a_nan_number_is_refused(models, tmp_path, path):
    doc = json.loads((models / "bias.json").read_text())
    _poison(doc, path)
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"thermal model file .*m.json: .* is nan, not a "
                       "finite number; write the model again with inertest thermal fit"):
        load_thermal_model(tmp_path / "m.json")


def test_a_thermal_model_may_leave_its_diagnostics_undetermined(models, tmp_path):
    model = load_thermal_model(models / "bias.json")
    doc = json.loads((models / "bias.json").read_text())
    doc["validation_rms"]["value"] = float("nan")
    (tmp_path / "m.json").write_text(json.dumps(doc))
    back = load_thermal_model(tmp_path / "m.json")
    assert back.coefficients.tolist() == model.coefficients.tolist()
    write_thermal_model(tmp_path / "again.json", back)  # NaN written as NaN, read back


def test_a_triad_thermal_model_with_a_nan_number_is_refused(models, tmp_path):
    doc = json.loads((models / "triad.json").read_text())
    text = json.dumps(doc)
    value = next(iter(doc["laws"].values()))["terms"]["a0"]["value"]
    (tmp_path / "m.json").write_text(text.replace(json.dumps(value), "NaN", 1))
    with pytest.raises(InputError, match="is nan, not a finite number; write the model again "
                       "with inertest thermal triad"):
        load_triad_thermal_model(tmp_path / "m.json")


def test_a_calibration_with_infinity_is_refused(tmp_path):
    (tmp_path / "c.json").write_text('{"accelerometer": {"bias": [0, Infinity, 0]}}')
    with pytest.raises(InputError, match=r"accelerometer.bias\[1\] is inf, not a finite number; "
                       "write the calibration again with inertest fit"):
        load_calibration(tmp_path / "c.json")
