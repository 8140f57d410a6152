"""Type-B error sources of the test equipment, and how each machine applies them to its motion.

A lab equipment file states the standard uncertainties (k = 1) of a table, dividing head or
centrifuge (``rate_ppm``, ``tilt_urad``, ``angle_arcsec``, ``radius_um``, see
:mod:`inertest.quality.lab`). Each equipment module declares, in its ``TYPE_B`` tuple of
:class:`TypeBSource`, which of them it accepts and how the error enters its kinematics; its
motion takes the errors it carries as an argument (``type_b``: ``{source name: error [SI]}``,
read with :func:`type_b_error`; none for the nominal machine). So the uncertainty budget
(:mod:`inertest.quality.budget`) can simulate a test on a machine with a given error
(:meth:`inertest.procedures.base.Procedure.motion`) and fit it with the nominal machine, without
any procedure knowing about Type-B sources (JCGM 100:2008, GUM 5.1.3: the sensitivity coefficient
as the change of the output estimate for a change of one input estimate).

Every source is applied as one systematic error common to all positions and runs of the test
(an index zero error, a rate-scale error, a tilt of the table axis), the error a calibration
certificate states.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation


@dataclass(frozen=True)
class TypeBSource:
    """One Type-B error a machine accepts.

    Attributes
    ----------
    name : str
        Name without the unit suffix, as :attr:`inertest.quality.lab.TypeB.name` (``"tilt"``).
    si_unit : str
        Unit of the error inside the library (``"rad"``, ``"1"``, ``"m"``).
    effect : str
        How the machine's motion applies it, in plain language.
    components : tuple of (str, str)
        When one lab-file value applies to several independent directions (the two tilt
        directions of a table axis): ``(component, effect)`` pairs. The budget applies the
        lab file's standard uncertainty to each component on its own, under the error name
        ``"<name>.<component>"`` (:func:`component_error`); empty for a single error.
    """

    name: str
    si_unit: str
    effect: str
    components: tuple[tuple[str, str], ...] = ()

    def error_names(self) -> tuple[tuple[str, str, str], ...]:
        """``(error name, component, effect)`` per applied error: the name itself when single."""
        if not self.components:
            return ((self.name, "", self.effect),)
        return tuple((component_error(self.name, c), c, e) for c, e in self.components)


def component_error(name: str, component: str) -> str:
    """Error name of one component of a source: ``"tilt.east-west"``."""
    return f"{name}.{component}"


def type_b_error(type_b: Mapping[str, float] | None, name: str) -> float:
    """The Type-B error ``name`` a machine carries [SI]: 0.0 when ``type_b`` does not name it."""
    return 0.0 if type_b is None else float(type_b.get(name, 0.0))


def tilt_rotation(
    tilt_rad: float, axis_enu: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Rotation (3, 3) in ENU that tilts a machine by ``tilt_rad`` about a horizontal axis.

    Parameters
    ----------
    tilt_rad : float
        Tilt [rad].
    axis_enu : ndarray, shape (3,), optional
        The machine's own axis; the tilt is about the horizontal direction perpendicular to it
        (east when the axis is vertical or along north, north when it is along east). Default:
        about east.
    """
    east, north = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    about = east
    if axis_enu is not None and abs(float(np.dot(axis_enu, east))) > 0.9:
        about = north
    return Rotation.from_rotvec(tilt_rad * about).as_matrix()


def axis_tilt_rotation(tilt_rad: float, axis_enu: NDArray[np.float64],
                       towards_enu: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation (3, 3) in ENU turning the unit ``axis_enu`` by ``tilt_rad`` towards ``towards_enu``.

    Parameters
    ----------
    tilt_rad : float
        Tilt [rad].
    axis_enu, towards_enu : ndarray, shape (3,)
        The machine's axis and a direction perpendicular to it (e.g. east for a polar axis);
        the rotation is about ``axis x towards``, so ``axis`` moves by ``tilt_rad * towards``
        to first order.
    """
    about = np.cross(axis_enu, towards_enu)
    return Rotation.from_rotvec(tilt_rad * about / np.linalg.norm(about)).as_matrix()
