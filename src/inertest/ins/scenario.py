"""An INS error-propagation scenario: where, for how long, and which error sources.

A scenario gathers the linearisation point (:class:`~inertest.ins.error_model.InsSite`),
the initial errors ``x0`` and the constant sources ``u`` of the static-base error equations,
all in SI. :func:`scenario_from_mapping` builds one from engineering units (a parsed TOML file
or command-line options); :func:`seed_scenario` is the worked example of the source.

Engineering keys (each quantity accepts one of the listed unit suffixes)::

    [site]    latitude_deg, gravity_m_s2, radius_m, earth_rate_rad_s, coriolis (bool)
    [run]     hours, step_s
    [errors]  accel_bias_ug | accel_bias_local_g | accel_bias_m_s2           = [E, N]
              gyro_drift_deg_h | gyro_drift_rad_s                           = [E, N, U]
              initial_velocity_m_s                                          = [E, N]
              initial_position_arcsec | initial_position_deg | initial_position_rad = [lat, lon]
              initial_attitude_arcsec | initial_attitude_arcmin | initial_attitude_rad = [E, N, U]

``ug`` is micro-g with g = g0 = 9.80665 m/s^2 (house convention); ``local_g`` is a multiple of
the scenario's own gravity (the source writes biases as ``1e-4 g`` with its ``g = 9.8``).
``accel_bias`` and ``gyro_drift`` are sensor output errors (output = true + error) resolved in
ENU; initial errors are computed minus true, ``initial_attitude`` is ``phi`` (the sign
conventions of :mod:`inertest.ins.error_model`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.earth import OMEGA_IE
from inertest.errors import InputError
from inertest.ins.error_model import DEFAULT_RADIUS_M, InsSite
from inertest.plan import check_known_keys, finite_number, toml_table
from inertest.units import (
    ARCMIN_TO_RAD,
    ARCSEC_TO_RAD,
    DEG_PER_H_TO_RAD_PER_S,
    DEG_TO_RAD,
    HOUR_TO_S,
    MICRO_G_TO_M_PER_S2,
)

# TOML validation with this module's error class (InputError).
_table = partial(toml_table, error=InputError)
_known = partial(check_known_keys, error=InputError)
_number = partial(finite_number, error=InputError)

__all__ = [
    "InsScenario",
    "scenario_from_mapping",
    "seed_scenario",
    "time_grid",
]

#: Quantity -> (count, {unit suffix: factor to SI, or "local_g"}).
_QUANTITIES: dict[str, tuple[int, dict[str, float | str]]] = {
    "accel_bias": (2, {"ug": MICRO_G_TO_M_PER_S2, "local_g": "local_g", "m_s2": 1.0}),
    "gyro_drift": (3, {"deg_h": DEG_PER_H_TO_RAD_PER_S, "rad_s": 1.0}),
    "initial_velocity": (2, {"m_s": 1.0}),
    "initial_position": (2, {"arcsec": ARCSEC_TO_RAD, "deg": DEG_TO_RAD, "rad": 1.0}),
    "initial_attitude": (3, {"arcsec": ARCSEC_TO_RAD, "arcmin": ARCMIN_TO_RAD, "rad": 1.0}),
}
_SITE_KEYS = {"latitude_deg", "gravity_m_s2", "radius_m", "earth_rate_rad_s", "coriolis", "name"}
_RUN_KEYS = {"hours", "step_s"}


@dataclass(frozen=True)
class InsScenario:
    """Site, duration and error sources of one propagation study, in SI.

    Attributes
    ----------
    site : InsSite
        Linearisation point.
    x0 : ndarray, shape (7,)
        Initial errors ``[dVE, dVN, dL, dlambda, phiE, phiN, phiU]`` [m/s, m/s, rad x 5].
    u : ndarray, shape (5,)
        Constant sources ``[bE, bN, eE, eN, eU]`` [m/s^2, m/s^2, rad/s x 3].
    duration_s : float
        Length of the run [s].
    step_s : float
        Output sample interval [s] (the solution is exact at every sample, whatever the step).
    name : str
        Label for reports.
    """

    site: InsSite
    x0: NDArray[np.float64] = field(default_factory=lambda: np.zeros(7))
    u: NDArray[np.float64] = field(default_factory=lambda: np.zeros(5))
    duration_s: float = 24 * HOUR_TO_S
    step_s: float = 60.0
    name: str = ""

    def __post_init__(self) -> None:
        x0 = np.asarray(self.x0, dtype=float)
        u = np.asarray(self.u, dtype=float)
        if x0.shape != (7,) or u.shape != (5,):
            raise InputError(f"x0 must have 7 and u 5 entries, got {x0.shape} and {u.shape}")
        if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(u))):
            raise InputError("initial errors and error sources must be finite numbers")
        object.__setattr__(self, "x0", x0)
        object.__setattr__(self, "u", u)
        time_grid(self.duration_s, self.step_s)  # validates both


def time_grid(duration_s: float, step_s: float) -> NDArray[np.float64]:
    """Samples ``0, step, 2 step, ...`` up to and including ``duration_s`` (when it is a multiple).

    Raises
    ------
    InputError
        When the duration or the step is not positive and finite, or the step exceeds the
        duration.
    """
    d, h = float(duration_s), float(step_s)
    if not (math.isfinite(d) and d > 0):
        raise InputError(f"duration must be positive, got {d:g} s; give e.g. --hours 24")
    if not (math.isfinite(h) and h > 0):
        raise InputError(f"step must be positive, got {h:g} s; give e.g. --step 1")
    if h > d:
        raise InputError(f"step {h:g} s is longer than the duration {d:g} s; use a smaller step")
    n = int(math.floor(d / h * (1 + 1e-12))) + 1
    if n > 50_000_000:
        raise InputError(f"{n} samples is too many; use a larger step")
    return h * np.arange(n, dtype=float)


def scenario_from_mapping(
    doc: Mapping[str, Any], *, source: str = "scenario"
) -> InsScenario:
    """Build a scenario from ``[site]``, ``[run]`` and ``[errors]`` tables in engineering units.

    Parameters
    ----------
    doc : mapping
        Parsed TOML (keys in the module docstring). Missing error keys are zero; missing
        gravity is the normal gravity at the latitude, missing radius 6378137 m.
    source : str
        Name used in error messages (e.g. the file name).

    Raises
    ------
    InputError
        For unknown keys, wrong list lengths, non-numbers, or two units for one quantity.
    """
    site_t = _table(doc, "site", source)
    run_t = _table(doc, "run", source)
    err_t = _table(doc, "errors", source)
    unknown = sorted(set(doc) - {"site", "run", "errors", "name"})
    if unknown:
        raise InputError(f"{source}: unknown table(s) {', '.join(unknown)}; known: site, run, "
                         "errors, name")
    _known(site_t, _SITE_KEYS, f"{source} [site]")
    _known(run_t, _RUN_KEYS, f"{source} [run]")
    if "latitude_deg" not in site_t:
        raise InputError(f"{source}: [site] needs latitude_deg (geodetic latitude in degrees)")
    coriolis = site_t.get("coriolis", True)
    if not isinstance(coriolis, bool):
        raise InputError(f"{source}: [site] coriolis must be true or false, got {coriolis!r}")
    site = InsSite(
        latitude_rad=_number(site_t["latitude_deg"], "latitude_deg", source) * DEG_TO_RAD,
        radius_m=_number(site_t.get("radius_m", DEFAULT_RADIUS_M), "radius_m", source),
        gravity_m_s2=(_number(site_t["gravity_m_s2"], "gravity_m_s2", source)
                      if "gravity_m_s2" in site_t else float("nan")),  # nan: normal gravity
        earth_rate_rad_s=_number(site_t.get("earth_rate_rad_s", OMEGA_IE), "earth_rate_rad_s",
                                 source),
        coriolis=coriolis,
    )
    values = _errors(err_t, site.gravity_m_s2, source)
    x0 = np.zeros(7)
    x0[0:2] = values["initial_velocity"]
    x0[2:4] = values["initial_position"]
    x0[4:7] = values["initial_attitude"]
    u = np.concatenate([values["accel_bias"], values["gyro_drift"]])
    return InsScenario(
        site=site,
        x0=x0,
        u=u,
        duration_s=_number(run_t.get("hours", 24.0), "hours", source) * HOUR_TO_S,
        step_s=_number(run_t.get("step_s", 60.0), "step_s", source),
        name=str(doc.get("name", site_t.get("name", ""))),
    )


def seed_scenario() -> InsScenario:
    """The worked example of seed 002: L = 39 deg, 24 h, every source at once.

    The source's MATLAB script sets ``g = 9.8``, Schuler period exactly 84.4 min
    (``R = g / ws^2`` with ``ws = 2 pi / (84.4 * 60)``), Earth rate ``2 pi / 24 h`` (the solar
    day), biases ``1e-4 g``, drifts 0.1 deg/h on E, N, U, initial velocity errors 0.1 m/s,
    position errors 0.0005 deg, attitude errors 20", 20", 5', and the simplified error model
    without the Coriolis terms. Its output grid is ``t = 0:10:ts``.

    The source's drift is the *platform* drift rate (it enters ``phi'`` with ``+``); in this
    package's convention (gyro output error, entering with ``-``;
    :mod:`inertest.ins.error_model`) the same platform drift is a gyro drift of
    **-0.1 deg/h**, which is what this scenario holds, so that its curves are the source's.
    """
    g = 9.8
    ws = 2 * math.pi / (84.4 * 60)
    site = InsSite(
        latitude_rad=39 * DEG_TO_RAD,
        radius_m=g / ws**2,
        gravity_m_s2=g,
        earth_rate_rad_s=2 * math.pi / (24 * HOUR_TO_S),
        coriolis=False,
    )
    drift = -0.1 * DEG_PER_H_TO_RAD_PER_S  # the source's +0.1 deg/h platform drift
    x0 = np.array([0.1, 0.1, 0.0005 * DEG_TO_RAD, 0.0005 * DEG_TO_RAD,
                   20 * ARCSEC_TO_RAD, 20 * ARCSEC_TO_RAD, 5 * ARCMIN_TO_RAD])
    u = np.array([1e-4 * g, 1e-4 * g, drift, drift, drift])
    return InsScenario(site=site, x0=x0, u=u, duration_s=24 * HOUR_TO_S, step_s=10.0,
                       name="worked example of the INS error-propagation report (L = 39 deg, 24 h)")



def _errors(t: Mapping[str, Any], gravity: float, source: str) -> dict[str, NDArray[np.float64]]:
    known = {f"{q}_{sfx}" for q, (_, units) in _QUANTITIES.items() for sfx in units}
    _known(t, known, f"{source} [errors]")
    out: dict[str, NDArray[np.float64]] = {}
    for q, (count, units) in _QUANTITIES.items():
        given = [sfx for sfx in units if f"{q}_{sfx}" in t]
        if len(given) > 1:
            keys = ", ".join(f"{q}_{sfx}" for sfx in given)
            raise InputError(f"{source}: [errors] gives {q} twice ({keys}); keep one")
        if not given:
            out[q] = np.zeros(count)
            continue
        key = f"{q}_{given[0]}"
        vals = t[key]
        if not isinstance(vals, Sequence) or isinstance(vals, str) or len(vals) != count:
            raise InputError(f"{source}: {key} must be a list of {count} numbers, got {vals!r}")
        arr = np.array([_number(v, key, source) for v in vals])
        factor = units[given[0]]
        out[q] = arr * (gravity if factor == "local_g" else float(factor))
    return out
