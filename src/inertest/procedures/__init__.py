"""Test procedures: plan -> motion -> reduction -> identification -> result.

Each procedure is a subclass of :class:`~inertest.procedures.base.Procedure` in a module of its
own; :data:`REGISTRY` is the one registry of them, by ``[procedure] kind``. A procedure's module is
imported only when a plan names its kind (``import inertest`` stays cheap), so the registry lists
``"module:Class"`` and hands out the procedure itself on first use::

    proc = REGISTRY["polar-tumble"]          # the PolarTumble procedure
    result = proc.fit(plan, data)            # written once, in Procedure.fit
    data = proc.simulate(plan, {"DI": 0.8}, noise=0.002, rng=1)

A new procedure is a new module (its class, its parameter class, its result) and a line here;
nothing else needs editing (docs/architecture.md).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

from inertest.errors import PlanError

if TYPE_CHECKING:
    from inertest.procedures.base import Procedure

#: ``kind: "module:Class"`` of every procedure, in the order of the docs.
_CLASSES: dict[str, str] = {
    "polar-tumble": "inertest.procedures.polar_tumble:PolarTumble",
    "local-level-tumble": "inertest.procedures.local_level_tumble:LocalLevelTumble",
    "gyro-rate-table": "inertest.procedures.gyro_rate_table:GyroRateTable",
    "gyro-triad-rotation": "inertest.procedures.gyro_triad_rotation:GyroTriadRotation",
    "ferraris": "inertest.procedures.ferraris:Ferraris",
    "triad-multiposition": "inertest.procedures.triad_multiposition:TriadMultiposition",
    "accelerometer-multipoint":
        "inertest.procedures.accelerometer_multipoint:AccelerometerMultipoint",
    "centrifuge-nine-position":
        "inertest.procedures.centrifuge_nine_position:CentrifugeNinePosition",
    "servo-table": "inertest.procedures.servo_table:ServoTableDrift",
    "orientation-free": "inertest.procedures.orientation_free:OrientationFree",
}


class _Registry(Mapping[str, "Procedure[Any, Any, Any]"]):
    """``{kind: procedure}``, each procedure's module imported on first use."""

    def __init__(self, classes: Mapping[str, str]) -> None:
        self._classes = dict(classes)
        self._loaded: dict[str, Procedure[Any, Any, Any]] = {}

    def __getitem__(self, kind: str) -> Procedure[Any, Any, Any]:
        if kind not in self._loaded:
            module, _, name = self._classes[kind].partition(":")
            self._loaded[kind] = getattr(importlib.import_module(module), name)()
        return self._loaded[kind]

    def __iter__(self) -> Iterator[str]:
        return iter(self._classes)

    def __len__(self) -> int:
        return len(self._classes)

    def __contains__(self, kind: object) -> bool:
        return kind in self._classes


#: The procedures by ``[procedure] kind``.
REGISTRY: Mapping[str, Procedure[Any, Any, Any]] = _Registry(_CLASSES)


def procedure(kind: str) -> Procedure[Any, Any, Any]:
    """The procedure of ``kind``; a clear error for unknown kinds."""
    if kind not in REGISTRY:
        raise PlanError(
            f'unknown procedure kind "{kind}"; use one of {", ".join(sorted(REGISTRY))}')
    return REGISTRY[kind]
