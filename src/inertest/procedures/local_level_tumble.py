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
from inertest.equipment.motion import Fixture
from inertest.errors import InertestWarning, PlanError
from inertest.estimation.noise_models import NOISE_MODELS
from inertest.models.sdf_gyro import coefficients_from_deg_h
from inertest.models.sdf_gyro import drift as model_drift
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
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
        return cls(positions=tuple(positions), **v)


#: Parameters of the ``[procedure]`` table besides ``positions`` (a list of direction triples,
#: read by :meth:`LocalLevelTumbleSpec.from_mapping`).
FIELDS = (
    Field("samples_per_position", "integer", default=1, positive=True,
          doc="readings at each position (simulation)"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
)




@dataclass(frozen=True, kw_only=True)
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


@dataclass(frozen=True)
class LevelObservations:
    """Local-level tumble data: the position of each row and its inputs from the fixture.

    ``labels`` (``"I O S"`` directions per row), ``f_ios_g`` (n, 3) [g0], ``earth_rate_rad_s``
    (n,) on I [rad/s], ``drift_rad_s`` (n,) indicated minus true input rate [rad/s],
    ``messages``: the axes never both up and down.
    """

    labels: NDArray
    f_ios_g: NDArray[np.float64]
    earth_rate_rad_s: NDArray[np.float64]
    drift_rad_s: NDArray[np.float64]
    messages: list[str]


class LocalLevelTumble(Procedure[LocalLevelTumbleSpec, LevelObservations,
                                 LocalLevelTumbleResult]):
    """Floated gyro, local-level tumble (seed 000, sec. 3): the static drift model from E/W/N/S/U/D.

    Data columns ``I_dir``, ``O_dir``, ``S_dir`` (letters E, W, N, S, U, D; S = south) and
    ``output`` [instrument output unit], in time order; rows with the same directions are one
    position (the unit of independence of the noise model).
    """

    kind = KIND
    title = "Floated gyro, local-level tumble"
    spec = LocalLevelTumbleSpec
    model = "inertest.models.sdf_gyro"
    method = "weighted least squares under a noise model"
    machines = (fixture,)
    noise_models = NOISE_MODELS
    report = "inertest.report.tumble:local_level_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> Fixture:
        """The level fixture at the plan's site (with its Type-B errors)."""
        return Fixture(fixture.motion, plan.site, dict(type_b or {}))

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Fixture
               ) -> LevelObservations:
        """Each row's position, its specific force and Earth rate, and the drift."""
        cols = require_columns(data, ("output",), ("I_dir", "O_dir", "S_dir"), procedure=KIND)
        labels = fixture.position_labels(cols["I_dir"], cols["O_dir"], cols["S_dir"])
        f, w_in = row_inputs(motion.positions(np.unique(labels)), labels)
        drift = plan.instrument.output_to_rate(cols["output"]) - w_in
        messages = _balance_messages(labels)
        for msg in messages:
            warnings.warn(msg, InertestWarning, stacklevel=3)
        return LevelObservations(labels, f, w_in, drift, messages)

    def identify(self, plan: Plan, obs: LevelObservations, *, sigma: float | None,
                 noise_model: str | None) -> LocalLevelTumbleResult:
        """What a local-level tumble determines of the static drift model."""
        site, inst = plan.site, plan.instrument
        drift = obs.drift_rad_s
        lsq, _, ident = identify_drift(
            obs.f_ios_g,
            drift,
            gravity_g=site.gravity_g,
            sigma_rad_s=known_sigma(sigma, inst.rad_s_per_output_unit),
            pivot_order=("DII", "DOO", "DSS", "DF"),
            normalize_to="DF",
            groups=obs.labels,
            noise_model=str(noise_model),
        )
        k = DEG_PER_H_TO_RAD_PER_S
        return LocalLevelTumbleResult(
            site_latitude_deg=site.latitude_deg,
            site_gravity_m_s2=site.gravity_m_s2,
            identification=ident,
            position=obs.labels,
            drift_deg_h=drift / k,
            fitted_deg_h=(drift - lsq.residuals) / k,
            earth_rate_deg_h=obs.earth_rate_rad_s / k,
            residual_output=inst.rate_to_output(lsq.residuals),
            output_unit=inst.output_unit,
            messages=tuple(obs.messages),
        )

    def synthesize(self, plan: Plan, motion: Fixture, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """Columns ``I_dir``, ``O_dir``, ``S_dir``, ``output`` [output unit], Earth rate included.

        ``truth``: coefficients by name [deg/h, deg/h/g, deg/h/g^2]; missing names are 0.
        """
        spec: LocalLevelTumbleSpec = plan.procedure
        reps = spec.samples_per_position
        pos = [p for p in spec.positions for _ in range(reps)]
        cols = [np.array([p[j] for p in pos]) for j in range(3)]
        f, w_in = row_inputs(motion.positions(spec.positions), fixture.position_labels(*cols))
        rate = w_in + model_drift(f, coefficients_from_deg_h(truth))
        output = plan.instrument.rate_to_output(rate) + noise_samples(rate.size, noise, rng)
        return {"I_dir": cols[0], "O_dir": cols[1], "S_dir": cols[2], "output": output}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = LocalLevelTumble()


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
