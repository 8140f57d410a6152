"""The rate-gyro model: one gyro axis whose output is a rate reading in raw units.

A rate gyro (a single-axis FOG, RLG, MEMS gyro, or one axis of a triad or IMU) reads
``E = K (w_in + B)`` [+ asymmetry and second-order terms, :mod:`inertest.procedures.
gyro_rate_table`]. Its raw reading is a rate in the instrument's output unit; the rules that turn
that unit into SI and name the scale factor's unit are written here once, for every gyro
procedure (rate table, triad rotations, navigation-mode calibration):

* a rate output (``deg/h``, ``deg/s``, ``rad/s``) is converted to rad/s and its scale factor is
  dimensionless (``"1"``);
* a pulse output (``count``) is read as the pulse rate count/s, so K is in ``count/deg``
  (count/s per deg/s, the same number as counts per degree turned);
* an electrical output (``V``, ``mA``) stays in its unit, K in ``<unit>/(deg/s)``
  (:func:`inertest.models.triad.scale_unit`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from inertest.errors import PlanError
from inertest.models import triad
from inertest.plan import Instrument
from inertest.units import RATE_UNITS

#: Instrument kinds a gyro rate-table test accepts.
GYRO_KINDS = ("rate-gyro", "gyro-triad", "imu", "sdf-gyro")


def raw_rate_per_si(output_unit: str) -> float:
    """Raw output per SI rate unit: ``1/RATE_UNITS[u]`` for rate outputs, 1 otherwise.

    A rate output is converted to rad/s (its scale factor is then dimensionless); pulse counts
    (read as count/s) and electrical outputs stay in their own unit.
    """
    return 1.0 / RATE_UNITS[output_unit] if output_unit in RATE_UNITS else 1.0


def raw_rate_unit(output_unit: str) -> str:
    """Unit of a raw rate reading: ``count/s`` for pulse outputs, the output unit otherwise."""
    return "count/s" if output_unit == "count" else output_unit


def scale_unit(output_unit: str) -> tuple[str, float]:
    """Unit of K and its SI value [raw SI per rad/s]: the triad model's rule for one gyro.

    ``("1", 1.0)`` for rate outputs, ``("count/deg", 180/pi)`` for pulses (count/s per deg/s),
    ``("<u>/(deg/s)", 180/pi)`` otherwise (:func:`inertest.models.triad.scale_unit`).
    """
    su = triad.scale_unit(raw_rate_unit(output_unit), "gyroscope")
    return su.unit, su.si_per_unit


def check_gyro(instrument: Instrument, kind: str) -> None:
    """Only gyros (single axis, triad, IMU) can be tested on a rate table."""
    if instrument.kind not in GYRO_KINDS:
        raise PlanError(
            f'{kind} tests a gyro, but [instrument] kind is "{instrument.kind}"; use one of '
            f"{', '.join(GYRO_KINDS)}"
        )


def triad_from_truth(truth: Mapping[str, float], output_unit: str
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``A`` [raw SI per rad/s] and ``b`` [raw SI rate] of a virtual gyro triad's truth.

    ``K_x..K_z`` [K unit, :func:`scale_unit`; default 1 for rate outputs], ``M_ij`` [urad],
    ``B_x..B_z`` [deg/h] (:func:`inertest.models.triad.model_from_truth`).
    """
    return triad.model_from_truth(truth, "gyroscope",
                                  triad.scale_unit(raw_rate_unit(output_unit), "gyroscope"))
