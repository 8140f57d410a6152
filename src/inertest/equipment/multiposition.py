"""Static multi-position orientation sets of a triad on a turntable or cube fixture.

A position is written as the local directions (E, W, N, S, U, D; S = south) of the triad's
reference axes x, y, z, e.g. ``"UEN"`` = x up, y east, z north, optionally followed by a tilt
about one body axis: ``"UEN/z+45"`` = from ``UEN``, turned +45 deg (right-handed) about the body
z axis. The attitude is the matrix ``C_nb`` (columns: body axes in ENU), so the specific force
felt at rest is ``f_b = C_nb^T (0, 0, g)``.

Schemes (``scheme_positions``):

* ``"6"``: each axis up and down (``UEN, DWN, NUE, SDE, ENU, WND``); the classical six-position
  method (IEEE Std 1293-2018 annex on multi-position tests): ``b = (f_up + f_down)/2`` and column
  ``j`` of ``S = K (I + M)`` is ``(f_up - f_down)/(2 g)`` with ``j`` up.
* ``"12"``: seed ``003_f374f866dfe7c99f.txt`` sec. 1.1 calibrates the accelerometers by a
  "twelve-position method" but does not list the positions (it cites its reference [2]); inertest
  uses the twelve positions in which gravity lies along a cube *edge* diagonal, i.e. each
  axis-up/axis-down attitude tilted +-45 deg about a horizontal body axis: every pair of sensor
  axes is excited together, the information is the same for all three axes
  (``sum f f^T = 4 g^2 I``) and ``sum f = 0``, so bias and ``S`` are uncorrelated.
* ``"24"``: the 24 rotations of the cube (each axis up and down at four headings, as the level
  fixture of the tumble tests): for an accelerometer the six gravity directions four times each.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import Site
from inertest.equipment.directions import triad_axes
from inertest.equipment.level_fixture import all_positions
from inertest.equipment.motion import StaticPositions
from inertest.equipment.type_b import TypeBSource, tilt_rotation, type_b_error
from inertest.errors import InputError

SCHEMES = ("6", "12", "24")
SIX = ("UEN", "DWN", "NUE", "SDE", "ENU", "WND")
TWELVE = (
    "UEN/z+45", "UEN/z-45", "DWN/z+45", "DWN/z-45",
    "NUE/x+45", "NUE/x-45", "SDE/x+45", "SDE/x-45",
    "ENU/y+45", "ENU/y-45", "WND/y+45", "WND/y-45",
)
_LABEL = re.compile(r"^([EWNSUD]{3})(?:/([xyz])([+-]\d+(?:\.\d*)?))?$")


def scheme_positions(scheme: str) -> tuple[str, ...]:
    """Position labels of a named scheme (``"6"``, ``"12"`` or ``"24"``)."""
    if scheme == "6":
        return SIX
    if scheme == "12":
        return TWELVE
    if scheme == "24":
        return tuple("".join(p) for p in all_positions())
    raise InputError(f'unknown multi-position scheme "{scheme}"; use one of {", ".join(SCHEMES)} '
                     "or list the positions")


def attitude(label: str) -> NDArray[np.float64]:
    """``C_nb`` (3, 3) of a position label; columns are the body x, y, z axes in ENU.

    Raises
    ------
    InputError
        Malformed label, axes not along three different local directions, or left-handed.
    """
    m = _LABEL.match(str(label).strip())
    if m is None:
        raise InputError(
            f'position "{label}" is not of the form "UEN" (directions of x, y, z among E, W, N, '
            'S, U, D) or "UEN/z+45" (then a tilt in degrees about a body axis)'
        )
    cols = triad_axes(m.group(1), axes="xyz", what=f'position "{label}"').T
    if m.group(2):
        tilt = Rotation.from_rotvec(np.radians(float(m.group(3))) * np.eye(3)["xyz".index(
            m.group(2))])
        cols = cols @ tilt.as_matrix()
    return cols


def attitudes(labels: object) -> NDArray[np.float64]:
    """``C_nb`` for each label, shape (n, 3, 3) (computed once per distinct label)."""
    arr = np.asarray(labels, dtype=str)
    uniq, inverse = np.unique(arr, return_inverse=True)
    table = np.stack([attitude(u) for u in uniq]) if uniq.size else np.zeros((0, 3, 3))
    return table[inverse.ravel()]


#: Type-B errors the fixture accepts (:mod:`inertest.equipment.type_b`), applied by :func:`motion`.
TYPE_B: tuple[TypeBSource, ...] = (
    TypeBSource("tilt", "rad", "fixture base out of level: tilted about east"),
)


def motion(labels: object, site: Site, *,
           type_b: Mapping[str, float] | None = None) -> StaticPositions:
    """The fixture as a :class:`~inertest.equipment.motion.Motion`: one static segment per label.

    Parameters
    ----------
    labels : sequence of str
        Position labels (repeats allowed; each distinct label is one segment, in first-seen
        order).
    site : Site
    type_b : mapping of str to float, optional
        The fixture's Type-B errors [SI] (:data:`TYPE_B`); none for the nominal fixture.

    Returns
    -------
    StaticPositions
        ``C_ni`` = :func:`attitude` of each label; at rest ``f_i = C_ni^T (0, 0, g)`` and
        ``omega_i = C_ni^T W_ie_n``.
    """
    distinct = dict.fromkeys(str(x) for x in np.asarray(labels, dtype=str).ravel())
    tilt = tilt_rotation(type_b_error(type_b, "tilt"))   # Type-B (zero on the nominal fixture)
    return StaticPositions({lab: tilt @ attitude(lab) for lab in distinct}, site)

