"""The calibration matrix and offset of a triad as printed: each entry rounded to its std.

``calibrated = matrix @ (raw - offset)`` with ``matrix = (K (I + M))^-1`` in SI per raw unit
and ``offset = b`` in the raw unit. The standard uncertainties of the entries follow from those
of ``K_i``, ``M_ij`` and ``B_i`` to first order (``M`` is small):
``u(matrix_ii) = |matrix_ii| u(K_i)/|K_i|``, ``u(matrix_ij) = |matrix_jj| u(M_ij)`` (M in rad),
``u(offset_i) = u(B_i) / |matrix_ii|`` (B in SI); they only set the printed decimal (JCGM
100:2008, GUM 7.2.6), the full-precision values are in the JSON.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from inertest.models.triad import (
    AXES,
    MISALIGNMENT_NAMES,
    OFF_DIAGONAL,
    TriadCalibration,
    bias_unit,
)
from inertest.report.rounding import format_with_std
from inertest.results import Estimate
from inertest.units import MICRORAD_TO_RAD

_SENSOR = {"m/s^2": "accelerometer", "rad/s": "gyroscope"}


def calibration_stds(
    cal: TriadCalibration, estimates: Mapping[str, Estimate]
) -> tuple[np.ndarray, np.ndarray] | None:
    """First-order stds of ``cal.matrix`` (3, 3) and ``cal.offset`` (3,); None when unknown."""
    need = [f"K_{a}" for a in AXES] + list(MISALIGNMENT_NAMES) + [f"B_{a}" for a in AXES]
    sensor = _SENSOR.get(cal.unit)
    if sensor is None or any(n not in estimates for n in need):
        return None
    m = np.abs(np.diag(cal.matrix))
    u_m = np.zeros((3, 3))
    for i, a in enumerate(AXES):
        k = estimates[f"K_{a}"]
        u_m[i, i] = m[i] * k.std / abs(k.value) if k.value else 0.0
    for name, (i, j) in zip(MISALIGNMENT_NAMES, OFF_DIAGONAL, strict=True):
        u_m[i, j] = m[j] * estimates[name].std * MICRORAD_TO_RAD
    _, b_si = bias_unit(sensor)
    u_o = np.array([estimates[f"B_{a}"].std * b_si / m[i] for i, a in enumerate(AXES)])
    return u_m, u_o


def calibration_rows(
    cal: TriadCalibration, estimates: Mapping[str, Estimate], *, label: str = ""
) -> list[list[str]]:
    """Rows ``[label axis, matrix_i1 ± u, matrix_i2 ± u, matrix_i3 ± u, offset_i ± u]``.

    Without the estimates' stds, four significant digits (and round-off printed as 0).
    """
    stds = calibration_stds(cal, estimates)
    rows = []
    for i, a in enumerate(AXES):
        if stds is None:
            cells = [format_with_std(float(v), None) for v in (*cal.matrix[i], cal.offset[i])]
        else:
            cells = [format_with_std(float(v), float(s))
                     for v, s in zip((*cal.matrix[i], cal.offset[i]),
                                     (*stds[0][i], stds[1][i]), strict=True)]
        rows.append([f"{label} {a}".strip(), *cells])
    return rows


def result_calibration_rows(result: object) -> list[list[str]]:
    """Rows of every triad of ``result.calibration`` (with the ``result.triads`` estimates).

    Each row: ``[sensor axis, matrix entries ± u, offset ± u, unit]``.
    """
    cal = result.calibration  # type: ignore[attr-defined]
    est = {t.sensor: t.all_estimates() for t in getattr(result, "triads", ())}
    rows = []
    for sensor, tri in (("accelerometer", cal.accelerometer), ("gyroscope", cal.gyroscope)):
        if tri is None:
            continue
        rows += [[*r, f"{tri.unit} per {tri.raw_unit}"]
                 for r in calibration_rows(tri, est.get(sensor, {}), label=sensor)]
    return rows
