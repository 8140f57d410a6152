"""Thermal model files: the JSON written by ``inertest thermal fit --model-out``.

The document (format :data:`~inertest.models.thermal.FORMAT_VERSION`) holds plain
numbers only -- polynomial coefficients with covariance, or the network's weights, biases and
scaling -- never a pickled object, so it is safe to load from anyone and readable by any
program (see :mod:`inertest.models.thermal` for the equations).

``inertest thermal triad --model-out`` writes a triad thermal model
(``"kind": "thermal-triad-model"``, :class:`~inertest.procedures.thermal_triad.
TriadThermalModel`): the K, M, B laws in temperature with their covariance, in the same way.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from inertest.errors import InputError
from inertest.io.atomic import write_text
from inertest.io.calibration_file import read_json_object
from inertest.models.thermal import MODEL_KIND, ThermalModel, model_from_dict
from inertest.models.thermal_triad import MODEL_KIND as TRIAD_MODEL_KIND
from inertest.models.thermal_triad import TriadThermalModel

_M = TypeVar("_M", ThermalModel, TriadThermalModel)
#: Keys of a model document that may be NaN: goodness-of-fit figures that a fit without
#: degrees of freedom or validation cycles cannot determine. Nothing under them is computed with.
DIAGNOSTICS = ("validation_rms", "noise", "chi2", "p_value")


def is_thermal_model(doc: dict) -> bool:
    """Whether a JSON document is a thermal model (``"kind": "thermal-model"``)."""
    return doc.get("kind") == MODEL_KIND


def is_triad_thermal_model(doc: dict) -> bool:
    """Whether a JSON document is a triad thermal model (``"kind": "thermal-triad-model"``)."""
    return doc.get("kind") == TRIAD_MODEL_KIND


def load_triad_thermal_model(path: str | os.PathLike[str]) -> TriadThermalModel:
    """The triad thermal model in ``path`` (written by ``thermal triad --model-out``)."""
    return _load_model(path, "triad thermal model", TriadThermalModel.from_dict,
                       result_kind="thermal-triad", command="thermal triad", args="PLAN DATA")


def load_thermal_model(path: str | os.PathLike[str]) -> ThermalModel:
    """The thermal model in ``path`` (written by :func:`write_thermal_model`)."""
    return _load_model(path, "thermal model", model_from_dict,
                       result_kind="thermal-compensation", command="thermal fit", args="DATA")


def _load_model(path: str | os.PathLike[str], what: str, from_dict: Callable[[dict], _M], *,
                result_kind: str, command: str, args: str) -> _M:
    """The model in ``path``; the ``result_kind`` result of ``command`` is refused with the fix."""
    doc = read_json_object(path, what, fix=f"write the model again with inertest {command} "
                           f"{args} --model-out MODEL.json", may_be_nan=DIAGNOSTICS)
    if doc.get("kind") == result_kind:
        raise InputError(f"{path} is a {command} result, not a model; write the model with "
                         f"inertest {command} {args} --model-out MODEL.json")
    try:
        return from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def write_thermal_model(path: str | os.PathLike[str],
                        model: ThermalModel | TriadThermalModel) -> Path:
    """Write ``model`` as indented JSON to ``path`` (atomically: whole or not at all)."""
    return write_text(path, json.dumps(model.to_dict(), indent=1) + "\n")
