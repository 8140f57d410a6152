"""The lab equipment file (inertest.quality.lab) and a plan's [test] table (inertest.plan)."""

import datetime as dt
import math
from pathlib import Path

import pytest

from inertest.errors import PlanError
from inertest.plan import read_test_table
from inertest.quality.lab import (
    LabFileError,
    equipment_from_mapping,
    overdue_messages,
    read_equipment,
    select_equipment,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lab" / "equipment.toml"


def _doc(**over):
    item = {"id": "RT-02", "name": "Two-axis rate table", "serial": "4711",
            "calibrated": dt.date(2026, 3, 1), "calibration_due": dt.date(2027, 3, 1),
            "type_b": {"rate_ppm": 5.0, "tilt_urad": 20.0, "angle_arcsec": 2.0}}
    item.update(over)
    return {"equipment": [item]}


def test_example_lab_file_reads_with_dates_and_si_type_b():
    lab = read_equipment(EXAMPLE)
    rt = lab["RT-02"]
    assert rt.calibration_due == dt.date(2027, 3, 1)
    si = rt.type_b_si
    # 1 arcsec = pi / 648000 rad; 1 urad = 1e-6 rad; 1 ppm = 1e-6 (definitions)
    assert si["angle"] == pytest.approx(2.0 * math.pi / 648000.0, rel=1e-15)
    assert si["tilt"] == pytest.approx(20e-6, rel=1e-15)
    assert si["rate"] == pytest.approx(5e-6, rel=1e-15)
    assert {t.key: t.value for t in rt.type_b} == {"rate_ppm": 5.0, "tilt_urad": 20.0,
                                                   "angle_arcsec": 2.0}
    # 1 mGal = 1e-5 m/s^2 (definition of the Gal, 1 cm/s^2)
    assert lab["GRAV-01"].type_b_si["gravity"] == pytest.approx(0.05e-5, rel=1e-15)
    assert lab["CF-01"].type_b_si["radius"] == pytest.approx(15e-6, rel=1e-15)


def test_overdue_on_test_date():
    rt = equipment_from_mapping(_doc())["RT-02"]
    assert not rt.overdue(dt.date(2027, 3, 1))
    assert rt.overdue(dt.date(2027, 3, 2))
    (msg,) = overdue_messages([rt], dt.date(2027, 4, 1))
    assert "RT-02" in msg and "2027-03-01" in msg
    assert rt.to_dict(dt.date(2027, 4, 1))["calibration_overdue"] is True


@pytest.mark.parametrize("over, words", [
    ({"serail": "1"}, ["serail", 'did you mean "serial"']),
    ({"calibration_due": "next year"}, ["calibration_due", "date"]),
    ({"calibration_due": dt.date(2020, 1, 1)}, ["before"]),
    ({"type_b": {"tilt": 3.0}}, ["tilt", "suffix"]),
    ({"type_b": {"tilt_urad": "big"}}, ["tilt_urad", "number"]),
    ({"type_b": {"tilt_urad": -1.0}}, ["tilt_urad"]),
])
def test_bad_lab_entries_name_the_problem(over, words):
    with pytest.raises(LabFileError) as exc:
        equipment_from_mapping(_doc(**over), source="lab.toml")
    for w in words:
        assert w in str(exc.value)


def test_duplicate_id_and_missing_file(tmp_path):
    doc = _doc()
    doc["equipment"].append(dict(doc["equipment"][0]))
    with pytest.raises(LabFileError, match="twice"):
        equipment_from_mapping(doc)
    with pytest.raises(LabFileError, match="does not exist"):
        read_equipment(tmp_path / "none.toml")


def test_unknown_equipment_id_names_both_files():
    lab = equipment_from_mapping(_doc())
    with pytest.raises(PlanError) as exc:
        select_equipment(lab, ["RT-03"], plan_source="plan p.toml", lab_source="lab l.toml")
    msg = str(exc.value)
    assert "p.toml" in msg and "l.toml" in msg and "RT-03" in msg and '"RT-02"' in msg


def test_test_table_reads_and_rejects_misspelt_keys():
    t = read_test_table({"operator": "A. Engineer", "date": dt.date(2026, 11, 20),
                         "equipment": ["RT-02"], "temperature_C": 22.5, "warm_up_min": 60},
                        "plan: [test]")
    assert t.equipment == ("RT-02",) and t.date == dt.date(2026, 11, 20)
    assert t.environment()["temperature"] == {"value": 22.5, "unit": "degC"}
    with pytest.raises(PlanError, match='did you mean "temperature_C"'):
        read_test_table({"temperature_c": 22.5}, "plan: [test]")
    with pytest.raises(PlanError, match="humidity_pct"):
        read_test_table({"humidity_pct": 140}, "plan: [test]")


def test_laboratory_and_test_item_read_and_reject_what_is_wrong():
    """[laboratory] of a lab file, the job and the item of a plan's [test] (ISO/IEC 17025:2017
    7.8.2.1 b, e, f, h; 7.8.3.1 a): empty when absent, named errors when wrong."""
    from inertest.quality.lab import laboratory_from_mapping, read_laboratory

    assert read_laboratory(EXAMPLE)["name"].startswith("Example Inertial Test Laboratory")
    assert laboratory_from_mapping(_doc()) == {}
    lab = laboratory_from_mapping({**_doc(), "laboratory": {"name": "L", "accreditation": ""}})
    assert lab == {"name": "L"}
    equipment_from_mapping({**_doc(), "laboratory": {"name": "L"}})  # a known table
    with pytest.raises(LabFileError, match='did you mean "address"'):
        laboratory_from_mapping({"laboratory": {"adress": "x"}}, source="lab.toml")
    t = read_test_table({"customer": "C Ltd", "customer_contact": "c@example.org",
                         "receipt_date": dt.date(2026, 11, 16),
                         "condition_on_receipt": "sealed", "deviations": [],
                         "data_origin": "measured"}, "plan: [test]")
    assert t.item.to_dict() == {"customer": "C Ltd", "customer_contact": "c@example.org",
                                "receipt_date": "2026-11-16", "condition_on_receipt": "sealed",
                                "deviations": [], "data_origin": "measured"}
    # not stated: None, and deviations None (not stated) differs from [] (none)
    assert set(read_test_table({}, "[test]").item.to_dict().values()) == {None}
    assert read_test_table({"deviations": "one step left out"}, "[test]").item.deviations == (
        "one step left out",)
    for bad, word in (({"data_origin": "simulation"}, "measured, simulated"),
                      ({"receipt_date": "16.11.2026"}, "receipt_date"),
                      ({"deviations": [3]}, "deviations"),
                      ({"custommer": "C"}, 'did you mean "customer"')):
        with pytest.raises(PlanError, match=word):
            read_test_table(bad, "plan: [test]")
