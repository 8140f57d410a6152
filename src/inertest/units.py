"""Engineering units <-> SI, in one place.

Inside inertest every quantity is SI: rad, s, m, m/s^2, rad/s. Engineering units appear only at
the edges (plans, data files, reports). The unit "g" is standard gravity ``G0`` = 9.80665 m/s^2
(ISO 80000-3; CGPM 1901), never the local gravity of the site.

Each constant is named after the conversion it performs: multiply a value in the first unit to
get the value in the second, e.g. ``x_rad_s = x_deg_h * DEG_PER_H_TO_RAD_PER_S``.
"""

from __future__ import annotations

import math
import re

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


#: Factor to SI and dimension (exponents of rad, m, s, count, A, V, and temperature as the
#: seventh where a symbol has one) of each unit symbol that compound units (``deg/h/g^2``,
#: ``count/(m/s^2)``, ``ug/g^2``, ``deg/h/degC``) are written with. ``degC`` and ``K`` are
#: temperature *differences* (a sensitivity per degree), the same size.
_DIMENSIONS = 7
_ATOMS: dict[str, tuple[float, tuple[int, ...]]] = {
    "rad": (1.0, (1, 0, 0, 0, 0, 0)), "mrad": (1e-3, (1, 0, 0, 0, 0, 0)),
    "urad": (MICRORAD_TO_RAD, (1, 0, 0, 0, 0, 0)), "deg": (DEG_TO_RAD, (1, 0, 0, 0, 0, 0)),
    "arcmin": (ARCMIN_TO_RAD, (1, 0, 0, 0, 0, 0)), "arcsec": (ARCSEC_TO_RAD, (1, 0, 0, 0, 0, 0)),
    "m": (1.0, (0, 1, 0, 0, 0, 0)), "mm": (1e-3, (0, 1, 0, 0, 0, 0)),
    "um": (1e-6, (0, 1, 0, 0, 0, 0)),
    "s": (1.0, (0, 0, 1, 0, 0, 0)), "ms": (1e-3, (0, 0, 1, 0, 0, 0)),
    "min": (60.0, (0, 0, 1, 0, 0, 0)),
    "h": (HOUR_TO_S, (0, 0, 1, 0, 0, 0)), "Hz": (1.0, (0, 0, -1, 0, 0, 0)),
    "g": (G0, (0, 1, -2, 0, 0, 0)), "mg": (MILLI_G_TO_M_PER_S2, (0, 1, -2, 0, 0, 0)),
    "ug": (MICRO_G_TO_M_PER_S2, (0, 1, -2, 0, 0, 0)),
    "count": (1.0, (0, 0, 0, 1, 0, 0)), "LSB": (1.0, (0, 0, 0, 1, 0, 0)),
    "A": (1.0, (0, 0, 0, 0, 1, 0)), "mA": (1e-3, (0, 0, 0, 0, 1, 0)),
    "uA": (1e-6, (0, 0, 0, 0, 1, 0)), "V": (1.0, (0, 0, 0, 0, 0, 1)),
    "mV": (1e-3, (0, 0, 0, 0, 0, 1)),
    "1": (1.0, (0, 0, 0, 0, 0, 0)), "ppm": (PPM_TO_RATIO, (0, 0, 0, 0, 0, 0)),
    "%": (1e-2, (0, 0, 0, 0, 0, 0)),
    "degC": (1.0, (0, 0, 0, 0, 0, 0, 1)), "K": (1.0, (0, 0, 0, 0, 0, 0, 1)),
}


def compound_unit(unit: str) -> tuple[float, tuple[float, ...]]:
    """Factor to SI and dimension of a compound unit such as ``deg/h/g^2`` or ``count/(m/s^2)``.

    Symbols of :data:`_ATOMS` joined by ``*`` and ``/`` (left to right), with integer powers
    ``^n``, parentheses and square roots ``sqrt(...)`` (noise densities: ``deg/sqrt(h)``, the
    angle random walk of IEEE Std 952-1997 Annex C). The dimension is the tuple of exponents of
    (rad, m, s, count, A, V), halves allowed: angles are kept apart from pure ratios, so
    ``urad`` and ``ppm`` do not convert.

    Raises
    ------
    UnitError
        An unknown symbol or a malformed unit.
    """
    tokens = re.findall(r"[A-Za-z%]+|\d+|[()*/^]|\S", unit.replace(" ", ""))
    pos = 0

    def term() -> tuple[float, list[float]]:
        nonlocal pos
        if pos >= len(tokens):
            raise UnitError(f'unit "{unit}" ends too early; write e.g. "deg/h/g^2"')
        tok = tokens[pos]
        pos += 1
        if tok == "sqrt":
            if pos >= len(tokens) or tokens[pos] != "(":
                raise UnitError(f'unit "{unit}": write a square root as sqrt(h)')
            pos += 1
            f, d = expr()
            if pos >= len(tokens) or tokens[pos] != ")":
                raise UnitError(f'unit "{unit}" has an unclosed parenthesis')
            pos += 1
            f, d = math.sqrt(f), [x / 2 for x in d]
        elif tok == "(":
            f, d = expr()
            if pos >= len(tokens) or tokens[pos] != ")":
                raise UnitError(f'unit "{unit}" has an unclosed parenthesis')
            pos += 1
        elif tok in _ATOMS:
            f, dim = _ATOMS[tok]
            d = [float(x) for x in dim] + [0.0] * (_DIMENSIONS - len(dim))
        else:
            known = ", ".join(_ATOMS)
            raise UnitError(f'unknown unit symbol "{tok}" in "{unit}"; use {known}')
        if pos < len(tokens) and tokens[pos] == "^":
            if pos + 1 >= len(tokens) or not tokens[pos + 1].isdigit():
                raise UnitError(f'unit "{unit}": a power needs an integer, e.g. g^2')
            n = int(tokens[pos + 1])
            pos += 2
            f, d = f**n, [x * n for x in d]
        return f, d

    def expr() -> tuple[float, list[float]]:
        nonlocal pos
        f, d = term()
        while pos < len(tokens) and tokens[pos] in "*/":
            op = tokens[pos]
            pos += 1
            f2, d2 = term()
            s = 1 if op == "*" else -1
            f, d = (f * f2 if s > 0 else f / f2), [a + s * b for a, b in zip(d, d2, strict=True)]
        return f, d

    factor, dim = expr()
    if pos != len(tokens):
        raise UnitError(f'unit "{unit}" is malformed near "{tokens[pos]}"')
    return factor, tuple(dim)


def convert(value: float, from_unit: str, to_unit: str) -> float:
    """``value`` in ``from_unit`` expressed in ``to_unit`` (compound units, :func:`compound_unit`).

    Raises
    ------
    UnitError
        The units measure different things (``deg/h`` and ``deg/h/g``).
    """
    f1, d1 = compound_unit(from_unit)
    f2, d2 = compound_unit(to_unit)
    if d1 != d2:
        raise UnitError(f'"{from_unit}" cannot be expressed in "{to_unit}": they measure '
                        "different quantities")
    return float(value) * f1 / f2
