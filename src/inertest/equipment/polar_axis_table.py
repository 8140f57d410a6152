"""Polar-axis turntable: a table whose rotation axis is parallel to the Earth's axis.

The gyro is mounted with its output axis O (mountings ``O-Np``, ``O-Sp``) or spin-reference axis
S (``S-Np``, ``S-Sp``) along the table axis, pointing to the north (Np) or south (Sp) celestial
pole; the input axis I lies in the table plane, perpendicular to the polar axis, so it never
senses the Earth rate (seed ``000_dad8be616c6569c7.txt``, sec. 2(5)).

Table angle convention (as in the seed): at ``theta = 0`` the I axis is horizontal and the other
in-plane axis (S for O mountings, O for S mountings) is at its highest; ``theta`` grows as I rises
towards up. Then, with latitude L and specific force in units of local gravity::

    mounting  fI              fO              fS
    O-Np      cosL sin(theta) +sinL           cosL cos(theta)
    O-Sp      cosL sin(theta) -sinL           cosL cos(theta)
    S-Np      cosL sin(theta) cosL cos(theta) +sinL
    S-Sp      cosL sin(theta) cosL cos(theta) -sinL

:func:`motion` gives the positions of a plan as a :class:`~inertest.equipment.motion.Motion`
(segments labelled ``"O-Np@45"``: mounting, then the table angle in deg, see
:func:`position_labels`), the one source of the inputs of the polar-tumble procedure.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import Site, earth_rate_enu, polar_axis_enu, specific_force_enu
from inertest.equipment.motion import StaticPositions, per_run
from inertest.equipment.type_b import (
    TypeBSource,
    axis_tilt_rotation,
    component_error,
    tilt_rotation,
    type_b_error,
)
from inertest.errors import InputError
from inertest.units import DEG_TO_RAD, G0

MOUNTINGS: tuple[str, ...] = ("O-Np", "O-Sp", "S-Np", "S-Sp")

#: Type-B errors the table accepts (:mod:`inertest.equipment.type_b`), applied by :func:`motion`.
#: ``tilt`` is the table axis' direction error, in both directions independently (the lab file's
#: value applies to each); ``squareness`` the table axis out of square with the trunnion the table
#: is flipped about for the Sp mountings, an east-west tilt that reverses with the flip. The
#: input axis then leaves the equatorial plane and senses the Earth rate: an error ``e`` [rad]
#: adds ``W e`` times a unit harmonic of theta to the drift (15.04 deg/h x 20 urad = 3.0e-4 deg/h).
TYPE_B: tuple[TypeBSource, ...] = (
    TypeBSource("angle", "rad", "encoder zero error: added to every table angle"),
    TypeBSource("tilt", "rad", "polar-axis alignment: the table axis tilted", components=(
        ("meridian", "the table axis tilted in the meridian plane (about east)"),
        ("east-west", "the table axis tilted towards east, the same for every mounting"),
    )),
    TypeBSource("squareness", "rad", "table axis out of square with the trunnion: the table "
                "axis tilted towards east for the Np mountings and towards west for the Sp "
                "mountings (the table flipped over the trunnion)"),
)


def _base_axes_and_rotation_axis(
    mounting: str, latitude_rad: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(I, O, S) in ENU at theta = 0 (rows) and the unit rotation axis of increasing theta."""
    p = polar_axis_enu(latitude_rad)
    east = np.array([1.0, 0.0, 0.0])
    # In the equatorial plane, the direction whose elevation is highest: (0, -sinL, cosL).
    e2 = np.cross(p, east) * -1.0
    if mounting == "O-Np":
        i, o, s, axis = east, p, e2, -p
    elif mounting == "O-Sp":
        i, o, s, axis = -east, -p, e2, p
    elif mounting == "S-Np":
        i, o, s, axis = -east, e2, p, p
    elif mounting == "S-Sp":
        i, o, s, axis = east, e2, -p, -p
    else:
        raise InputError(
            f'unknown polar-tumble mounting "{mounting}"; use one of {", ".join(MOUNTINGS)}'
        )
    return np.vstack([i, o, s]), axis


def instrument_axes_enu(
    mounting: str, table_angle_rad: ArrayLike, latitude_rad: float
) -> NDArray[np.float64]:
    """Unit vectors of the gyro's I, O, S axes in ENU at each table angle.

    Parameters
    ----------
    mounting : {"O-Np", "O-Sp", "S-Np", "S-Sp"}
    table_angle_rad : array_like, shape (n,)
        Table angle theta [rad].
    latitude_rad : float
        Site latitude [rad].

    Returns
    -------
    ndarray, shape (n, 3, 3)
        ``axes[k, j]`` is axis j (0: I, 1: O, 2: S) in ENU, i.e. the rows of ``C_ios_enu``.
    """
    base, axis = _base_axes_and_rotation_axis(mounting, latitude_rad)
    theta = np.atleast_1d(np.asarray(table_angle_rad, dtype=float))
    rot = Rotation.from_rotvec(theta[:, None] * axis[None, :])
    return np.stack([rot.apply(base[j]) for j in range(3)], axis=1)


