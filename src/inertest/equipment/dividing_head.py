"""Dividing head: a precision index head turning the instrument in a vertical plane.

A horizontal head axis turns the instrument (seed ``000_dad8be616c6569c7.txt``, ch. 3,
sec. 3; IEEE Std 1293-2018, multipoint tumble test).

Mountings name the plane of the instrument that turns in the vertical plane (the third axis lies
along the horizontal head axis and feels no gravity):

* ``"IA-PA"`` (head axis along OA): ``aI = gamma cos(theta)``, ``aP = gamma sin(theta)``,
  ``aO = 0``;
* ``"IA-OA"`` (head axis along PA): ``aI = gamma cos(theta)``, ``aO = gamma sin(theta)``,
  ``aP = 0``;
* ``"PA-OA"`` (head axis along IA): ``aP = gamma cos(theta)``, ``aO = gamma sin(theta)``,
  ``aI = 0``.

``theta`` is the head angle [deg in plans and data], zero with the first axis of the plane up
and increasing as the second axis turns up; ``gamma = g_local / g0``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError

MOUNTINGS: tuple[str, ...] = ("IA-PA", "IA-OA", "PA-OA")
#: Columns of (aI, aP, aO) that carry the cos and sin of the head angle.
_PLANE = {"IA-PA": (0, 1), "IA-OA": (0, 2), "PA-OA": (1, 2)}
#: The axis along the head axis (never excited) for each mounting.
HEAD_AXIS = {"IA-PA": "OA", "IA-OA": "PA", "PA-OA": "IA"}


def check_mounting(mounting: str) -> str:
    """The canonical mounting name; a clear error otherwise."""
    key = str(mounting).strip().upper()
    if key not in _PLANE:
        raise InputError(f'unknown dividing-head mounting "{mounting}"; use one of '
                         f'{", ".join(MOUNTINGS)}')
    return key


def specific_force(
    mounting: ArrayLike, angle_deg: ArrayLike, gravity_g: float
) -> NDArray[np.float64]:
    """Specific force along (IA, PA, OA) [g0] at each head position, shape (n, 3).

    Parameters
    ----------
    mounting : array_like of str, shape (n,) or a single str
    angle_deg : array_like, shape (n,)
        Head angle [deg].
    gravity_g : float
        Local gravity [g0].
    """
    t = np.radians(np.atleast_1d(np.asarray(angle_deg, dtype=float)))
    m = np.broadcast_to(np.asarray(mounting, dtype=str), t.shape)
    out = np.zeros((t.size, 3))
    for key in np.unique(m):
        sel = m == key
        c, s = _PLANE[check_mounting(key)]
        out[sel, c] = gravity_g * np.cos(t[sel])
        out[sel, s] = gravity_g * np.sin(t[sel])
    return out


def equally_spaced(n: int) -> NDArray[np.float64]:
    """``n`` head angles equally spaced over 360 deg from 0 [deg]."""
    if n < 1:
        raise InputError(f"the number of head positions must be positive, got {n}")
    return np.arange(n) * 360.0 / n
