"""Static-base error equations of a north-pointing local-level INS: the linear system.

Seed ``002_1196b4fb2ac75bfc.txt`` (INS error propagation report), with the sign conventions
below (the seed's own gyro term differs; see the last paragraph). States, in SI::

    x = [dVE, dVN, dL, dlambda, phiE, phiN, phiU]      (m/s, m/s, rad, rad, rad, rad, rad)

Inputs (constant or time-varying sources), in SI::

    u = [bE, bN, eE, eN, eU]                            (m/s^2, m/s^2, rad/s, rad/s, rad/s)

Sign conventions (the one statement of them; ``ins-errors``, ``modulation system`` and the
closed forms follow it)
--------------------------------------------------------------------------------------------
* **Errors are computed minus true**: ``dVE = VE_computed - VE_true``, likewise ``dVN``,
  ``dL`` (latitude) and ``dlambda`` (longitude), all in the ENU frame (x east, y north, z up).
* **Gyro drift is an output error of the gyro** (the package convention,
  :mod:`inertest`: ``w_out = w_true + drift``). ``eE, eN, eU`` are the gyro output errors
  resolved in ENU, ``e^n = C_b^n dw_ib^b`` (drift, and for a moving IMU scale factor and
  misalignment times the true rate). A positive drift makes the computed frame turn
  *negatively*: it enters ``phi'`` with a minus sign.
* **Accelerometer bias is an output error of the accelerometer** (``f_out = f_true + bias``);
  ``bE, bN`` are resolved in ENU, ``b^n = C_b^n df^b``. It enters ``dV'`` with a plus sign.
* **phi** is the attitude error of the computed (platform) frame p relative to the *true*
  ENU frame n: ``C_b^n(computed) = (I - [phi x]) C_b^n(true)``, i.e. the computed frame is
  the true one turned by the small right-handed rotation vector ``phi`` (``C_n^p = I -
  [phi x]``). phiE, phiN are the tilts about east and north, phiU the azimuth error (positive
  about up, counter-clockwise seen from above).
* **psi** (not a state here) is the same attitude error relative to the *computed* ENU frame
  c at the computed position: ``phi = psi + dtheta`` with the position-error angle
  ``dtheta = (-dL, dlambda cos L, dlambda sin L)`` (the rotation from n to c, same sign rule);
  the psi form of the equations (D. O. Benson, "A comparison of two approaches to
  pure-inertial and Doppler-inertial error analysis", IEEE Trans. Aerosp. Electron. Syst.
  11(4), 1975, doi:10.1109/TAES.1975.308101) is equivalent.

Equations: the attitude and velocity error equations of a strapdown system (Titterton &
Weston, *Strapdown Inertial Navigation Technology*, 2nd ed. 2004, ch. 12; Britting,
*Inertial Navigation Systems Analysis*, 1971), ``phi' = -w_in^n x phi + dw_in^n - C_b^n
dw_ib^b`` and ``dV' = f^n x phi + C_b^n df^b - (2 w_ie^n + w_en^n) x dV - ...``, on a static
base (``V = 0``, ``f^n = (0, 0, g)``, vertical channel left out)::

    dVE'     = -g phiN + 2 W sinL dVN + bE
    dVN'     =  g phiE - 2 W sinL dVE + bN
    dL'      =  dVN / R
    dlambda' =  dVE / (R cosL)
    phiE'    = -dVN / R + W sinL phiN - W cosL phiU - eE
    phiN'    =  dVE / R - W sinL dL - W sinL phiE - eN
    phiU'    =  dVE tanL / R + W cosL dL + W cosL phiE - eU

``coriolis=False`` drops the two ``2 W sinL`` terms: the source's simplified model, which has
no Foucault modulation of the Schuler oscillation.

The seed writes ``+eps`` in ``phi'`` because its ``eps`` is the *platform* drift rate caused
by the gyro torques (a gimballed platform that turns at ``eps``); the computed frame of a
strapdown system turns at minus the gyro output error, so ``eps_seed = -e`` (checked against
an independent nonlinear strapdown simulation in ``tests/ins/test_strapdown_reference.py``).

This module holds only the matrices ``x' = A x + B u``; solutions live in
:mod:`inertest.ins.propagation` and the rotation-modulation study in
:mod:`inertest.studies.rotation_modulation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from inertest.earth import OMEGA_IE, normal_gravity
from inertest.errors import InputError

#: State names, in order, as used in JSON output and tables.
STATES: tuple[str, ...] = ("dVE", "dVN", "dL", "dlambda", "phiE", "phiN", "phiU")
#: SI unit of each state.
STATE_UNITS: dict[str, str] = {
    "dVE": "m/s",
    "dVN": "m/s",
    "dL": "rad",
    "dlambda": "rad",
    "phiE": "rad",
    "phiN": "rad",
    "phiU": "rad",
}
#: Input (error source) names, in order.
INPUTS: tuple[str, ...] = ("bE", "bN", "eE", "eN", "eU")
#: One-line statement of the sign conventions, for command outputs and reports.
SIGN_CONVENTION = (
    "errors = computed - true (ENU); gyro drift and accelerometer bias are sensor output "
    "errors (output = true + error) resolved in ENU; phi turns the true ENU frame into the "
    "computed one, C_b^n(computed) = (I - [phi x]) C_b^n(true), so phi' = ... - drift and "
    "dV' = ... + bias"
)
#: SI unit of each input.
INPUT_UNITS: dict[str, str] = {
    "bE": "m/s^2",
    "bN": "m/s^2",
    "eE": "rad/s",
    "eN": "rad/s",
    "eU": "rad/s",
}

#: Mean equatorial radius used by default (WGS-84 semi-major axis), m.
DEFAULT_RADIUS_M = 6378137.0


@dataclass(frozen=True)
class InsSite:
    """Where and how the error equations are linearised.

    Attributes
    ----------
    latitude_rad : float
        Geodetic latitude L, rad; ``|L| < pi/2`` (the equations contain sec L and tan L).
    radius_m : float
        Earth radius R, m.
    gravity_m_s2 : float
        Magnitude of gravity g, m/s^2.
    earth_rate_rad_s : float
        Earth rate W, rad/s.
    coriolis : bool
        Keep the ``2 W sinL`` Coriolis cross-coupling of the velocity errors.
    """

    latitude_rad: float
    radius_m: float = DEFAULT_RADIUS_M
    gravity_m_s2: float = float("nan")
    earth_rate_rad_s: float = OMEGA_IE
    coriolis: bool = True

    def __post_init__(self) -> None:
        lat = float(self.latitude_rad)
        if not math.isfinite(lat) or abs(lat) >= math.pi / 2 - 1e-9:
            raise InputError(
                f"latitude {math.degrees(lat):g} deg is at or beyond +-90 deg: the error "
                "equations contain sec L and tan L; use a latitude strictly between -90 and 90 deg"
            )
        if not (math.isfinite(self.radius_m) and self.radius_m > 0):
            raise InputError(f"Earth radius must be positive and finite, got {self.radius_m} m")
        if math.isnan(self.gravity_m_s2):
            object.__setattr__(self, "gravity_m_s2", float(normal_gravity(lat)))
        if not (math.isfinite(self.gravity_m_s2) and self.gravity_m_s2 > 0):
            raise InputError(f"gravity must be positive and finite, got {self.gravity_m_s2} m/s^2")
        if not (math.isfinite(self.earth_rate_rad_s) and self.earth_rate_rad_s >= 0):
            raise InputError(f"Earth rate must be finite and >= 0, got {self.earth_rate_rad_s}")


def system_matrix(site: InsSite) -> NDArray[np.float64]:
    """The 7x7 state matrix ``A`` of ``x' = A x + B u`` (module docstring; seed 002)."""
    lat, r, g, w = site.latitude_rad, site.radius_m, site.gravity_m_s2, site.earth_rate_rad_s
    s, c, t = math.sin(lat), math.cos(lat), math.tan(lat)
    k = 2.0 * w * s if site.coriolis else 0.0
    a = np.zeros((7, 7))
    # dVE'
    a[0, 5] = -g
    a[0, 1] = k
    # dVN'
    a[1, 4] = g
    a[1, 0] = -k
    # dL', dlambda'
    a[2, 1] = 1.0 / r
    a[3, 0] = 1.0 / (r * c)
    # phiE'
    a[4, 1] = -1.0 / r
    a[4, 5] = w * s
    a[4, 6] = -w * c
    # phiN'
    a[5, 0] = 1.0 / r
    a[5, 2] = -w * s
    a[5, 4] = -w * s
    # phiU'
    a[6, 0] = t / r
    a[6, 2] = w * c
    a[6, 4] = w * c
    return a


