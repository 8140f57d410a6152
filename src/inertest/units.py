"""Engineering units <-> SI, in one place.

Inside inertest every quantity is SI: rad, s, m, m/s^2, rad/s. Engineering units appear only at
the edges (plans, data files, reports). The unit "g" is standard gravity ``G0`` = 9.80665 m/s^2
(ISO 80000-3; CGPM 1901), never the local gravity of the site.

Each constant is named after the conversion it performs: multiply a value in the first unit to
get the value in the second, e.g. ``x_rad_s = x_deg_h * DEG_PER_H_TO_RAD_PER_S``.
"""

from __future__ import annotations

import math

from inertest.errors import UnitError

#: Standard gravity [m/s^2] (the unit "g").
G0 = 9.80665

DEG_TO_RAD = math.pi / 180.0
ARCSEC_TO_RAD = DEG_TO_RAD / 3600.0
ARCMIN_TO_RAD = DEG_TO_RAD / 60.0
HOUR_TO_S = 3600.0
DEG_PER_H_TO_RAD_PER_S = DEG_TO_RAD / HOUR_TO_S
DEG_PER_S_TO_RAD_PER_S = DEG_TO_RAD
#: Angle random walk: deg/sqrt(h) -> rad/sqrt(s).
DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S = DEG_TO_RAD / math.sqrt(HOUR_TO_S)
#: Rate random walk: deg/h/sqrt(h) -> rad/s/sqrt(s).
DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S = DEG_PER_H_TO_RAD_PER_S / math.sqrt(HOUR_TO_S)
#: Velocity random walk: m/s/sqrt(h) -> m/s/sqrt(s).
M_PER_S_PER_SQRT_H_TO_M_PER_S_PER_SQRT_S = 1.0 / math.sqrt(HOUR_TO_S)
G_TO_M_PER_S2 = G0
MICRO_G_TO_M_PER_S2 = 1e-6 * G0
MILLI_G_TO_M_PER_S2 = 1e-3 * G0
PPM_TO_RATIO = 1e-6
#: Microradian -> rad (misalignment angles are reported in urad, IEEE Std 952 specification format).
MICRORAD_TO_RAD = 1e-6
#: Gyro g-sensitivity: deg/h per g -> rad/s per m/s^2.
DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2 = DEG_PER_H_TO_RAD_PER_S / G0
#: International nautical mile, m.
NAUTICAL_MILE_M = 1852.0

#: Angular-rate units accepted at the edges, with their factor to rad/s.
RATE_UNITS: dict[str, float] = {
    "rad/s": 1.0,
    "deg/s": DEG_PER_S_TO_RAD_PER_S,
    "deg/h": DEG_PER_H_TO_RAD_PER_S,
}

#: Electrical output units of torque-rebalance loops (need a scale factor in deg/h per unit).
ELECTRICAL_UNITS: dict[str, float] = {"A": 1.0, "mA": 1e-3, "uA": 1e-6, "V": 1.0, "mV": 1e-3}

#: Raw digital outputs (counts, LSB); the procedure estimates or is given their scale.
COUNT_UNITS: dict[str, float] = {"count": 1.0}

#: Specific-force units accepted at the edges, with their factor to m/s^2.
ACCEL_UNITS: dict[str, float] = {
    "m/s^2": 1.0,
    "g": G0,
    "mg": MILLI_G_TO_M_PER_S2,
    "ug": MICRO_G_TO_M_PER_S2,
}


def rate_to_si(value, unit: str):
    """Convert an angular rate from ``unit`` (one of :data:`RATE_UNITS`) to rad/s."""
    return value * _factor(unit, RATE_UNITS, "angular-rate")


def rate_from_si(value, unit: str):
    """Convert an angular rate in rad/s to ``unit`` (one of :data:`RATE_UNITS`)."""
    return value / _factor(unit, RATE_UNITS, "angular-rate")


def accel_to_si(value, unit: str):
    """Convert a specific force from ``unit`` (one of :data:`ACCEL_UNITS`) to m/s^2."""
    return value * _factor(unit, ACCEL_UNITS, "specific-force")


def accel_from_si(value, unit: str):
    """Convert a specific force in m/s^2 to ``unit`` (one of :data:`ACCEL_UNITS`)."""
    return value / _factor(unit, ACCEL_UNITS, "specific-force")


def gyro_coefficient_unit(g_power: int) -> str:
    """Engineering unit of a gyro drift coefficient multiplying ``f**g_power`` (f in g).

    ``0 -> "deg/h"``, ``1 -> "deg/h/g"``, ``2 -> "deg/h/g^2"``.
    """
    if g_power == 0:
        return "deg/h"
    if g_power == 1:
        return "deg/h/g"
    return f"deg/h/g^{g_power}"


def _factor(unit: str, table: dict[str, float], what: str) -> float:
    try:
        return table[unit]
    except KeyError:
        known = ", ".join(f'"{u}"' for u in table)
        raise UnitError(f'unknown {what} unit "{unit}"; use one of {known}') from None
