"""Test procedures: plan -> motion -> reduction -> identification -> result.

The one registry of procedures is :data:`REGISTRY`: a line per procedure, naming its module, the
instrument kinds it accepts and, optionally, its report section. Modules are imported only when a
plan names their kind, so ``import inertest`` stays cheap. Each procedure module provides

* ``KIND``: the ``[procedure] kind`` of plan files, and ``SPEC``: its parameter class with
  ``SPEC.from_mapping(params)`` (read by the generic reader of :mod:`inertest.procedures.spec`);
* ``fit(plan, data, *, sigma=None)`` -> a frozen result inheriting
  :class:`~inertest.results.LinearTestResult` (``kind``, ``identification``, ``details()``,
  ``to_dict()`` = the result envelope);
* ``simulate(plan, truth, *, noise=0.0, rng=None)`` -> data columns, with ``truth`` a mapping of
  coefficient names to values in the procedure's engineering units;
* optionally ``truth_quantities(truth)`` -> the truth extended by the derived quantities the
  result reports (e.g. a rate table's ``K_pos`` from ``K`` and ``asymmetry``).

A new procedure is a new module and a new line in :data:`REGISTRY`; nothing else needs editing.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType

from inertest.errors import PlanError


@dataclass(frozen=True)
class ProcedureInfo:
    """One registered procedure.

    Attributes
    ----------
    kind : str
        ``[procedure] kind`` of plan files.
    module : str
        Module implementing it (imported on first use).
    title : str
        What a test engineer calls it.
    report : str or None
        ``"module:function"`` building its report sections (``(result, truth, *, title)`` ->
        sections); None for the generic identification table.
    """

    kind: str
    module: str
    title: str
    report: str | None = None


REGISTRY: dict[str, ProcedureInfo] = {
    p.kind: p
    for p in (
        ProcedureInfo(
            "polar-tumble", "inertest.procedures.polar_tumble",
            "Floated gyro, polar-axis tumble",
            "inertest.report.tumble:polar_tumble_sections",
        ),
        ProcedureInfo(
            "local-level-tumble", "inertest.procedures.local_level_tumble",
            "Floated gyro, local-level tumble",
            "inertest.report.tumble:local_level_sections",
        ),
        ProcedureInfo(
            "gyro-rate-table", "inertest.procedures.gyro_rate_table",
            "Rate gyro on a rate table",
            "inertest.report.gyro_triad:rate_table_sections",
        ),
        ProcedureInfo(
            "gyro-triad-rotation", "inertest.procedures.gyro_triad_rotation",
            "Gyro triad, 360-degree rotations",
            "inertest.report.gyro_triad:rotation_sections",
        ),
        ProcedureInfo(
            "ferraris", "inertest.procedures.ferraris",
            "IMU, Ferraris session",
            "inertest.report.ferraris:ferraris_sections",
        ),
        ProcedureInfo(
            "triad-multiposition", "inertest.procedures.triad_multiposition",
            "Accelerometer triad, multi-position",
            "inertest.report.accelerometer:triad_sections",
        ),
        ProcedureInfo(
            "accelerometer-multipoint", "inertest.procedures.accelerometer_multipoint",
            "Pendulous accelerometer, dividing head",
            "inertest.report.accelerometer:multipoint_sections",
        ),
        ProcedureInfo(
            "centrifuge-nine-position", "inertest.procedures.centrifuge_nine_position",
            "Floated gyro, dual-axis centrifuge",
            "inertest.report.centrifuge:nine_position_sections",
        ),
        ProcedureInfo("servo-table", "inertest.procedures.servo_table",
                      "Floated gyro, servo-table drift test",
                      "inertest.report.servo_table:servo_table_sections"),
        ProcedureInfo("orientation-free", "inertest.procedures.orientation_free",
                      "IMU, multi-position without known orientations (Tedaldi)",
                      "inertest.report.orientation_free:orientation_free_sections"),
    )
}


def procedure_info(kind: str) -> ProcedureInfo:
    """The registry entry of ``kind``; a clear error for unknown kinds."""
    try:
        return REGISTRY[kind]
    except KeyError:
        raise PlanError(
            f'unknown procedure kind "{kind}"; use one of {", ".join(sorted(REGISTRY))}'
        ) from None


def procedure_module(kind: str) -> ModuleType:
    """The module implementing procedure ``kind`` (imported on first use)."""
    return importlib.import_module(procedure_info(kind).module)