def input_matrix() -> NDArray[np.float64]:
    """The 7x5 input matrix ``B``: biases drive dVE, dVN (+1), gyro drifts phiE, phiN, phiU (-1).

    Both are sensor output errors resolved in ENU (module docstring, sign conventions).
    """
    b = np.zeros((7, 5))
    b[0, 0] = b[1, 1] = 1.0
    b[4, 2] = b[5, 3] = b[6, 4] = -1.0
    return b


#: Largest attitude error [rad] at which the linear (small-angle) error model is trusted: 0.5
#: deg, where its histories are off by up to about 4 % of their range (:data:`MISFIT_PER_RAD`).
LINEAR_LIMIT_RAD = math.radians(0.5)
#: Misfit of the linear histories per radian of attitude error, as a fraction of each state's
#: range: measured against an independent nonlinear strapdown navigator (the one of
#: ``tests/ins/test_strapdown_reference.py``) over 24 h, 0.081 per degree where the heading
#: error comes from a vertical drift (a 20 ppm z scale factor under single-axis rotation at
#: 6 deg/s: 1.64 deg, 13.3 %; a static 0.1 deg/h vertical drift: 0.39 deg, 3.3 %) and 0.013 per
#: degree from a horizontal drift (0.5 deg/h east: 4.97 deg, 6.4 %). The larger, rounded up to
#: 0.085 per degree, is stated.
MISFIT_PER_RAD = 0.085 * 180.0 / math.pi


