"""Static drift model of a single-degree-of-freedom (SDF) floated gyro in a 1 g field.

Model (seed ``000_dad8be616c6569c7.txt``, ch. 3, sec. 1.1; DESIGN.md)::

    drift = DF + DI fI + DO fO + DS fS + DIO fI fO + DOS fO fS + DSI fS fI
               + DII fI^2 + DOO fO^2 + DSS fS^2

with ``(fI, fO, fS)`` the specific force along the input, output and spin-reference axes as a
multiple of standard gravity g0 (dimensionless), and the drift added to the true input rate:
``w_out = w_I + drift``. Coefficients are held in SI rate units per power of g: rad/s, rad/s/g,
rad/s/g^2; they are reported in deg/h, deg/h/g, deg/h/g^2.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.units import DEG_PER_H_TO_RAD_PER_S, gyro_coefficient_unit

#: Coefficient names in the order of the regressor columns.
COEFFICIENTS: tuple[str, ...] = (
    "DF", "DI", "DO", "DS", "DIO", "DOS", "DSI", "DII", "DOO", "DSS",
)
#: Power of the specific force (in g) that each coefficient multiplies.
G_POWER: dict[str, int] = {
    "DF": 0, "DI": 1, "DO": 1, "DS": 1,
    "DIO": 2, "DOS": 2, "DSI": 2, "DII": 2, "DOO": 2, "DSS": 2,
}
#: Engineering unit of each coefficient.
ENGINEERING_UNIT: dict[str, str] = {k: gyro_coefficient_unit(p) for k, p in G_POWER.items()}


def drift_regressors(f_ios_g: ArrayLike) -> NDArray[np.float64]:
    """Regressor matrix of the static drift model.

    Parameters
    ----------
    f_ios_g : array_like, shape (n, 3)
        Specific force along (I, O, S) [g0].

    Returns
    -------
    ndarray, shape (n, 10)
        Columns ``1, fI, fO, fS, fI fO, fO fS, fS fI, fI^2, fO^2, fS^2`` in the order of
        :data:`COEFFICIENTS`, so that ``drift = Phi @ coefficients``.
    """
    f = np.asarray(f_ios_g, dtype=float)
    if f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"specific force must have shape (n, 3), got {f.shape}")
    fi, fo, fs = f[:, 0], f[:, 1], f[:, 2]
    out = np.empty((f.shape[0], 10))  # filled in place: no temporary columns
    out[:, 0] = 1.0
    out[:, 1:4] = f
    np.multiply(fi, fo, out=out[:, 4])
    np.multiply(fo, fs, out=out[:, 5])
    np.multiply(fs, fi, out=out[:, 6])
    np.multiply(f, f, out=out[:, 7:10])
    return out


def regressors_from_moments(weight: float, first: ArrayLike, second: ArrayLike
                            ) -> NDArray[np.float64]:
    """A weighted sum of the rows of :func:`drift_regressors`, from moments of the force.

    ``sum_i w_i Phi(f_i)`` needs only ``weight = sum w_i``, ``first = sum w_i f_i`` and
    ``second = sum w_i f_i f_i^T``: computed so, the ``(n, 10)`` regressor matrix is never
    built (whole-cycle means of long records).

    Parameters
    ----------
    weight : float
        Sum of the weights (1 for a weighted mean).
    first : array_like, shape (3,)
        Weighted sum of the specific force along (I, O, S) [g0].
    second : array_like, shape (3, 3)
        Weighted sum of its outer products [g0^2].

    Returns
    -------
    ndarray, shape (10,)
        ``sum w_i Phi(f_i)``, in the order of :data:`COEFFICIENTS`.
    """
    m1 = np.asarray(first, dtype=float)
    m2 = np.asarray(second, dtype=float)
    if m1.shape != (3,) or m2.shape != (3, 3):
        raise InputError(f"moments need shapes (3,) and (3, 3), got {m1.shape} and {m2.shape}")
    return np.array([float(weight), *m1, m2[0, 1], m2[1, 2], m2[2, 0], m2[0, 0], m2[1, 1],
                     m2[2, 2]])


def drift(f_ios_g: ArrayLike, coefficients: ArrayLike) -> NDArray[np.float64]:
    """Static drift [same rate unit as ``coefficients``] for specific forces ``f_ios_g`` [g0].

    ``drift_regressors(f) @ coefficients`` evaluated as
    ``DF + fI (DI + DII fI + DIO fO) + fO (DO + DOO fO + DOS fS) + fS (DS + DSS fS + DSI fI)``
    (equal to rounding), with temporaries of ``n`` values instead of the ``(n, 10)`` matrix.
    """
    c = np.asarray(coefficients, dtype=float)
    if c.shape != (len(COEFFICIENTS),):
        raise InputError(f"expected {len(COEFFICIENTS)} coefficients, got shape {c.shape}")
    f = np.asarray(f_ios_g, dtype=float)
    if f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"specific force must have shape (n, 3), got {f.shape}")
    df, di, do, ds, dio, dos, dsi, dii, doo, dss = (float(v) for v in c)
    fi, fo, fs = f[:, 0], f[:, 1], f[:, 2]
    out = np.full(f.shape[0], df)
    for a, lin, square, cross, b in ((fi, di, dii, dio, fo), (fo, do, doo, dos, fs),
                                     (fs, ds, dss, dsi, fi)):
        term = a * square
        term += lin
        term += cross * b
        term *= a
        out += term
    return out


def coefficients_from_deg_h(values: Mapping[str, float]) -> NDArray[np.float64]:
    """Coefficient vector [rad/s per g^k] from a mapping of names to deg/h per g^k.

    Names not given are zero; unknown names are an error (a typo would otherwise be a silent zero).
    """
    unknown = sorted(set(values) - set(COEFFICIENTS))
    if unknown:
        raise InputError(
            f"unknown drift coefficient(s) {', '.join(unknown)}; "
            f"use the names {', '.join(COEFFICIENTS)}"
        )
    out = np.zeros(len(COEFFICIENTS))
    for i, name in enumerate(COEFFICIENTS):
        v = float(values.get(name, 0.0))
        if not np.isfinite(v):
            raise InputError(f"drift coefficient {name} must be finite, got {v}")
        out[i] = v * DEG_PER_H_TO_RAD_PER_S
    return out