def specific_force_ios(
    mounting: str, table_angle_rad: ArrayLike, latitude_rad: float, gravity_m_s2: float
) -> NDArray[np.float64]:
    """Specific force along (I, O, S) [g0] at each table angle, shape (n, 3)."""
    axes = instrument_axes_enu(mounting, table_angle_rad, latitude_rad)
    return axes @ specific_force_enu(gravity_m_s2) / G0


def input_rate(
    mounting: str, table_angle_rad: ArrayLike, latitude_rad: float
) -> NDArray[np.float64]:
    """Earth rate along the input axis [rad/s] (zero by design of the test, to rounding)."""
    axes = instrument_axes_enu(mounting, table_angle_rad, latitude_rad)
    return axes[:, 0, :] @ earth_rate_enu(latitude_rad)


def position_labels(mounting: ArrayLike, angle_deg: ArrayLike) -> NDArray[np.str_]:
    """Segment label of each (mounting, table angle) row: ``"O-Np@45"``.

    The angle is taken modulo 360 deg and written with 9 significant digits, so readings of one
    position (``0`` and ``360``, or the same angle read back from a file) share a label.

    Parameters
    ----------
    mounting : array_like of str, shape (n,) or a single str
    angle_deg : array_like, shape (n,)
        Table angle theta [deg].

    Returns
    -------
    ndarray of str, shape (n,)
    """
    a = np.atleast_1d(np.asarray(angle_deg, dtype=float))
    m = np.broadcast_to(np.asarray(mounting).astype(str, copy=False), a.shape)
    return per_run(lambda mr, ar: np.char.add(np.char.add(mr, "@"), np.char.mod(
        "%.9g", np.mod(ar, 360.0) + 0.0)), m, a)


def motion(mountings: ArrayLike, angles_deg: ArrayLike, site: Site, *,
           type_b: Mapping[str, float] | None = None) -> StaticPositions:
    """The table holding the gyro at every table angle of every mounting, as a motion.

    Parameters
    ----------
    mountings : array_like of str
        Mountings, any of ``O-Np``, ``O-Sp``, ``S-Np``, ``S-Sp``.
    angles_deg : array_like, shape (k,)
        Table angles theta [deg] (the same encoder angles for every mounting).
    site : Site
        Latitude (the polar axis) and local gravity.
    type_b : mapping of str to float, optional
        The table's Type-B errors [SI] (:data:`TYPE_B`); none for the nominal table.

    Returns
    -------
    StaticPositions
        Segments ``"<mounting>@<angle>"`` (:func:`position_labels`), mounting by mounting in the
        order given, angles in the order given; attitude ``C_ni`` with columns I, O, S in ENU
        (:func:`instrument_axes_enu` transposed). Its inputs: Earth rate and ``+g`` up on
        I, O, S, so ``f_i / g`` follows the table of the module docstring and ``omega_i[:, 0]``
        vanishes (the input axis stays in the equatorial plane, on the nominal table).

    Raises
    ------
    InputError
        An unknown mounting.
    """
    angles = np.atleast_1d(np.asarray(angles_deg, dtype=float))
    # Type-B errors (zero unless applied): the labels stay the nominal angles.
    offset = type_b_error(type_b, "angle")
    p, east = polar_axis_enu(site.latitude_rad), np.array([1.0, 0.0, 0.0])
    common = tilt_rotation(type_b_error(type_b, component_error("tilt", "meridian"))) @ \
        axis_tilt_rotation(type_b_error(type_b, component_error("tilt", "east-west")), p, east)
    square = type_b_error(type_b, "squareness")
    attitudes: dict[str, NDArray[np.float64]] = {}
    for m in np.atleast_1d(np.asarray(mountings).astype(str)):
        axes = instrument_axes_enu(str(m), angles * DEG_TO_RAD + offset, site.latitude_rad)
        flip = -1.0 if str(m).endswith("Sp") else 1.0
        tilt = common @ axis_tilt_rotation(flip * square, p, east)
        for label, rows in zip(position_labels(m, angles), axes, strict=True):
            attitudes[str(label)] = tilt @ rows.T
    return StaticPositions(attitudes, site)
