"""Triad calibration files: the ``fit --json`` result of a triad procedure, or a bare block."""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path

from inertest.errors import InputError
from inertest.models.imu import ImuCalibration
from inertest.plan import check_finite_document
from inertest.results import read_envelope


def read_json_object(path: str | os.PathLike[str], what: str, *,
                     fix: str = "write the file again with inertest",
                     may_be_nan: Iterable[str] = (), finite: bool = True) -> dict:
    """The JSON object in ``path``; anything else is an InputError naming the file.

    A NaN or infinite number (Python's JSON reads ``NaN``, ``Infinity``) is refused naming its
    key and ``fix``, except under the diagnostic keys ``may_be_nan``
    (:func:`inertest.plan.check_finite_document`); ``finite=False`` leaves that to the caller.
    """
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{what} file {p} is not JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise InputError(f"{what} file {p} must hold a JSON object")
    if finite:
        check_finite_document(doc, f"{what} file {p}", fix=fix, error=InputError,
                              may_be_nan=may_be_nan)
    return doc


def load_calibration(path: str | os.PathLike[str], *, what: str = "calibration") -> ImuCalibration:
    """The triad calibration held in ``path``.

    Accepted: a result envelope (``result.calibration``; its schema version checked by
    :func:`inertest.results.read_envelope`), or a bare ``{"accelerometer": ..., "gyroscope":
    ...}`` block.
    """
    doc = read_json_object(path, what, fix="write the calibration again with inertest fit "
                           "PLAN DATA --json")
    if "kind" in doc or "schema_version" in doc:
        doc = read_envelope(doc, source=f"{what} file {Path(path)}")
    result = doc.get("result")
    body = result if isinstance(result, dict) else doc
    block = body.get("calibration", body)
    if not isinstance(block, dict):
        raise InputError(f'"calibration" in {Path(path)} must be an object')
    return ImuCalibration.from_dict(block)
