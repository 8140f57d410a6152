"""Plan and truth files (TOML) -> :class:`inertest.plan.Plan` and coefficient vectors."""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from inertest.earth import Site
from inertest.errors import PlanError
from inertest.plan import (
    INSTRUMENT_KINDS,
    Field,
    Instrument,
    Plan,
    check_finite_document,
    check_known_keys,
    read_fields,
    read_test_table,
    toml_table,
)
from inertest.procedures import procedure


def read_toml(path: str | os.PathLike[str], what: str) -> dict[str, Any]:
    """Parse a TOML file; syntax errors and NaN/inf numbers are a PlanError naming the file."""
    p = Path(path)
    try:
        with p.open("rb") as fh:
            doc = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise PlanError(f"{what} file {p} is not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise PlanError(f"{what} file {p} is not UTF-8 text; save it as UTF-8") from None
    except IsADirectoryError:
        raise PlanError(f"{what} file {p} is a folder; give the TOML file") from None
    check_finite_document(doc, f"{what} file {p}", fix="give a finite number")
    return doc


#: Top-level tables of a plan file.
PLAN_TABLES = ("site", "instrument", "procedure", "test")
SITE_FIELDS = (
    Field("latitude_deg", unit="deg", minimum=-90.0, maximum=90.0,
          doc="geodetic latitude in degrees"),
    Field("gravity", default=None, unit="m/s^2", positive=True),
    Field("name", "text", default=""),
)
INSTRUMENT_FIELDS = (
    Field("kind", "text", default="sdf-gyro", choices=INSTRUMENT_KINDS),
    Field("serial", "text", default=""),
    Field("output_unit", "text", default="deg/h"),
    Field("scale_factor", default=None, unit="deg/h per output unit"),
)


def plan_from_mapping(doc: Mapping[str, Any], *, source: str = "plan") -> Plan:
    """Build a :class:`Plan` from parsed ``[site]``, ``[instrument]``, ``[procedure]`` tables.

    Every table is read by declared fields (:func:`inertest.plan.read_fields`): a misspelt
    table or key, a boolean where a number belongs or a value out of range is an error naming
    the fix, never a silent default.
    """
    check_known_keys(doc, set(PLAN_TABLES), source)
    for table in ("site", "procedure"):
        if not isinstance(doc.get(table), Mapping):
            raise PlanError(f"{source} has no [{table}] table; see README.md for the plan layout")
    site_t, proc_t = doc["site"], doc["procedure"]
    inst_t = toml_table(doc, "instrument", source)
    site_v = read_fields(site_t, SITE_FIELDS, f"{source}: [site]")
    site = Site.at(site_v["latitude_deg"], site_v["gravity"])
    inst_v = read_fields(inst_t, INSTRUMENT_FIELDS, f"{source}: [instrument]")
    instrument = Instrument(**inst_v)
    kind = proc_t.get("kind")
    if kind is None:
        raise PlanError(f"{source}: [procedure] needs kind (e.g. \"polar-tumble\")")
    if not isinstance(kind, str):
        raise PlanError(f"{source}: [procedure] kind must be text, got {kind!r}")
    spec = procedure(kind).spec.from_mapping(proc_t)
    test = (read_test_table(doc["test"], f"{source}: [test]") if "test" in doc else None)
    return Plan(site=site, instrument=instrument, procedure=spec, test=test)


def load_plan(path: str | os.PathLike[str]) -> Plan:
    """Read a plan file (TOML, layout in :mod:`inertest.plan`)."""
    return plan_from_mapping(read_toml(path, "plan"), source=f"plan {path}")


def load_truth(path: str | os.PathLike[str]) -> dict[str, float]:
    """Read true coefficients of a virtual instrument, in the procedure's engineering units.

    The file holds ``NAME = value`` pairs, at top level or in a ``[coefficients]`` table (for an
    SDF gyro: DF, DI, ... in deg/h, deg/h/g, deg/h/g^2). Names are checked by the procedure.
    """
    doc = read_toml(path, "truth")
    values = doc.get("coefficients", doc)
    if not isinstance(values, Mapping):
        raise PlanError(f"truth file {path}: [coefficients] must be a table of NAME = value")
    out = {}
    for k, v in values.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise PlanError(f"truth file {path}: {k} must be a number, got {v!r}")
        out[str(k)] = float(v)
    if not out:  # every coefficient zero by accident (an empty or mistyped file)
        raise PlanError(f"truth file {path} gives no coefficient; write NAME = value pairs "
                        "(give 0 explicitly for a coefficient that is zero)")
    return out
