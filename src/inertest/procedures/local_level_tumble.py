"""Local-level ("geographic") tumble test of an SDF floated gyro in the 1 g field.

Seed ``000_dad8be616c6569c7.txt``, ch. 3, sec. 3: the gyro's axes are set along the local
directions E, S, W, N, U, D. At each position exactly one gyro axis is vertical, so specific force
acts on one axis at a time: the cross-axis terms DIO, DOS, DSI never enter a reading and cannot be
found; the linear terms DI, DO, DS are found from up/down pairs, and each square term only in the
combination ``DF + (g/g0)^2 Dxx`` (because fI^2 + fO^2 + fS^2 = (g/g0)^2). The Earth rate on the
input axis, ``W (I . (0, cos L, sin L))``, is subtracted from each reading.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.equipment import level_fixture as fixture
from inertest.errors import InertestWarning, PlanError
from inertest.estimation.identify import NOISE_MODELS, check_noise_model
from inertest.models.sdf_gyro import coefficients_from_deg_h
from inertest.models.sdf_gyro import drift as model_drift
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.sdf_drift import identify_drift, row_inputs
from inertest.procedures.spec import known_sigma, noise_samples, require_columns
from inertest.results import LinearTestResult
from inertest.units import DEG_PER_H_TO_RAD_PER_S

KIND = "local-level-tumble"


@dataclass(frozen=True)
class LocalLevelTumbleSpec:
    """Parameters of a local-level tumble plan (``[procedure]`` table).

    Attributes
    ----------
    positions : tuple of (str, str, str)
        Directions of (I, O, S) at each position, letters E, W, N, S, U, D (S = south). In a plan
        file: ``positions = ["UNW", "DNE", ...]`` or ``[["U", "N", "W"], ...]``. Default: the 24
        right-handed positions (each axis up and down at four headings).
    samples_per_position : int
        Readings recorded at each position (for simulation).
    noise_model : str
        Noise model behind the uncertainties: ``auto`` (default), ``white``,
        ``position-offsets``, ``random-walk`` or ``flicker``
        (:func:`inertest.estimation.identify.solve`).
    """

    kind: ClassVar[str] = KIND
    positions: tuple[tuple[str, str, str], ...] = field(
        default_factory=lambda: tuple(fixture.all_positions())
    )
    samples_per_position: int = 1
    noise_model: str = "auto"

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> LocalLevelTumbleSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS` and positions)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "positions"))
        if "positions" not in params:
            return cls(**v)
        raw = params["positions"]
        if not isinstance(raw, list) or not raw:
            raise PlanError('positions must be a non-empty list such as ["UNW", "DNE"]')
        positions = []
        for p in raw:
            triple = tuple(p) if isinstance(p, (list, str)) else ()
            if len(triple) != 3 or not all(isinstance(t, str) for t in triple):
                raise PlanError(
                    f"position {p!r} must give three directions (I, O, S), e.g. \"UNW\""
                )
            fixture.axes_from_directions(*triple)  # validates letters and handedness
            positions.append(tuple(t.upper() for t in triple))
        return cls(positions=tuple(positions), **v)  # type: ignore[arg-type]


#: Parameters of the ``[procedure]`` table besides ``positions`` (a list of direction triples,
#: read by :meth:`LocalLevelTumbleSpec.from_mapping`).
FIELDS = (
    Field("samples_per_position", "integer", default=1, positive=True,
          doc="readings at each position (simulation)"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
)


SPEC = LocalLevelTumbleSpec


@dataclass(frozen=True)
class LocalLevelTumbleResult(LinearTestResult):
    """Outcome of :func:`fit` for a local-level tumble.

    Attributes
    ----------
    identification : Identification
        Coefficients (DI, DO, DS when each axis was both up and down), combinations
        ``DF + (g/g0)^2 Dxx``, and the statement of what is not determined.
    position : ndarray of str
        ``"I O S"`` directions of each row.
    drift_deg_h, fitted_deg_h : ndarray
        Observed drift (Earth rate removed) and model value per row [deg/h].
    """

    position: NDArray = field(repr=False)
    drift_deg_h: NDArray[np.float64] = field(repr=False)
    fitted_deg_h: NDArray[np.float64] = field(repr=False)
    earth_rate_deg_h: NDArray[np.float64] = field(repr=False)
    procedure: str = KIND


def fit(
    plan: Plan, data: Mapping[str, object], *, sigma: float | None = None,
    noise_model: str | None = None,
) -> LocalLevelTumbleResult:
    """Identify what a local-level tumble determines of the static drift model.

    Parameters
    ----------
    plan : Plan
        Site, instrument and a :class:`LocalLevelTumbleSpec`.
    data : mapping
        Columns ``I_dir``, ``O_dir``, ``S_dir`` (letters E, W, N, S, U, D; S = south) and
        ``output`` [instrument output unit], in time order; rows with the same directions are one
        position (the unit of independence of the noise model).
    sigma : float, optional
        Known white noise per row [output unit]; estimated from the residuals when omitted.
    noise_model : str, optional
        Overrides the plan's ``noise_model``.
    """
    cols = require_columns(data, ("output",), ("I_dir", "O_dir", "S_dir"), procedure=KIND)
    site, inst = plan.site, plan.instrument
    labels = fixture.position_labels(cols["I_dir"], cols["O_dir"], cols["S_dir"])
    f, w_in = row_inputs(fixture.motion(np.unique(labels), site), labels)
    drift = inst.output_to_rate(cols["output"]) - w_in
    sigma_rad_s = known_sigma(sigma, inst.rad_s_per_output_unit)
    messages = _balance_messages(labels)
    for msg in messages:
        warnings.warn(msg, InertestWarning, stacklevel=2)
    spec: LocalLevelTumbleSpec = plan.procedure
    lsq, _, ident = identify_drift(
        f,
        drift,
        gravity_g=site.gravity_g,
        sigma_rad_s=sigma_rad_s,
        pivot_order=("DII", "DOO", "DSS", "DF"),
        normalize_to="DF",
        groups=labels,
        noise_model=check_noise_model(
            noise_model if noise_model is not None else spec.noise_model),
    )
    k = DEG_PER_H_TO_RAD_PER_S
    return LocalLevelTumbleResult(
        site_latitude_deg=site.latitude_deg,
        site_gravity_m_s2=site.gravity_m_s2,
        identification=ident,
        position=labels,
        drift_deg_h=drift / k,
        fitted_deg_h=(drift - lsq.residuals) / k,
        earth_rate_deg_h=w_in / k,
        residual_output=inst.rate_to_output(lsq.residuals),
        output_unit=inst.output_unit,
        messages=tuple(messages),
    )


def simulate(
    plan: Plan,
    truth: Mapping[str, float],
    *,
    noise: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> dict[str, NDArray]:
    """Readings of a virtual gyro on the plan's local-level tumble (Earth rate included).

    ``truth`` maps coefficient names to values [deg/h, deg/h/g, deg/h/g^2]; missing names are 0.

    Returns columns ``I_dir``, ``O_dir``, ``S_dir``, ``output`` [output unit].
    """
    spec: LocalLevelTumbleSpec = plan.procedure
    reps = spec.samples_per_position
    pos = [p for p in spec.positions for _ in range(reps)]
    cols = [np.array([p[j] for p in pos]) for j in range(3)]
    f, w_in = row_inputs(fixture.motion(spec.positions, plan.site),
                         fixture.position_labels(*cols))
    rate = w_in + model_drift(f, coefficients_from_deg_h(truth))
    output = plan.instrument.rate_to_output(rate) + noise_samples(rate.size, noise, rng)
    return {"I_dir": cols[0], "O_dir": cols[1], "S_dir": cols[2], "output": output}


def _balance_messages(labels: NDArray) -> list[str]:
    """Each axis should be up and down: otherwise its linear term mixes with DF."""
    out = []
    for j, axis in enumerate("IOS"):
        dirs = {lab.split(" ")[j] for lab in np.unique(labels)}
        if not {"U", "D"} <= dirs:
            have = "up" if "U" in dirs else ("down" if "D" in dirs else "vertical")
            out.append(
                f"the {axis} axis is never "
                + ("both up and down" if have != "vertical" else "vertical")
                + f"; D{axis} is then not separable from DF and D{axis}{axis}"
            )
    return out
