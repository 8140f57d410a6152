"""Static model of a single pendulous accelerometer (IEEE Std 530-1978 / IEEE Std 1293-2018).

Model (the accelerometer test on a dividing head of seed ``000_dad8be616c6569c7.txt``, ch. 3,
sec. 3; IEEE Std 1293-2018 eq. (1), pendulous axes IA input, PA pendulous, OA output)::

    E / K1 = K0 + aI + K2 aI^2 + K3 aI^3 + KIP aI aP + KIO aI aO + KPO aP aO
                + KPP aP^2 + KOO aO^2 + dO aP - dP aO

with ``(aI, aP, aO)`` the specific force along IA, PA, OA as a multiple of standard gravity
g0 (dimensionless), ``E`` the output [output unit], ``K1`` the scale factor [output unit per g],
``K0`` the bias [g], ``K2``, ``K3`` the second- and third-order nonlinearity [g/g^2, g/g^3],
``KIP, KIO, KPO, KPP, KOO`` cross-coupling and cross-axis square terms [g/g^2] and ``dO``, ``dP``
the misalignment of IA about OA and PA [rad]. Reported in ug, ug/g^2, ug/g^3 and urad.

The output is linear in ``theta = K1 * (K0, 1, K2, K3, KIP, KIO, KPO, KPP, KOO, dO, dP)``,
the form the tests identify (:func:`regressors`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError

#: Coefficient names in the order of :func:`regressors` (K1 multiplies aI alone).
COEFFICIENTS: tuple[str, ...] = (
    "K0", "K1", "K2", "K3", "KIP", "KIO", "KPO", "KPP", "KOO", "dO", "dP",
)
#: Engineering unit of each coefficient (K1's unit is the output unit per g, set by the plan).
ENGINEERING_UNIT: dict[str, str] = {
    "K0": "ug", "K2": "ug/g^2", "K3": "ug/g^3", "KIP": "ug/g^2", "KIO": "ug/g^2",
    "KPO": "ug/g^2", "KPP": "ug/g^2", "KOO": "ug/g^2", "dO": "urad", "dP": "urad",
}
#: Engineering unit -> dimensionless (g or rad) value: all are micro.
MICRO = 1e-6


def regressors(a_ipo_g: ArrayLike) -> NDArray[np.float64]:
    """Regressor matrix, shape (n, 11), columns in :data:`COEFFICIENTS` order.

    Parameters
    ----------
    a_ipo_g : array_like, shape (n, 3)
        Specific force along (IA, PA, OA) [g0].

    Returns
    -------
    ndarray
        ``E = regressors(a) @ theta`` with ``theta = K1 * (K0, 1, K2, K3, KIP, KIO, KPO, KPP,
        KOO, dO, dP)``.
    """
    a = np.asarray(a_ipo_g, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"specific force must have shape (n, 3) (IA, PA, OA), got {a.shape}")
    i, p, o = a.T
    return np.column_stack([
        np.ones_like(i), i, i**2, i**3, i * p, i * o, p * o, p**2, o**2, p, -o,
    ])


def theta_from_coefficients(coefficients: Mapping[str, float]) -> NDArray[np.float64]:
    """``theta`` [output unit] from engineering coefficients (K1 [output/g], others in u-units).

    Missing names are zero; ``K1`` is required.
    """
    unknown = sorted(set(coefficients) - set(COEFFICIENTS))
    if unknown:
        raise InputError(f"unknown accelerometer coefficient(s) {', '.join(unknown)}; known: "
                         f"{', '.join(COEFFICIENTS)}")
    if "K1" not in coefficients:
        raise InputError("the accelerometer model needs K1 (scale factor, output unit per g)")
    k1 = float(coefficients["K1"])
    return np.array([k1 if n == "K1" else k1 * float(coefficients.get(n, 0.0)) * MICRO
                     for n in COEFFICIENTS])


def output(a_ipo_g: ArrayLike, coefficients: Mapping[str, float]) -> NDArray[np.float64]:
    """Model output ``E`` [output unit] for specific force (IA, PA, OA) [g0], shape (n,)."""
    return regressors(a_ipo_g) @ theta_from_coefficients(coefficients)
