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

:func:`motion` gives the head positions as a :class:`~inertest.equipment.motion.Motion`
(segments labelled ``"IA-PA@45"``): instrument axes (IA, PA, OA), right-handed
(``OA = IA x PA``), the head axis horizontal and pointing to the azimuth ``head_azimuth_deg``
(default north; it matters only for the Earth rate).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import Site
from inertest.equipment.motion import StaticPositions
from inertest.equipment.type_b import TypeBSource, tilt_rotation, type_b_error
from inertest.errors import InputError

MOUNTINGS: tuple[str, ...] = ("IA-PA", "IA-OA", "PA-OA")
#: Columns of (aI, aP, aO) that carry the cos and sin of the head angle.
_PLANE = {"IA-PA": (0, 1), "IA-OA": (0, 2), "PA-OA": (1, 2)}
#: The axis along the head axis (never excited) for each mounting.
HEAD_AXIS = {"IA-PA": "OA", "IA-OA": "PA", "PA-OA": "IA"}
#: Type-B errors the head accepts (:mod:`inertest.equipment.type_b`), applied by :func:`motion`.
TYPE_B: tuple[TypeBSource, ...] = (
    TypeBSource("angle", "rad", "indexing zero error: added to every head angle"),
    TypeBSource("tilt", "rad", "head axis out of horizontal: the head tilted about east"),
)


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


def position_labels(mounting: ArrayLike, angle_deg: ArrayLike) -> NDArray[np.str_]:
    """Segment label of each (mounting, head angle) row: ``"IA-PA@45"``.

    The mounting in canonical form (:func:`check_mounting`), the angle modulo 360 deg with 9
    significant digits, so that readings of one position share a label.
    """
    a = np.atleast_1d(np.asarray(angle_deg, dtype=float))
    m = np.broadcast_to(np.asarray(mounting).astype(str), a.shape)
    keys, inverse = np.unique(m, return_inverse=True)
    canon = np.array([check_mounting(k) for k in keys], dtype=str)[inverse.reshape(a.shape)]
    return np.char.add(np.char.add(canon, "@"), np.char.mod("%.9g", np.mod(a, 360.0) + 0.0))


def attitudes(
    mounting: str, angle_deg: ArrayLike, head_azimuth_deg: float = 0.0
) -> NDArray[np.float64]:
    """``C_ni`` (columns IA, PA, OA in ENU) at each head angle, shape (k, 3, 3).

    With the head axis along north, the plane's first axis is ``a1 = (-sin t, 0, cos t)`` and its
    second ``a2 = (cos t, 0, sin t)`` (``a1`` up at ``t = 0``, ``a2`` up at 90 deg) and
    ``a1 x a2`` = north: IA-PA ``(a1, a2, N)``, IA-OA ``(a1, -N, a2)``, PA-OA ``(N, a1, a2)``.
    The head azimuth (clockwise from north) turns all three about up.
    """
    t = np.radians(np.atleast_1d(np.asarray(angle_deg, dtype=float)))
    zero = np.zeros_like(t)
    a1 = np.stack([-np.sin(t), zero, np.cos(t)], axis=1)
    a2 = np.stack([np.cos(t), zero, np.sin(t)], axis=1)
    north = np.tile([0.0, 1.0, 0.0], (t.size, 1))
    cols = {"IA-PA": (a1, a2, north), "IA-OA": (a1, -north, a2),
            "PA-OA": (north, a1, a2)}[check_mounting(mounting)]
    c = np.stack(cols, axis=2)
    if head_azimuth_deg:
        c = Rotation.from_rotvec([0.0, 0.0, -np.radians(head_azimuth_deg)]).as_matrix() @ c
    return c


def motion(
    mountings: ArrayLike, angles_deg: ArrayLike, site: Site, *, head_azimuth_deg: float = 0.0,
    type_b: Mapping[str, float] | None = None,
) -> StaticPositions:
    """The head holding the instrument at every angle of every mounting, as a motion.

    Parameters
    ----------
    mountings : array_like of str
        Mountings, any of ``IA-PA``, ``IA-OA``, ``PA-OA``.
    angles_deg : array_like, shape (k,)
        Head angles [deg].
    site : Site
        Local gravity (and latitude, for the Earth rate).
    head_azimuth_deg : float
        Azimuth of the head axis, clockwise from north [deg].
    type_b : mapping of str to float, optional
        The head's Type-B errors [SI] (:data:`TYPE_B`); none for the nominal head.

    Returns
    -------
    StaticPositions
        Segments ``"<mounting>@<angle>"`` (:func:`position_labels`), mounting by mounting;
        instrument axes (IA, PA, OA). Its specific force ``f_i / g0`` equals
        :func:`specific_force` with ``gravity_g = g / g0``; the axis along the head axis feels
        none (on the nominal head).

    Raises
    ------
    InputError
        An unknown mounting.
    """
    angles = np.atleast_1d(np.asarray(angles_deg, dtype=float))
    # Type-B errors (zero unless applied): the labels stay the nominal angles.
    true_angles = angles + np.degrees(type_b_error(type_b, "angle"))
    tilt = tilt_rotation(type_b_error(type_b, "tilt"))
    out: dict[str, NDArray[np.float64]] = {}
    for m in np.atleast_1d(np.asarray(mountings).astype(str)):
        for label, c in zip(position_labels(m, angles), attitudes(str(m), true_angles,
                                                                  head_azimuth_deg), strict=True):
            out[str(label)] = tilt @ c
    return StaticPositions(out, site)
