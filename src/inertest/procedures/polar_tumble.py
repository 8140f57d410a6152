"""Polar-axis tumble test of an SDF floated gyro in the 1 g field.

Seed ``000_dad8be616c6569c7.txt`` (NWPU lecture notes, ch. 3, sec. 2): the turntable axis is
parallel to the Earth's axis, the gyro's I axis perpendicular to it (so ``w_I = 0``), and the
table turns through equally spaced angles over 360 deg in each of four mountings (O or S axis to
the north or south pole). At each mounting the drift is a Fourier series in the table angle::

    S_T i = B0 + S1 sin(theta) + C1 cos(theta) + S2 sin(2 theta) + C2 cos(2 theta)

With gamma = g/g0 and latitude L, for the O mountings (upper sign Np, lower Sp)::

    B0 = DF +- gamma sinL DO + gamma^2 sin^2L DOO + gamma^2 cos^2L (DII + DSS) / 2
    S1 = gamma cosL (DI +- gamma sinL DIO)        C1 = gamma cosL (DS +- gamma sinL DOS)
    S2 = gamma^2 cos^2L DSI / 2                   C2 = gamma^2 cos^2L (DSS - DII) / 2

and for the S mountings the same with (O, S) exchanged in B0, C1 and DIO in S2, DSI in S1,
(DOO - DII) in C2. The closed-form separation (seed, sec. 2(4), with gamma restored) follows
from sums and differences of the Np and Sp terms; it is computed here beside the general least
squares over all data, and the two agree exactly for noise-free data.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.equipment import polar_axis_table as table
from inertest.equipment.motion import Fixture, run_starts
from inertest.errors import DataError, IdentifiabilityError, InertestWarning, PlanError
from inertest.estimation.harmonics import HarmonicFit, harmonic_design, harmonic_names
from inertest.estimation.identify import NoiseFit, combination_name
from inertest.estimation.least_squares import weighted_least_squares
from inertest.estimation.noise_models import (
    BIAS_TIME_SCALE_DEFAULT,
    NOISE_MODELS,
    check_bias_time_scale,
)
from inertest.models.sdf_gyro import ENGINEERING_UNIT, coefficients_from_deg_h
from inertest.models.sdf_gyro import drift as model_drift
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.sdf_drift import identify_drift, position_inputs, row_inputs
from inertest.procedures.spec import known_sigma, noise_samples, require_columns
from inertest.results import Combination, Estimate, LinearTestResult
from inertest.units import DEG_PER_H_TO_RAD_PER_S, DEG_TO_RAD

KIND = "polar-tumble"
#: Latitudes closer than this to a pole leave I without gravity: the test needs cos L > 0.
_MIN_COS_LAT = 0.05


@dataclass(frozen=True)
class PolarTumbleSpec:
    """Parameters of a polar-axis tumble plan (``[procedure]`` table).

    Attributes
    ----------
    mountings : tuple of str
        Mountings to run, any of ``O-Np``, ``O-Sp``, ``S-Np``, ``S-Sp`` (default all four).
    angles_deg : tuple of float
        Table angles [deg]; default 16 equally spaced from 0 (``positions = 16``).
    samples_per_position : int
        Readings recorded at each angle (for simulation).
    noise_model : str
        Noise model of the gyro behind the uncertainties: ``auto`` (default: chosen by AIC),
        ``white``, ``position-offsets`` (the table re-settles, the drift moves between
        positions), ``random-walk`` or ``flicker``; see
        :func:`inertest.estimation.identify.solve`.
    bias_time_scale : float
        Under flicker noise, the time over which the drift's constant terms (DF + DII) are
        meant, in test durations (e.g. calibration interval / test duration); default 2, about
        the drift during this test. For 1/f noise the bias wanders further over longer times,
        and a longer time scale includes that wander in the std.
    """

    kind: ClassVar[str] = KIND
    mountings: tuple[str, ...] = table.MOUNTINGS
    angles_deg: tuple[float, ...] = tuple(np.arange(16) * 22.5)
    samples_per_position: int = 1
    noise_model: str = "auto"
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> PolarTumbleSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}", ignore=("kind",))
        if v["angles_deg"] is not None and v["positions"] is not None:
            raise PlanError("give either positions (a count) or angles_deg (a list), not both")
        if v["angles_deg"] is not None:
            angles = v["angles_deg"]
        else:
            count = 16 if v["positions"] is None else v["positions"]
            angles = tuple(float(a) for a in np.arange(count) * 360.0 / count)
        return cls(mountings=v["mountings"], angles_deg=angles,
                   samples_per_position=v["samples_per_position"], noise_model=v["noise_model"],
                   bias_time_scale=check_bias_time_scale(v["bias_time_scale"]))


#: Parameters of the ``[procedure]`` table of a polar-tumble plan.
FIELDS = (
    Field("mountings", "texts", default=table.MOUNTINGS, choices=table.MOUNTINGS,
          doc="mountings to run"),
    Field("positions", "integer", default=None, positive=True,
          doc="count of table angles equally spaced over 360 deg from 0 (default 16)"),
    Field("angles_deg", "numbers", default=None, unit="deg", doc="table angles"),
    Field("samples_per_position", "integer", default=1, positive=True,
          doc="readings at each angle (simulation)"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
    Field("bias_time_scale", default=BIAS_TIME_SCALE_DEFAULT, unit="test durations",
          minimum=1.0, doc="time over which the constant terms are meant under flicker noise "
          "(e.g. calibration interval / test duration)"),
)


@dataclass(frozen=True)
class MountingHarmonics:
    """Fourier terms of the drift at one mounting [deg/h], and the data they came from."""

    mounting: str
    terms: tuple[Estimate, ...]
    angles_deg: NDArray[np.float64] = field(repr=False)
    drift_deg_h: NDArray[np.float64] = field(repr=False)
    fit: HarmonicFit = field(repr=False)


@dataclass(frozen=True, kw_only=True)
class PolarTumbleResult(LinearTestResult):
    """Outcome of :func:`fit` for a polar-axis tumble.

    Attributes
    ----------
    identification : Identification
        General least squares over all data: coefficients, combinations, what is not separable.
    harmonics : dict
        Per mounting, the Fourier terms B0, S1, C1, S2, C2 [deg/h] with std.
    closed_form : dict
        Per mounting pair (``"O"``: O-Np + O-Sp, ``"S"``: S-Np + S-Sp), the seed's closed-form
        separation as combinations of coefficients.
    mounting, angle_deg, drift_deg_h, fitted_deg_h : ndarray
        The observations and the general model's fitted values, per row.
    messages : tuple of str
        Warnings about the plan (spacing, count of positions).
    """

    harmonics: dict[str, MountingHarmonics]
    closed_form: dict[str, tuple[Combination, ...]]
    mounting: NDArray = field(repr=False)
    angle_deg: NDArray[np.float64] = field(repr=False)
    drift_deg_h: NDArray[np.float64] = field(repr=False)
    fitted_deg_h: NDArray[np.float64] = field(repr=False)
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d: dict[str, object] = {}
        d["harmonics"] = {
            m: {t.name: t.to_dict() for t in h.terms} for m, h in self.harmonics.items()
        }
        d["closed_form"] = {k: [c.to_dict() for c in v] for k, v in self.closed_form.items()}
        return d


@dataclass(frozen=True)
class TumbleObservations:
    """Polar-tumble data reduced to positions, with the inputs of each from the table.

    Attributes
    ----------
    mounting, angle_deg : ndarray, shape (n,)
        The data's mounting and table angle [deg] of each row.
    starts : ndarray of int
        First row of each run of equal (mounting, angle) rows.
    present : list of str
        Mountings in the data, in :data:`~inertest.equipment.polar_axis_table.MOUNTINGS` order.
    labels : ndarray of str, shape (G,)
        Position labels (sorted).
    position : ndarray of int, shape (n,)
        Position of each row (into ``labels``).
    f_ios_g : ndarray, shape (G, 3)
        Specific force on I, O, S at each position [g0].
    drift_rad_s : ndarray, shape (n,)
        Indicated rate minus the true input rate of each row [rad/s].
    messages : list of str
        Warnings about the plan's angles (spacing, count).
    """

    mounting: NDArray
    angle_deg: NDArray[np.float64]
    starts: NDArray[np.intp]
    present: list[str]
    labels: NDArray
    position: NDArray[np.intp]
    f_ios_g: NDArray[np.float64]
    drift_rad_s: NDArray[np.float64]
    messages: list[str]


class PolarTumble(Procedure[PolarTumbleSpec, TumbleObservations, PolarTumbleResult]):
    """Floated gyro, polar-axis tumble (seed 000, sec. 2): static drift model by Fourier terms.

    Data columns ``mounting`` (str), ``angle_deg`` [deg] and ``output`` [instrument output unit];
    one row per sample or per position average, in time order. Rows with the same mounting and
    angle are one position (the unit of independence of the noise model).

    Angle convention: ``angle_deg`` is the table angle theta of the seed's figures, the same
    encoder reading for every mounting: at theta = 0 the gyro's I axis is horizontal and the
    other in-plane axis (S for the O mountings, O for the S mountings) at its highest; theta
    grows as I rises, so ``fI = gamma cos L sin(theta)`` and, in the O mountings,
    ``fS = gamma cos L cos(theta)`` (:mod:`inertest.equipment.polar_axis_table`). Flipping the
    table over its trunnion for the Sp mountings must not re-zero the encoder differently: an
    Sp angle read 180 deg off reverses S1 and C1 of that mounting. With all four mountings the
    O and S pairs then disagree and the model checks warn; with only one pair (O-Np + O-Sp)
    the design is exactly determined in S1 and C1 and the error cannot be seen (DI, DS, DIO,
    DOS come out wrong). Check the convention on the first position of each mounting.
    """

    kind = KIND
    title = "Floated gyro, polar-axis tumble"
    spec = PolarTumbleSpec
    model = "inertest.models.sdf_gyro"
    method = "weighted least squares under a noise model; Fourier terms per mounting and the " \
        "seed's closed-form separation beside it"
    machines = (table,)
    noise_models = NOISE_MODELS
    report = "inertest.report.tumble:polar_tumble_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> Fixture:
        """The polar-axis table at the plan's site (with its Type-B errors)."""
        _check_latitude(plan.site.latitude_rad)
        return Fixture(table.motion, plan.site, dict(type_b or {}))

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Fixture
               ) -> TumbleObservations:
        """Positions from the runs of equal (mounting, angle) rows, and their inputs."""
        cols = require_columns(data, ("angle_deg", "output"), ("mounting",), procedure=KIND)
        mounting, angle_deg = cols["mounting"], cols["angle_deg"]
        starts = run_starts(mounting, angle_deg)  # runs of equal (mounting, angle) rows
        unknown = sorted(set(np.unique(mounting[starts]).tolist()) - set(table.MOUNTINGS))
        if unknown:
            raise DataError(
                f"mounting(s) {', '.join(unknown)} in the data are not polar-tumble mountings; "
                f"use {', '.join(table.MOUNTINGS)}"
            )
        # Positions from the runs of equal (mounting, angle) rows: a label and the inputs per
        # position, an integer position per row (no per-row strings, inputs or design).
        run_mounting, run_angle = mounting[starts], angle_deg[starts]
        present = [m for m in table.MOUNTINGS if np.any(run_mounting == m)]
        labels, run_code = np.unique(table.position_labels(run_mounting, run_angle),
                                     return_inverse=True)
        position = np.repeat(run_code, np.diff(np.append(starts, mounting.shape[0])))
        f, w_in = position_inputs(motion.positions(present, np.unique(run_angle)), labels)
        drift = plan.instrument.output_to_rate(cols["output"])
        if np.any(w_in):
            drift -= w_in[position]
        messages = _spacing_messages(run_mounting, run_angle, present)
        for msg in messages:
            warnings.warn(msg, InertestWarning, stacklevel=3)
        return TumbleObservations(mounting, angle_deg, starts, present, labels, position, f,
                                  drift, messages)

    def identify(self, plan: Plan, obs: TumbleObservations, *, sigma: float | None,
                 noise_model: str | None) -> PolarTumbleResult:
        """The drift coefficients by least squares, and the Fourier terms of each mounting."""
        site, inst = plan.site, plan.instrument
        spec: PolarTumbleSpec = plan.procedure
        sigma_rad_s = known_sigma(sigma, inst.rad_s_per_output_unit)
        drift, mounting, angle_deg, starts = obs.drift_rad_s, obs.mounting, obs.angle_deg, \
            obs.starts
        messages = list(obs.messages)
        lsq, noise, ident = identify_drift(
            obs.f_ios_g, drift, gravity_g=site.gravity_g, sigma_rad_s=sigma_rad_s,
            groups=obs.labels, noise_model=str(noise_model), position_index=obs.position,
            bias_time_scale=spec.bias_time_scale,
        )
        k = DEG_PER_H_TO_RAD_PER_S
        # Per-row results in place (each a new array of n rows otherwise): the same numbers.
        fitted_deg_h = np.subtract(drift, lsq.residuals)
        fitted_deg_h /= k
        drift /= k
        harmonics = {}
        run_mounting = mounting[starts]
        run_stop = np.append(starts[1:], mounting.shape[0])
        for m in obs.present:
            runs = np.flatnonzero(run_mounting == m)
            rows: slice | NDArray[np.bool_] = slice(starts[runs[0]], run_stop[runs[-1]])
            if runs[-1] - runs[0] + 1 != runs.size:  # the mounting's rows are not one block
                rows = mounting == m
            try:
                harmonics[m] = _harmonics(m, angle_deg[rows], drift[rows], rows, noise)
            except IdentifiabilityError as exc:
                # The general least squares above still says what the data determine.
                messages.append(f"no Fourier terms for {exc}")
                warnings.warn(messages[-1], InertestWarning, stacklevel=3)
        closed = _closed_forms(harmonics, site.latitude_rad, site.gravity_g)
        del noise
        return PolarTumbleResult(
            site_latitude_deg=site.latitude_deg,
            site_gravity_m_s2=site.gravity_m_s2,
            identification=ident,
            harmonics=harmonics,
            closed_form=closed,
            mounting=mounting,
            angle_deg=angle_deg,
            drift_deg_h=drift,
            fitted_deg_h=fitted_deg_h,
            residual_output=inst.rate_to_output(lsq.residuals),
            output_unit=inst.output_unit,
            messages=tuple(messages),
        )

    def synthesize(self, plan: Plan, motion: Fixture, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """Columns ``mounting``, ``angle_deg``, ``output`` [output unit] of the plan's positions.

        ``truth``: drift coefficients by name [deg/h, deg/h/g, deg/h/g^2]; missing names are 0.
        """
        spec: PolarTumbleSpec = plan.procedure
        reps = spec.samples_per_position
        ang = np.repeat(np.asarray(spec.angles_deg, dtype=float), reps)
        mounting = np.concatenate([np.full(ang.size, m) for m in spec.mountings])
        angle_deg = np.tile(ang, len(spec.mountings))
        positions = motion.positions(spec.mountings, spec.angles_deg)
        f, w_in = row_inputs(positions, table.position_labels(mounting, angle_deg))
        rate = w_in + model_drift(f, coefficients_from_deg_h(truth))
        output = plan.instrument.rate_to_output(rate) + noise_samples(rate.size, noise, rng)
        return {"mounting": mounting, "angle_deg": angle_deg, "output": output}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = PolarTumble()


def _check_latitude(latitude_rad: float) -> None:
    if np.cos(latitude_rad) < _MIN_COS_LAT:
        raise PlanError(
            f"a polar-axis tumble at latitude {np.degrees(latitude_rad):.2f} deg gives the I axis "
            "almost no gravity (cos L < 0.05); use a local-level tumble near the poles"
        )


def _spacing_messages(
    mounting: NDArray, angle_deg: NDArray[np.float64], present: Sequence[str]
) -> list[str]:
    """The seed asks for angles equally spaced over 360 deg from 0, a multiple of 4 of them."""
    out = []
    for m in present:
        a = np.unique(np.round(np.mod(angle_deg[mounting == m], 360.0), 9))
        n = a.size
        regular = np.allclose(a, np.arange(n) * 360.0 / n, atol=1e-6)
        if not regular or n % 4:
            out.append(
                f"{m}: {n} distinct table angle(s) "
                + ("not equally spaced from 0 over 360 deg" if not regular else "")
                + (" and " if (not regular and n % 4) else "")
                + (f"count {n} not a multiple of 4" if n % 4 else "")
                + "; the Fourier terms are then correlated (general least squares still applies)"
            )
    return out


def _harmonics(
    mounting: str, angle_deg: NDArray[np.float64], drift_deg_h: NDArray[np.float64],
    rows: slice | NDArray[np.bool_], noise: NoiseFit,
) -> MountingHarmonics:
    """B0..C2 by GLS over the position means of one mounting, under the fitted noise model.

    ``rows``: the mounting's rows (a slice when they are one block: views, not copies).
    """
    k = DEG_PER_H_TO_RAD_PER_S
    unit = noise.unit_index[rows]
    size = int(unit.max()) + 1
    all_counts = np.bincount(unit, minlength=size)
    units = np.flatnonzero(all_counts)  # np.unique(unit), without sorting the rows
    counts = all_counts[units]
    ybar = np.bincount(unit, drift_deg_h, minlength=size)[units] / counts
    angle = np.bincount(unit, np.mod(angle_deg, 360.0), minlength=size)[units] / counts
    n_angles = np.unique(np.round(np.mod(angle, 360.0), 9)).size
    if n_angles < 5:
        raise IdentifiabilityError(
            f"mounting {mounting}: {n_angles} distinct angle(s) cannot separate the 5 Fourier "
            "terms B0, S1, C1, S2, C2; use at least 5 (the seed uses a multiple of 4)")
    V = noise.unit_covariance
    V = np.diag(V[units]) if V.ndim == 1 else V[np.ix_(units, units)]
    L = np.linalg.cholesky(V / k**2)
    H = harmonic_design(angle * DEG_TO_RAD, 2)
    lsq = weighted_least_squares(np.linalg.solve(L, H), np.linalg.solve(L, ybar), sigma=1.0)
    hf = HarmonicFit(harmonic_names(2), lsq.x, lsq.covariance, lsq)
    terms = tuple(
        Estimate(n, float(v), float(s), "deg/h")
        for n, v, s in zip(hf.names, hf.values, hf.std, strict=True)
    )
    return MountingHarmonics(mounting, terms, angle_deg, drift_deg_h, hf)


#: Closed-form separation for a pair of mountings (seed sec. 2(4), gamma restored).
#: Each entry: (coefficient terms with weights as functions of sL, cL, gamma;
#:              weights on [B0, S1, C1, S2, C2] of Np and of Sp as functions of sL, cL, gamma).
def _pair_formulas(first: str, sL: float, cL: float, gm: float):
    """Rows ``(terms, wN, wS)`` so that ``sum terms * D = wN . X_Np + wS . X_Sp``."""
    a, b = ("DO", "DS") if first == "O" else ("DS", "DO")
    ab, ba = ("DOO", "DSS") if first == "O" else ("DSS", "DOO")
    x1 = "DIO" if first == "O" else "DSI"      # coupled with DI in S1
    x2 = "DOS"                                  # coupled with the in-plane axis in C1
    x3 = "DSI" if first == "O" else "DIO"      # alone in S2
    z = np.zeros(5)

    def e(i: int, v: float) -> NDArray[np.float64]:
        w = z.copy()
        w[i] = v
        return w

    rows = []
    if abs(sL) > 1e-6:
        rows += [
            ({a: 1.0}, e(0, 1 / (2 * gm * sL)), e(0, -1 / (2 * gm * sL))),
            ({x1: 1.0}, e(1, 1 / (2 * gm**2 * sL * cL)), e(1, -1 / (2 * gm**2 * sL * cL))),
            ({x2: 1.0}, e(2, 1 / (2 * gm**2 * sL * cL)), e(2, -1 / (2 * gm**2 * sL * cL))),
        ]
    rows += [
        ({"DI": 1.0}, e(1, 1 / (2 * gm * cL)), e(1, 1 / (2 * gm * cL))),
        ({b: 1.0}, e(2, 1 / (2 * gm * cL)), e(2, 1 / (2 * gm * cL))),
        ({x3: 1.0}, e(3, 1 / (gm**2 * cL**2)), e(3, 1 / (gm**2 * cL**2))),
        ({ba: 1.0, "DII": -1.0}, e(4, 1 / (gm**2 * cL**2)), e(4, 1 / (gm**2 * cL**2))),
        (
            {"DF": 1.0, ab: gm**2 * sL**2, "DII": gm**2 * cL**2 / 2, ba: gm**2 * cL**2 / 2},
            e(0, 0.5), e(0, 0.5),
        ),
    ]
    return rows


def _closed_forms(
    harmonics: Mapping[str, MountingHarmonics], latitude_rad: float, gamma: float
) -> dict[str, tuple[Combination, ...]]:
    sL, cL = float(np.sin(latitude_rad)), float(np.cos(latitude_rad))
    out: dict[str, tuple[Combination, ...]] = {}
    for first in ("O", "S"):
        n, s = f"{first}-Np", f"{first}-Sp"
        if n not in harmonics or s not in harmonics:
            continue
        xn, xs = harmonics[n].fit.values, harmonics[s].fit.values
        cn, cs = harmonics[n].fit.covariance, harmonics[s].fit.covariance
        combos = []
        for terms, wn, ws in _pair_formulas(first, sL, cL, gamma):
            value = float(wn @ xn + ws @ xs)
            std = float(np.sqrt(wn @ cn @ wn + ws @ cs @ ws))
            lead = next(iter(terms))
            combos.append(
                Combination(
                    name=combination_name(list(terms.items())),
                    terms=dict(terms),
                    value=value,
                    std=std,
                    unit=ENGINEERING_UNIT[lead],
                )
            )
        out[first] = tuple(combos)
    return out
