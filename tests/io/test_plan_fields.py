"""Plans are read strictly: misspelt tables and keys, booleans for numbers, values out of range."""

from __future__ import annotations

import pytest

from inertest.errors import PlanError
from inertest.io.plan_file import load_plan, plan_from_mapping
from inertest.plan import Field, read_fields

GOOD = {
    "site": {"latitude_deg": 34.25},
    "instrument": {"kind": "sdf-gyro", "serial": "FG-1", "output_unit": "mA",
                   "scale_factor": 12.5},
    "procedure": {"kind": "polar-tumble"},
}


def _with(table: str, **changes) -> dict:
    doc = {k: dict(v) for k, v in GOOD.items()}
    doc[table].update(changes)
    return doc


def test_a_good_plan_reads():
    plan = plan_from_mapping(GOOD)
    assert plan.instrument.scale_factor == 12.5 and plan.kind == "polar-tumble"


def test_misspelt_table_is_an_error_with_a_suggestion():
    doc = dict(GOOD)
    doc["instrumnet"] = doc.pop("instrument")
    with pytest.raises(PlanError, match='instrumnet.*did you mean "instrument"'):
        plan_from_mapping(doc)


@pytest.mark.parametrize(("table", "change", "message"), [
    ("site", {"latitude_deg": True}, "latitude_deg must be a number"),
    ("site", {"latitude_deg": "34"}, "latitude_deg must be a number"),
    ("site", {"latitude_deg": 91.0}, r"latitude_deg must lie in \[-90.0, 90.0\]"),
    ("site", {"gravity": 0}, "gravity must be positive"),
    ("site", {"latitud_deg": 3}, 'did you mean "latitude_deg"'),
    ("instrument", {"scale_factor": False}, "scale_factor must be a number"),
    ("instrument", {"serial": 17}, "serial must be text"),
    ("instrument", {"kind": "sdf-gyr"}, 'did you mean "sdf-gyro"'),
    ("instrument", {"scalefactor": 1.0}, 'did you mean "scale_factor"'),
    ("procedure", {"kind": 3}, "kind must be text"),
])
def test_wrong_types_and_names_are_errors(table, change, message):
    with pytest.raises(PlanError, match=message):
        plan_from_mapping(_with(table, **change))


def test_field_reader_lists_and_bounds():
    fields = (Field("rates", "numbers", unit="deg/s", minimum=-100, maximum=100),
              Field("n", "integer", default=1, minimum=1))
    assert read_fields({"rates": [1, 2.5]}, fields, "t") == {"rates": (1.0, 2.5), "n": 1}
    with pytest.raises(PlanError, match="must be a non-empty list"):
        read_fields({"rates": []}, fields, "t")
    with pytest.raises(PlanError, match=r"must lie in"):
        read_fields({"rates": [1, 200]}, fields, "t")
    with pytest.raises(PlanError, match="whole number"):
        read_fields({"rates": [1], "n": 2.5}, fields, "t")
    with pytest.raises(PlanError, match="needs rates"):
        read_fields({}, fields, "t")


def test_non_utf8_plan_is_a_clear_error(tmp_path):
    path = tmp_path / "plan.toml"
    path.write_bytes(b'[site]\nlatitude_deg = 34.0\nname = "\xff\xfe"\n')
    with pytest.raises(PlanError, match="not UTF-8"):
        load_plan(path)
