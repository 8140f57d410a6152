"""The site: normal gravity, Earth rate and the local-level ENU frame.

Frame convention: local level ENU, x east, y north, z up. An instrument at rest on the Earth
feels a specific force of magnitude g (local gravity) pointing up, and the Earth rate
``OMEGA_IE`` about the polar axis, whose ENU components are ``(0, W cos L, W sin L)``.

References
----------
NIMA TR8350.2 (3rd ed., 2000), "Department of Defense World Geodetic System 1984", eq. (4-1)
(Somigliana's closed formula) and table 3.1/3.4 (constants).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.units import DEG_TO_RAD, G0

#: WGS-84 Earth rotation rate [rad/s] (TR8350.2 table 3.1).
OMEGA_IE = 7.2921151467e-5
#: WGS-84 semi-major axis [m].
WGS84_A = 6378137.0
#: WGS-84 normal gravity at the equator [m/s^2] (TR8350.2 table 3.4).
WGS84_GAMMA_E = 9.7803253359
#: WGS-84 Somigliana constant k = b*gamma_p/(a*gamma_e) - 1 [-] (TR8350.2 table 3.4).
WGS84_K = 0.00193185265241
#: WGS-84 first eccentricity squared [-] (TR8350.2 table 3.3).
WGS84_E2 = 6.69437999014e-3

#: Unit vectors of the six local directions in ENU. "S" is south here (as in the sources'
#: local-level tumble), not the gyro's spin axis.
DIRECTIONS_ENU: dict[str, NDArray[np.float64]] = {
    "E": np.array([1.0, 0.0, 0.0]),
    "W": np.array([-1.0, 0.0, 0.0]),
    "N": np.array([0.0, 1.0, 0.0]),
    "S": np.array([0.0, -1.0, 0.0]),
    "U": np.array([0.0, 0.0, 1.0]),
    "D": np.array([0.0, 0.0, -1.0]),
}


def check_latitude(latitude_rad: float, *, allow_poles: bool = True) -> float:
    """Return ``latitude_rad`` as float after checking it lies in [-pi/2, pi/2]."""
    lat = float(latitude_rad)
    if not np.isfinite(lat) or abs(lat) > np.pi / 2 + 1e-15:
        raise InputError(
            f"latitude must be within [-90, 90] deg, got {np.degrees(lat):g} deg"
        )
    if not allow_poles and abs(abs(lat) - np.pi / 2) < 1e-12:
        raise InputError("latitude must be strictly between -90 and 90 deg (sec L is infinite)")
    return lat


def normal_gravity(latitude_rad: ArrayLike) -> NDArray[np.float64]:
    """Normal gravity on the WGS-84 ellipsoid at geodetic latitude ``latitude_rad``.

    Parameters
    ----------
    latitude_rad : array_like
        Geodetic latitude [rad].

    Returns
    -------
    ndarray
        Magnitude of normal gravity at height zero [m/s^2].

    Notes
    -----
    Somigliana's closed formula, NIMA TR8350.2 eq. (4-1)::

        gamma = gamma_e (1 + k sin^2 L) / sqrt(1 - e^2 sin^2 L)

    It gives 9.7803253359 m/s^2 at the equator and 9.8321849379 m/s^2 at the poles.
    """
    s2 = np.sin(np.asarray(latitude_rad, dtype=float)) ** 2
    return WGS84_GAMMA_E * (1.0 + WGS84_K * s2) / np.sqrt(1.0 - WGS84_E2 * s2)


def earth_rate_enu(latitude_rad: float) -> NDArray[np.float64]:
    """Earth rotation vector in the ENU frame [rad/s], ``(0, W cos L, W sin L)``."""
    lat = check_latitude(latitude_rad)
    return OMEGA_IE * np.array([0.0, np.cos(lat), np.sin(lat)])


def specific_force_enu(gravity_m_s2: float) -> NDArray[np.float64]:
    """Specific force on an instrument at rest in ENU [m/s^2]: ``(0, 0, +g)``."""
    return np.array([0.0, 0.0, float(gravity_m_s2)])


def polar_axis_enu(latitude_rad: float) -> NDArray[np.float64]:
    """Unit vector of the Earth's axis pointing to the north celestial pole, in ENU."""
    lat = check_latitude(latitude_rad)
    return np.array([0.0, np.cos(lat), np.sin(lat)])


@dataclass(frozen=True)
class Site:
    """Where a test runs.

    Attributes
    ----------
    latitude_rad : float
        Geodetic latitude [rad].
    gravity_m_s2 : float
        Local gravity magnitude [m/s^2]; the normal gravity at the latitude unless measured.
    """

    latitude_rad: float
    gravity_m_s2: float

    @classmethod
    def at(cls, latitude_deg: float, gravity_m_s2: float | None = None) -> Site:
        """Site at ``latitude_deg`` [deg]; gravity from Somigliana's formula when not given."""
        lat = check_latitude(float(latitude_deg) * DEG_TO_RAD)
        g = float(normal_gravity(lat)) if gravity_m_s2 is None else float(gravity_m_s2)
        if not np.isfinite(g) or not 9.7 < g < 9.9:
            raise InputError(
                f"site gravity must be a local gravity in m/s^2 (about 9.78 to 9.83), got {g:g}"
            )
        return cls(latitude_rad=lat, gravity_m_s2=g)

    @property
    def latitude_deg(self) -> float:
        """Latitude [deg]."""
        return float(np.degrees(self.latitude_rad))

    @property
    def gravity_g(self) -> float:
        """Local gravity as a multiple of standard gravity g0 [-]."""
        return self.gravity_m_s2 / G0
