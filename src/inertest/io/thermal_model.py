"""Thermal model files: the JSON written by ``inertest thermal fit --model-out``.

The document (format :data:`~inertest.procedures.thermal_model.FORMAT_VERSION`) holds plain
numbers only -- polynomial coefficients with covariance, or the network's weights, biases and
scaling -- never a pickled object, so it is safe to load from anyone and readable by any
program (see :mod:`inertest.procedures.thermal_model` for the equations).

``inertest thermal triad --model-out`` writes a triad thermal model
(``"kind": "thermal-triad-model"``, :class:`~inertest.procedures.thermal_triad.
TriadThermalModel`): the K, M, B laws in temperature with their covariance, in the same way.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from inertest.errors import InputError
from inertest.io.atomic import write_text
from inertest.procedures.thermal_model import MODEL_KIND, ThermalModel, model_from_dict
from inertest.procedures.thermal_triad import MODEL_KIND as TRIAD_MODEL_KIND
from inertest.procedures.thermal_triad import TriadThermalModel


def read_json_object(path: str | os.PathLike[str], what: str) -> dict:
    """The JSON object in ``path``; anything else is an InputError naming the file."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{what} file {p} is not JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise InputError(f"{what} file {p} must hold a JSON object")
    return doc


def is_thermal_model(doc: dict) -> bool:
    """Whether a JSON document is a thermal model (``"kind": "thermal-model"``)."""
    return doc.get("kind") == MODEL_KIND


def is_triad_thermal_model(doc: dict) -> bool:
    """Whether a JSON document is a triad thermal model (``"kind": "thermal-triad-model"``)."""
    return doc.get("kind") == TRIAD_MODEL_KIND


def load_triad_thermal_model(path: str | os.PathLike[str]) -> TriadThermalModel:
    """The triad thermal model in ``path`` (written by ``thermal triad --model-out``)."""
    doc = read_json_object(path, "triad thermal model")
    if doc.get("kind") == "thermal-triad":
        raise InputError(f"{path} is a thermal triad result, not a model; write the model with "
                         "inertest thermal triad PLAN DATA --model-out MODEL.json")
    try:
        return TriadThermalModel.from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def load_thermal_model(path: str | os.PathLike[str]) -> ThermalModel:
    """The thermal model in ``path`` (written by :func:`write_thermal_model`)."""
    doc = read_json_object(path, "thermal model")
    if doc.get("kind") == "thermal-compensation":
        raise InputError(f"{path} is a thermal fit result, not a model; write the model with "
                         "inertest thermal fit DATA --model-out MODEL.json")
    try:
        return model_from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def write_thermal_model(path: str | os.PathLike[str],
                        model: ThermalModel | TriadThermalModel) -> Path:
    """Write ``model`` as indented JSON to ``path`` (atomically: whole or not at all)."""
    return write_text(path, json.dumps(model.to_dict(), indent=1) + "\n")
