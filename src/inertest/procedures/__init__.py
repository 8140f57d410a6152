"""Test procedures: plan -> motion -> reduction -> identification -> result.

Each procedure is a subclass of :class:`~inertest.procedures.base.Procedure` in a module of its
own, named after its ``[procedure] kind`` (``polar-tumble`` in ``polar_tumble.py``), that
exposes the procedure as ``PROCEDURE``. :data:`REGISTRY` finds them there: a plan's kind imports
only its own module (``import inertest`` and ``--help`` stay cheap), and the list of kinds comes
from the package's modules. So a new procedure is one new module (with its test and its example);
no other file lists it::

    proc = REGISTRY["polar-tumble"]          # the PolarTumble procedure
    result = proc.fit(plan, data)            # written once, in Procedure.fit
    data = proc.simulate(plan, {"DI": 0.8}, noise=0.002, rng=1)

Modules without ``PROCEDURE`` (the shared parts ``base``, ``spec``, ``sdf_drift``; analyses run
by their own commands) are not procedures.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

from inertest.errors import PlanError

if TYPE_CHECKING:
    from inertest.procedures.base import Procedure


def _module_of(kind: str) -> str:
    return f"{__name__}.{kind.replace('-', '_')}"


class _Registry(Mapping[str, "Procedure[Any, Any, Any]"]):
    """``{kind: procedure}``, each procedure's module imported on first use."""

    def __init__(self) -> None:
        self._loaded: dict[str, Procedure[Any, Any, Any] | None] = {}
        self._kinds: tuple[str, ...] | None = None

    def _load(self, kind: str) -> Procedure[Any, Any, Any] | None:
        if kind not in self._loaded:
            proc = None
            if kind.replace("-", "_").isidentifier() and "_" not in kind:
                try:
                    module = importlib.import_module(_module_of(kind))
                except ModuleNotFoundError as exc:
                    if exc.name != _module_of(kind):
                        raise
                else:
                    found = getattr(module, "PROCEDURE", None)
                    proc = found if getattr(found, "kind", None) == kind else None
            self._loaded[kind] = proc
        return self._loaded[kind]

    def __getitem__(self, kind: str) -> Procedure[Any, Any, Any]:
        proc = self._load(kind) if isinstance(kind, str) else None
        if proc is None:
            raise KeyError(kind)
        return proc

    def __contains__(self, kind: object) -> bool:
        return isinstance(kind, str) and self._load(kind) is not None

    def __iter__(self) -> Iterator[str]:
        if self._kinds is None:  # every module of the package that exposes a PROCEDURE
            names = sorted(m.name for m in pkgutil.iter_modules(__path__)
                           if not m.name.startswith("_"))
            self._kinds = tuple(k for k in (n.replace("_", "-") for n in names) if k in self)
        return iter(self._kinds)

    def __len__(self) -> int:
        return len(tuple(iter(self)))


#: The procedures by ``[procedure] kind``.
REGISTRY: Mapping[str, Procedure[Any, Any, Any]] = _Registry()


def procedure(kind: str) -> Procedure[Any, Any, Any]:
    """The procedure of ``kind``; a clear error for unknown kinds."""
    if kind not in REGISTRY:
        raise PlanError(
            f'unknown procedure kind "{kind}"; use one of {", ".join(sorted(REGISTRY))}')
    return REGISTRY[kind]
