"""Plan and truth files (TOML) -> :class:`inertest.plan.Plan` and coefficient vectors."""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from inertest.earth import Site
from inertest.errors import PlanError
from inertest.plan import Instrument, Plan
from inertest.procedures import procedure_module


def read_toml(path: str | os.PathLike[str], what: str) -> dict[str, Any]:
    """Parse a TOML file; syntax errors become a :class:`PlanError` naming the file."""
    p = Path(path)
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise PlanError(f"{what} file {p} is not valid TOML: {exc}") from None


def plan_from_mapping(doc: Mapping[str, Any], *, source: str = "plan") -> Plan:
    """Build a :class:`Plan` from parsed ``[site]``, ``[instrument]``, ``[procedure]`` tables."""
    for table in ("site", "procedure"):
        if not isinstance(doc.get(table), Mapping):
            raise PlanError(f"{source} has no [{table}] table; see README.md for the plan layout")
    site_t, proc_t = doc["site"], doc["procedure"]
    inst_t = doc.get("instrument", {})
    if "latitude_deg" not in site_t:
        raise PlanError(f"{source}: [site] needs latitude_deg (geodetic latitude in degrees)")
    unknown_site = sorted(set(site_t) - {"latitude_deg", "gravity", "name"})
    if unknown_site:
        raise PlanError(
            f"{source}: [site] has unknown key(s) {', '.join(unknown_site)}; "
            "known: latitude_deg, gravity (m/s^2), name"
        )
    try:
        site = Site.at(float(site_t["latitude_deg"]), _opt_float(site_t.get("gravity")))
    except (TypeError, ValueError) as exc:
        raise PlanError(f"{source}: [site] {exc}") from None
    unknown_inst = sorted(set(inst_t) - {"kind", "serial", "output_unit", "scale_factor"})
    if unknown_inst:
        raise PlanError(
            f"{source}: [instrument] has unknown key(s) {', '.join(unknown_inst)}; "
            "known: kind, serial, output_unit, scale_factor"
        )
    instrument = Instrument(
        kind=str(inst_t.get("kind", "sdf-gyro")),
        serial=str(inst_t.get("serial", "")),
        output_unit=str(inst_t.get("output_unit", "deg/h")),
        scale_factor=_opt_float(inst_t.get("scale_factor")),
    )
    kind = proc_t.get("kind")
    if kind is None:
        raise PlanError(f"{source}: [procedure] needs kind (e.g. \"polar-tumble\")")
    spec = procedure_module(str(kind)).SPEC.from_mapping(proc_t)
    return Plan(site=site, instrument=instrument, procedure=spec)


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
    return out


def _opt_float(v: object) -> float | None:
    if v is None:
        return None
    try:
        return float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise PlanError(f"expected a number, got {v!r}") from None
