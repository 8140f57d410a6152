"""Test procedures: plan -> observables -> identification -> result.

Each procedure is a module listed in :data:`_MODULES` that provides

* ``KIND``: the ``[procedure] kind`` of plan files, and ``SPEC``: its parameter class with
  ``SPEC.from_mapping(params)``;
* ``fit(plan, data, *, sigma=None)`` -> a frozen result with ``procedure``, ``identification``
  (:class:`~inertest.results.Identification`) and ``to_dict()``;
* ``simulate(plan, truth, *, noise=0.0, rng=None)`` -> data columns, with ``truth`` a mapping of
  coefficient names to values in the procedure's engineering units;
* optionally ``truth_quantities(truth)`` -> the truth extended by the derived quantities the
  result reports (e.g. a rate table's ``K_pos`` from ``K`` and ``asymmetry``), so simulated
  results can be compared with their truth quantity by quantity.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from inertest.errors import PlanError

_MODULES: tuple[str, ...] = (
    "polar_tumble",
    "local_level_tumble",
    "gyro_rate_table",
    "gyro_triad_rotation",
    "ferraris",
    "triad_multiposition",
    "accelerometer_multipoint",
    "centrifuge_nine_position",
)

PROCEDURES: dict[str, ModuleType] = {}
for _name in _MODULES:
    _module = importlib.import_module(f"inertest.procedures.{_name}")
    PROCEDURES[_module.KIND] = _module


def procedure_module(kind: str) -> ModuleType:
    """The module implementing procedure ``kind``; a clear error for unknown kinds."""
    try:
        return PROCEDURES[kind]
    except KeyError:
        raise PlanError(
            f'unknown procedure kind "{kind}"; use one of {", ".join(sorted(PROCEDURES))}'
        ) from None