@dataclass(frozen=True)
class LinearValidity:
    """How far the linear (first-order, small-angle) error model can be trusted on a run.

    The error equations drop every product of two errors (``phi x phi``, ``phi x dV``, the
    second-order terms of the direction cosines), which grow with the attitude error: the
    largest over the run is the measure, and :data:`MISFIT_PER_RAD` times it the expected
    misfit of the histories (checked against a nonlinear strapdown navigator).

    Attributes
    ----------
    max_attitude_error_rad : float
        Largest ``|phi|`` over the run [rad].
    expected_misfit : float
        Expected largest misfit of a linear history, as a fraction of its range [-].
    limit_rad : float
        The attitude error above which the result warns [rad].
    """

    max_attitude_error_rad: float
    expected_misfit: float
    limit_rad: float = LINEAR_LIMIT_RAD

    @property
    def valid(self) -> bool:
        """The attitude error stays within :attr:`limit_rad`."""
        return self.max_attitude_error_rad <= self.limit_rad

    @property
    def message(self) -> str | None:
        """The warning when the linear model no longer holds, else None."""
        if self.valid:
            return None
        return (f"the attitude error reaches {math.degrees(self.max_attitude_error_rad):.2f} "
                f"deg, above the {math.degrees(self.limit_rad):g} deg where the linear error "
                f"model holds to a few percent: its histories may be off by up to about "
                f"{self.expected_misfit:.0%} of their range (second-order terms); read them as "
                "estimates, or shorten the span or reduce the errors")

    def to_dict(self) -> dict[str, object]:
        """JSON block ``linear_model`` (SI, with units)."""
        return {"max_attitude_error_rad": self.max_attitude_error_rad,
                "expected_misfit_fraction": self.expected_misfit,
                "limit_rad": self.limit_rad, "valid": self.valid,
                "basis": "misfit per radian of attitude error against a nonlinear strapdown "
                         "navigator (24 h, static and single-axis rotation)",
                "units": {"max_attitude_error_rad": "rad", "expected_misfit_fraction": "-",
                          "limit_rad": "rad"}}


def linear_validity(phi: NDArray[np.float64]) -> LinearValidity:
    """The :class:`LinearValidity` of a run from its attitude errors ``phi`` (n, 3) [rad]."""
    worst = float(np.max(np.linalg.norm(np.asarray(phi, dtype=float), axis=-1), initial=0.0))
    return LinearValidity(worst, MISFIT_PER_RAD * worst)
