"""Test procedures: plan -> observables -> identification -> result.

:data:`PROCEDURES` maps each ``[procedure] kind`` of a plan file to its module, which provides a
``Spec`` class with ``from_mapping``, and ``fit(plan, data, sigma=None)`` and
``simulate(plan, coefficients, noise=..., rng=...)`` functions.
"""

from __future__ import annotations

from types import ModuleType

from inertest.errors import PlanError
from inertest.procedures import local_level_tumble, polar_tumble

PROCEDURES: dict[str, ModuleType] = {
    polar_tumble.KIND: polar_tumble,
    local_level_tumble.KIND: local_level_tumble,
}
SPECS = {
    polar_tumble.KIND: polar_tumble.PolarTumbleSpec,
    local_level_tumble.KIND: local_level_tumble.LocalLevelTumbleSpec,
}


def procedure_module(kind: str) -> ModuleType:
    """The module implementing procedure ``kind``; a clear error for unknown kinds."""
    try:
        return PROCEDURES[kind]
    except KeyError:
        raise PlanError(
            f'unknown procedure kind "{kind}"; use one of {", ".join(sorted(PROCEDURES))}'
        ) from None
