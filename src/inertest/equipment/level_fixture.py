"""Level fixture: the instrument's axes set along the local directions E, W, N, S, U, D.

Used by the local-level ("geographic") tumble (seed ``000_dad8be616c6569c7.txt``, sec. 3). The
letter S names *south* here; the gyro's spin-reference axis is the third column of a position.

:func:`motion` gives a plan's positions as a :class:`~inertest.equipment.motion.Motion`
(segments labelled ``"U N W"``: the directions of I, O, S, see :func:`position_labels`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.earth import DIRECTIONS_ENU, Site, earth_rate_enu, specific_force_enu
from inertest.equipment.directions import letter_of, triad_axes
from inertest.equipment.motion import StaticPositions
from inertest.equipment.type_b import TypeBSource, tilt_rotation, type_b_error
from inertest.errors import InputError
from inertest.units import G0


def axes_from_directions(i_dir: str, o_dir: str, s_dir: str) -> NDArray[np.float64]:
    """Rows I, O, S in ENU for one position given as direction letters.

    Raises
    ------
    InputError
        A letter is not one of E, W, N, S, U, D, two axes are not perpendicular, or the triad is
        left-handed (the gyro axes satisfy I x O = S).
    """
    what = f"position (I={i_dir}, O={o_dir}, S={s_dir})"
    return triad_axes((i_dir, o_dir, s_dir), axes="IOS", what=what)


def specific_force_ios(axes: NDArray[np.float64], gravity_m_s2: float) -> NDArray[np.float64]:
    """Specific force along (I, O, S) [g0]; ``axes`` has shape (n, 3, 3) (rows I, O, S in ENU)."""
    return axes @ specific_force_enu(gravity_m_s2) / G0


def input_rate(axes: NDArray[np.float64], latitude_rad: float) -> NDArray[np.float64]:
    """Earth rate along the input axis [rad/s] for each position, shape (n,)."""
    return axes[:, 0, :] @ earth_rate_enu(latitude_rad)


def all_positions() -> list[tuple[str, str, str]]:
    """The 24 right-handed positions with each gyro axis along a local direction.

    Each of I, O, S points up and down once for each of the four horizontal headings of the
    other two axes: the full set of the cube's rotations, a balanced default plan.
    """
    out = []
    letters = list(DIRECTIONS_ENU)
    for a in letters:
        for b in letters:
            va, vb = DIRECTIONS_ENU[a], DIRECTIONS_ENU[b]
            if abs(va @ vb) > 0.5:
                continue
            c = np.cross(va, vb)
            out.append((a, b, letter_of(c)))
    return out


def position_labels(i_dir: ArrayLike, o_dir: ArrayLike, s_dir: ArrayLike) -> NDArray[np.str_]:
    """Segment label of each row from its I, O, S direction letters: ``"U N W"`` (upper case)."""
    i, o, s = (np.char.upper(np.asarray(d).astype(str)) for d in (i_dir, o_dir, s_dir))
    return np.char.add(np.char.add(np.char.add(i, " "), np.char.add(o, " ")), s)


#: Type-B errors the fixture accepts (:mod:`inertest.equipment.type_b`), applied by :func:`motion`.
TYPE_B: tuple[TypeBSource, ...] = (
    TypeBSource("tilt", "rad", "fixture base out of level: tilted about east"),
)


def motion(positions: Iterable[str | Sequence[str]], site: Site, *,
           type_b: Mapping[str, float] | None = None) -> StaticPositions:
    """The fixture holding the gyro in each position, as a motion.

    Parameters
    ----------
    positions : iterable
        Directions of (I, O, S) at each position: ``("U", "N", "W")``, ``"UNW"`` or a label
        ``"U N W"`` (letters E, W, N, S, U, D; S = south).
    site : Site
    type_b : mapping of str to float, optional
        The fixture's Type-B errors [SI] (:data:`TYPE_B`); none for the nominal fixture.

    Returns
    -------
    StaticPositions
        Segments ``"U N W"`` (:func:`position_labels`) in the order given; attitude ``C_ni``
        with columns I, O, S in ENU. At rest: ``f_i = C_ni^T (0, 0, g)`` (``+-g`` on the
        vertical axis, zero on the others) and ``omega_i[:, 0] = W I . (0, cos L, sin L)``.

    Raises
    ------
    InputError
        A position that is not three local directions of a right-handed triad.
    """
    tilt = tilt_rotation(type_b_error(type_b, "tilt"))   # Type-B (zero on the nominal fixture)
    attitudes: dict[str, NDArray[np.float64]] = {}
    for p in positions:
        triple = p.split() if isinstance(p, str) and " " in p.strip() else list(p)
        if len(triple) != 3:
            raise InputError(f"position {p!r} must give three directions (I, O, S), e.g. \"UNW\"")
        label = str(position_labels(*triple))
        attitudes[label] = tilt @ axes_from_directions(*triple).T
    return StaticPositions(attitudes, site)
