"""Direction letters of a local-level frame, and the triads they name (one parser for all).

A test engineer names the attitude of an instrument on a fixture by where its axes point: ``E``,
``W``, ``N``, ``S`` (south), ``U``, ``D`` in the local frame ENU (x east, y north, z up), e.g.
``"UEN"`` for an accelerometer triad with x up, y east, z north, or ``I=N, O=U, S=E`` for an SDF
gyro. Every fixture (level fixture, multi-position cube, rate table) reads such triads here.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from inertest.earth import DIRECTIONS_ENU
from inertest.errors import InputError

#: The six direction letters, in the order of :data:`inertest.earth.DIRECTIONS_ENU`.
LETTERS: tuple[str, ...] = tuple(DIRECTIONS_ENU)


def letter_of(v: NDArray[np.float64]) -> str:
    """The direction letter of a unit vector along a local axis (``(0, 0, -1)`` -> ``"D"``)."""
    for k, u in DIRECTIONS_ENU.items():
        if u @ v > 0.5:
            return k
    raise InputError(f"{np.asarray(v).tolist()} is not along a local axis E/W, N/S, U/D")


def triad_axes(
    letters: Sequence[str], *, axes: str, what: str, left_handed: str | None = None,
) -> NDArray[np.float64]:
    """Unit vectors (rows) in ENU of three instrument axes given by direction letters.

    Parameters
    ----------
    letters : sequence of 3 str
        One letter per axis, in the order of ``axes`` (case and blanks ignored).
    axes : str
        The three axis names, e.g. ``"xyz"`` or ``"IOS"`` (a right-handed triad:
        ``axes[0] x axes[1] = axes[2]``).
    what : str
        How the messages name the triad (``'attitude "UEN"'``, ``"position (I=N, O=U, S=E)"``).
    left_handed : str, optional
        The message for a left-handed triad (default: names the direction the third axis
        must point).

    Returns
    -------
    ndarray, shape (3, 3)
        Row ``j``: axis ``axes[j]`` in ENU.

    Raises
    ------
    InputError
        An unknown letter, axes not along three different local axes, or a left-handed triad.
    """
    vecs = []
    for axis, d in zip(axes, letters, strict=True):
        key = str(d).strip().upper()
        if key not in DIRECTIONS_ENU:
            raise InputError(f'{axis} axis direction "{d}" is not one of E, W, N, S, U, D '
                             f"(S = south), in {what}")
        vecs.append(DIRECTIONS_ENU[key])
    a, b, c = vecs
    if abs(a @ b) > 0.5 or abs(b @ c) > 0.5 or abs(c @ a) > 0.5:
        raise InputError(f"{what} is not an orthogonal triad: {', '.join(axes)} must point "
                         "along different axes of E/W, N/S, U/D")
    if np.cross(a, b) @ c < 0:
        raise InputError(left_handed or (
            f"{what} is left-handed: {axes[0]} x {axes[1]} = {axes[2]}, so {axes[2]} must "
            f"be {letter_of(np.cross(a, b))} here"))
    return np.vstack(vecs)
