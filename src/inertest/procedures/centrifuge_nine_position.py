"""Nine-position identification of an SDF gyro's drift model on a dual-axis centrifuge.

Sun, Ren & Wang (seed ``004_f16e7c07e7c35fdc.txt``), sec. 4: the gyro
sits on the counter-rotating platform of a dual-axis centrifuge in nine attitudes (three
mountings x fixture angles 0, +45, -45 deg, see :mod:`inertest.equipment.centrifuge`) and the main
axis turns at two or more rates. Each run (one position at one rate) is reduced by *whole-cycle
integration* (eqs. 18-22): the gyro output is averaged over whole revolutions of the arm, and the
ten regressors of the static drift model (:mod:`inertest.models.sdf_gyro`) are averaged over
exactly the same samples with the same weights
(:func:`inertest.estimation.reduction.whole_cycle_weights`: equal weights, corrected so that the
arm's first and second harmonics average to exactly zero when a revolution does not hold an
integer number of samples). The averaged input rate on I is subtracted and the ten coefficients
are found by least squares with their analytic covariance.

Inputs: the regressors are built from the exact inputs of the error-free machine, the motion
:class:`inertest.equipment.centrifuge.CentrifugeRuns` (:func:`machine_motion`: one segment per
run, kinematics of :func:`~inertest.equipment.centrifuge.centrifuge_motion`), Earth rotation
included: the specific force contains the Earth-rate Coriolis term ``2 W x v`` (up to ``2 W w R``,
2.3e-4 g at 8.85 rad/s and R = 2.5 m) and ``W x (W x p)``, and the rate on I is the Earth rate.
Leaving them out (the closed form :func:`~inertest.equipment.centrifuge.ideal_inputs`) biases DII
by about one standard uncertainty at the source's settings, and the bias does not shrink with
more data.

Sense of rotation: ``omega`` is the *signed* main-axis rate, right-handed about up, i.e. positive
when the arm turns counter-clockwise seen from above and negative when it turns clockwise. The
Coriolis term adds ``2 W sin(latitude) |w| R`` to the centripetal force in one sense and takes it
away in the other, so the data must say which way the arm turned; runs at ``+w`` and ``-w`` are
distinct runs.

Why the centrifuge separates what a 1 g tumble cannot: over a revolution the specific force in the
platform frame has mean ``(0, 0, g)`` and second moment ``diag(A^2/2, A^2/2, g^2)`` with
``A = R w^2``, so the sum of the averaged squares is ``A^2 + g^2``, which changes with the rate.
At a single rate that sum is again a constant and DF is not separable from DII, DOO, DSS.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.earth import OMEGA_IE
from inertest.equipment import centrifuge as machine
from inertest.errors import DataError, InertestWarning, InputError, PlanError
from inertest.estimation.identify import identify
from inertest.estimation.least_squares import LinearFit, weighted_least_squares
from inertest.estimation.noise_models import NOISE_MODELS, check_noise_model
from inertest.estimation.reduction import (
    RowGroups,
    group_rows,
    whole_cycle_correction,
    whole_cycle_mask,
)
from inertest.estimation.units import PositionDesign
from inertest.models.sdf_gyro import (
    COEFFICIENTS,
    ENGINEERING_UNIT,
    coefficients_from_deg_h,
    drift,
    regressors_from_moments,
)
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import known_sigma, noise_samples, require_columns
from inertest.results import Identification, LinearTestResult
from inertest.units import DEG_PER_H_TO_RAD_PER_S, G0

KIND = "centrifuge-nine-position"

_TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class RunMeans:
    """Whole-revolution means of each run (one position at one main-axis rate).

    Attributes
    ----------
    position : ndarray of int, shape (m,)
        Position 1..9 of each run.
    omega : ndarray, shape (m,)
        Signed main-axis rate [rad/s] (positive counter-clockwise seen from above).
    revolutions : ndarray of int, shape (m,)
        Whole revolutions kept.
    n_samples : ndarray of int, shape (m,)
        Samples kept (those with ``omega (t - t0) / 2 pi < revolutions``).
    n_dropped : ndarray of int, shape (m,)
        Samples of the run beyond the last whole revolution (not used).
    noise_factor : ndarray, shape (m,)
        ``sqrt(sum(weights^2))``: a run mean's noise is ``sigma_sample * noise_factor``
        (``1/sqrt(n)`` for equal weights).
    output_rate_rad_s : ndarray, shape (m,)
        Mean gyro output [rad/s].
    input_rate_rad_s : ndarray, shape (m,)
        Mean input rate on I [rad/s].
    regressors : ndarray, shape (m, 10)
        Mean of the per-sample regressors of :func:`inertest.models.sdf_gyro.drift_regressors`
        (specific force in g0), columns in the order of ``COEFFICIENTS``.
    f_mean_g : ndarray, shape (m, 3)
        Mean specific force on I, O, S [g0] (for reports).
    structural_regressors : ndarray, shape (m, 10)
        The regressors' exact continuous whole-revolution means of the force's fitted constant
        and first harmonic of the arm (``f = c + a cos + b sin`` per axis:
        ``mean f_i f_j = c_i c_j + (a_i a_j + b_i b_j) / 2``). Used only to decide which
        coefficients the test can determine, so that the O(1/samples) leakage of a sampled
        average (non-integer samples per revolution) does not pass for information.
    first_row : ndarray of int, shape (m,)
        First data row of each run: the runs in time order for the noise models that wander
        over the test (random walk, flicker).
    within_residuals_rad_s : ndarray, shape (sum(n_samples),)
        Each run's kept samples of the drift (output minus input rate on I) [rad/s] minus the
        run model: a constant plus the arm's first and second harmonics, fitted by least squares
        to the run's samples. The drift model is quadratic in a force that is a constant plus a
        first harmonic of the arm, so this run model holds the whole signal and the residuals
        are the noise within the run. Runs one after the other in the order of ``position``.
    within_dof : ndarray of int, shape (m,)
        Degrees of freedom of each run's residuals (samples kept minus 5).
    """

    position: NDArray[np.int64]
    omega: NDArray[np.float64]
    revolutions: NDArray[np.int64]
    n_samples: NDArray[np.int64]
    n_dropped: NDArray[np.int64]
    noise_factor: NDArray[np.float64]
    output_rate_rad_s: NDArray[np.float64]
    input_rate_rad_s: NDArray[np.float64]
    regressors: NDArray[np.float64]
    f_mean_g: NDArray[np.float64]
    structural_regressors: NDArray[np.float64]
    first_row: NDArray[np.int64]
    within_residuals_rad_s: NDArray[np.float64]
    within_dof: NDArray[np.int64]

    @property
    def drift_rad_s(self) -> NDArray[np.float64]:
        """Observed mean drift: mean output minus mean input rate on I [rad/s]."""
        return self.output_rate_rad_s - self.input_rate_rad_s


@dataclass(frozen=True)
class CentrifugeNinePositionSpec:
    """Parameters of a nine-position centrifuge plan (``[procedure]`` table).

    Attributes
    ----------
    radius_m : float
        Arm radius R from the main axis to the instrument [m] (required).
    platform_heading_deg : float
        Azimuth of ``x_P`` (the arm at ``t = 0``), clockwise from north [deg]; sets how the
        Earth rate projects on the gyro axes.
    omegas_rad_s : tuple of float
        Signed main-axis rates [rad/s] run at every position (for simulation; the fit takes the
        rates from the data): positive counter-clockwise, negative clockwise seen from above.
        Default 4.43 and 8.85 rad/s (5 g and 20 g at R = 2.5 m, Sun, Ren & Wang).
    revolutions : int
        Whole revolutions recorded per run (for simulation).
    sample_rate_hz : float
        Output sampling rate (for simulation) [Hz].
    positions : tuple of int
        Positions 1..9 run (for simulation).
    noise_model : str
        Noise of the gyro behind the uncertainties, with the run as the unit of independence
        (:func:`inertest.estimation.identify.solve`): ``auto`` (default: chosen by AIC),
        ``white``, ``position-offsets`` (an offset per run: the drift moves between runs, the
        machine re-settles), ``random-walk`` or ``flicker`` (a drift wandering over the test).
    """

    kind: ClassVar[str] = KIND
    radius_m: float = 2.5
    platform_heading_deg: float = 0.0
    omegas_rad_s: tuple[float, ...] = (4.43, 8.85)
    revolutions: int = 100
    sample_rate_hz: float = 50.0
    positions: tuple[int, ...] = machine.POSITIONS
    noise_model: str = "auto"

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> CentrifugeNinePositionSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}", ignore=("kind",))
        omegas = v["omegas_rad_s"]
        if any(w == 0.0 for w in omegas):
            raise PlanError(
                "omegas_rad_s must hold finite nonzero signed rates [rad/s] (positive "
                f"counter-clockwise, negative clockwise seen from above), got {list(omegas)}")
        if len(set(omegas)) != len(omegas):
            raise PlanError(f"omegas_rad_s lists a rate twice: {list(omegas)}; give each once")
        raw_p = v["positions"]
        if any(p != int(p) or not 1 <= p <= 9 for p in raw_p):
            raise PlanError(f"positions must be a non-empty list of numbers 1..9, got "
                            f"{list(raw_p)}")
        positions = tuple(int(p) for p in raw_p)
        if len(set(positions)) != len(positions):
            raise PlanError(f"positions lists a position twice: {list(positions)}; give each once")
        return cls(**{**v, "positions": positions})


#: Parameters of the ``[procedure]`` table of a nine-position centrifuge plan.
FIELDS = (
    Field("radius_m", positive=True, unit="m", doc="the arm radius to the instrument [m]"),
    Field("platform_heading_deg", default=0.0, unit="deg",
          doc="azimuth of x_P, clockwise from north"),
    Field("omegas_rad_s", "numbers", default=CentrifugeNinePositionSpec.omegas_rad_s,
          unit="rad/s", doc="signed main-axis rates, positive counter-clockwise from above"),
    Field("revolutions", "integer", default=CentrifugeNinePositionSpec.revolutions,
          positive=True, doc="whole revolutions per run (simulation)"),
    Field("sample_rate_hz", default=CentrifugeNinePositionSpec.sample_rate_hz, positive=True,
          unit="Hz", doc="output sampling rate (simulation)"),
    Field("positions", "numbers", default=machine.POSITIONS, doc="positions 1..9 run"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS,
          doc="noise model behind the uncertainties (the run is the unit of independence)"),
)



@dataclass(frozen=True, kw_only=True)
class CentrifugeNinePositionResult(LinearTestResult):
    """Outcome of :func:`fit`: the ten drift coefficients from whole-revolution run means.

    Per-run arrays (one entry per run = position at one rate) are in run order (position, then
    rate).

    Attributes
    ----------
    identification : Identification
        Coefficients [deg/h, deg/h/g, deg/h/g^2], combinations and statements.
    radius_m, platform_heading_deg : float
        Machine geometry used for the ideal inputs.
    run_position, run_omega, run_revolutions, run_samples : ndarray
        Position, main-axis rate [rad/s], whole revolutions and samples kept per run.
    drift_deg_h, fitted_deg_h, earth_rate_deg_h : ndarray
        Mean observed drift (output minus input rate on I), model value and mean input rate on I
        per run [deg/h].
    residual_output : ndarray
        Run-mean residual [output unit].
    """

    radius_m: float
    platform_heading_deg: float
    run_position: NDArray[np.int64] = field(repr=False)
    run_omega: NDArray[np.float64] = field(repr=False)
    run_revolutions: NDArray[np.int64] = field(repr=False)
    run_samples: NDArray[np.int64] = field(repr=False)
    drift_deg_h: NDArray[np.float64] = field(repr=False)
    fitted_deg_h: NDArray[np.float64] = field(repr=False)
    earth_rate_deg_h: NDArray[np.float64] = field(repr=False)
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d: dict[str, object] = {}
        d["machine"] = {"radius_m": self.radius_m,
                        "platform_heading_deg": self.platform_heading_deg}
        d["runs"] = [
            {"position": int(p), "omega_rad_s": float(w), "revolutions": int(r),
             "samples": int(n), "drift_deg_h": float(dr), "fitted_deg_h": float(fi),
             "residual": float(res)}
            for p, w, r, n, dr, fi, res in zip(
                self.run_position, self.run_omega, self.run_revolutions, self.run_samples,
                self.drift_deg_h, self.fitted_deg_h, self.residual_output, strict=True)
        ]
        return d


@dataclass(frozen=True)
class CentrifugeObservations:
    """Centrifuge samples reduced to whole-revolution run means, with their coverage notes."""

    runs: RunMeans
    messages: list[str]


class CentrifugeNinePosition(Procedure[CentrifugeNinePositionSpec, CentrifugeObservations,
                                       CentrifugeNinePositionResult]):
    """Floated gyro on a dual-axis centrifuge, nine-position method (seed 004).

    Data columns ``position`` (1..9), ``omega`` (nominal signed main-axis rate of the run, rad/s,
    positive counter-clockwise and negative clockwise seen from above: the same value on every
    sample of a run, since runs are told apart by it), ``t`` (time since the arm passed
    ``x_P``, s; each run may have its own clock) and ``output`` [instrument output unit], one
    row per sample. A known ``sigma`` is the white noise per sample [output unit]; estimated
    otherwise (see ``noise_model`` of :func:`fit_inputs`). The result names the noise model
    used (``identification.noise_model``), its components and its checks.

    The inputs are the exact ones of the error-free machine with Earth rotation (the plan's
    radius, heading and site, no machine error); machine errors are the business of the
    centrifuge study.
    """

    kind = KIND
    title = "Floated gyro, dual-axis centrifuge"
    spec = CentrifugeNinePositionSpec
    model = "inertest.models.sdf_gyro"
    method = "whole-revolution run means, weighted least squares under a noise model"
    machines = (machine,)
    noise_models = NOISE_MODELS
    report = "inertest.report.centrifuge:nine_position_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> machine.Centrifuge:
        """The plan's centrifuge (radius, platform heading, site), with its Type-B errors."""
        spec: CentrifugeNinePositionSpec = plan.procedure
        return machine.Centrifuge(spec.radius_m, plan.site,
                                  float(np.radians(spec.platform_heading_deg)),
                                  dict(type_b or {}))

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: machine.Centrifuge
               ) -> CentrifugeObservations:
        """Whole-revolution means of every run (position, rate) with the machine's inputs."""
        cols = require_columns(data, ("position", "omega", "t", "output"), (), procedure=KIND)
        pos, omega, t = _positions(cols["position"]), cols["omega"], cols["t"]
        _check_rates(omega)
        groups = group_rows(pos, omega)
        runs_motion = _runs_motion(motion, groups)
        labels = runs_motion.segments

        def inputs(r: int, rows: slice | NDArray[np.intp]) -> tuple[NDArray, NDArray]:
            w_ios, f = runs_motion.rate_and_force(labels[r], t[rows])
            return f, w_ios[:, 0]

        k = plan.instrument.rad_s_per_output_unit
        y = cols["output"] if k == 1.0 else plan.instrument.output_to_rate(cols["output"])
        runs = _reduce_runs(groups, t, y, inputs)  # y is only read
        return CentrifugeObservations(runs, _coverage_messages(runs))

    def identify(self, plan: Plan, obs: CentrifugeObservations, *, sigma: float | None,
                 noise_model: str | None) -> CentrifugeNinePositionResult:
        """The ten drift coefficients from the run means (:func:`fit_inputs`'s rule)."""
        spec: CentrifugeNinePositionSpec = plan.procedure
        site, inst, runs = plan.site, plan.instrument, obs.runs
        messages = list(obs.messages)
        lsq, ident = _identify_runs(runs, known_sigma(sigma, inst.rad_s_per_output_unit),
                                    str(noise_model))
        lost = [n for n in COEFFICIENTS if n not in ident.coefficients]
        missing = sorted(set(machine.POSITIONS) - {int(p) for p in runs.position})
        if missing:
            messages.append(
                f"positions {', '.join(map(str, missing))} not measured; "
                + (f"{', '.join(lost)} are then not individually identifiable (see 'not "
                   "determined')" if lost
                   else "all ten coefficients are still identifiable from the runs given")
            )
        for msg in messages:
            warnings.warn(msg, InertestWarning, stacklevel=3)
        k = DEG_PER_H_TO_RAD_PER_S
        return CentrifugeNinePositionResult(
            site_latitude_deg=site.latitude_deg,
            site_gravity_m_s2=site.gravity_m_s2,
            identification=ident,
            radius_m=spec.radius_m,
            platform_heading_deg=spec.platform_heading_deg,
            run_position=runs.position,
            run_omega=runs.omega,
            run_revolutions=runs.revolutions,
            run_samples=runs.n_samples,
            drift_deg_h=runs.drift_rad_s / k,
            fitted_deg_h=(runs.drift_rad_s - lsq.residuals) / k,
            earth_rate_deg_h=runs.input_rate_rad_s / k,
            residual_output=inst.rate_to_output(lsq.residuals),
            output_unit=inst.output_unit,
            messages=tuple(messages),
        )

    def synthesize(self, plan: Plan, motion: machine.Centrifuge, truth: Mapping[str, float],
                   *, noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """Samples of a virtual gyro on the centrifuge: every position at every rate.

        Each run starts with the arm on ``x_P`` at ``t = 0`` and is sampled at
        ``sample_rate_hz`` from ``t = 0`` up to and including the first sample at or after the
        end of the last revolution (:func:`~inertest.equipment.centrifuge.run_times`), so that
        the run spans ``revolutions`` whole revolutions by the rule of
        :func:`~inertest.estimation.reduction.whole_cycle_mask`. Inputs from the machine's
        exact kinematics run by run (those of :func:`machine_inputs`, Earth rotation included);
        output rate = input rate on I (Earth rate) + drift. ``truth`` maps coefficient names
        to deg/h, deg/h/g, deg/h/g^2; missing names are 0.

        Returns columns ``position``, ``omega`` [rad/s], ``t`` [s], ``output`` [output unit].
        """
        spec: CentrifugeNinePositionSpec = plan.procedure
        coef = coefficients_from_deg_h(truth)
        runs = [(p, w) for p in spec.positions for w in spec.omegas_rad_s]
        times = [machine.run_times(w, spec.sample_rate_hz, spec.revolutions) for _, w in runs]
        sizes = [t.size for t in times]
        pos = np.repeat(np.array([p for p, _ in runs], dtype=np.int64), sizes)
        omega = np.repeat(np.array([w for _, w in runs], dtype=float), sizes)
        t = np.concatenate(times)
        # Run by run (the machine's rate and force, no attitude), into the one output column:
        # no temporaries of the whole test.
        rate = np.empty(t.size)
        runs_motion = motion.runs(tuple(runs))
        i = 0
        for label, tr in zip(runs_motion.segments, times, strict=True):
            w_ios, f = runs_motion.rate_and_force(label, tr)
            f /= G0
            rate[i:i + tr.size] = w_ios[:, 0] + drift(f, coef)
            i += tr.size
        output = plan.instrument.rate_to_output(rate)
        output += noise_samples(rate.size, noise, rng)
        return {"position": pos, "omega": omega, "t": t, "output": output}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = CentrifugeNinePosition()


def machine_inputs(
    centrifuge: machine.Centrifuge, position: ArrayLike, omega: ArrayLike, t: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact inputs of the machine for every sample, Earth rotation included.

    The inputs of :func:`machine_motion` (one evaluation of
    :func:`inertest.equipment.centrifuge.centrifuge_motion` per run: distinct position and
    signed rate).

    Parameters
    ----------
    centrifuge : Centrifuge
        The machine (radius, platform heading, site; :meth:`CentrifugeNinePosition.motion`).
    position, omega, t : array_like, shape (n,)
        Position 1..9, signed main-axis rate [rad/s] (positive counter-clockwise seen from
        above) and time since the arm passed ``x_P`` [s] of every sample.

    Returns
    -------
    f_ios, omega_ios : ndarray, shape (n, 3)
        Specific force [m/s^2] (with the Earth-rate terms ``2 W x v + W x (W x p)``) and
        inertial angular rate [rad/s] on I, O, S.
    """
    pos, tt = np.asarray(position), np.asarray(t, dtype=float)
    groups = group_rows(pos, np.asarray(omega, dtype=float))
    runs = _runs_motion(centrifuge, groups)
    f, w_ios = np.empty((tt.size, 3)), np.empty((tt.size, 3))
    for r, label in enumerate(runs.segments):  # one evaluation per run, no attitude
        rows = groups.span(r)
        w_ios[rows], f[rows] = runs.rate_and_force(label, tt[rows])
    return f, w_ios


def machine_motion(
    centrifuge: machine.Centrifuge, position: ArrayLike, omega: ArrayLike
) -> machine.CentrifugeRuns:
    """The machine running every distinct (position, rate) of the samples, as a motion.

    Parameters
    ----------
    centrifuge : Centrifuge
        The machine (:meth:`CentrifugeNinePosition.motion`).
    position, omega : array_like, shape (n,)
        Position 1..9 and signed main-axis rate [rad/s] of every sample (or of every run).

    Returns
    -------
    CentrifugeRuns
        One segment per distinct (position, rate), labelled as by
        :func:`inertest.equipment.centrifuge.run_labels`.
    """
    return _runs_motion(centrifuge,
                        group_rows(np.asarray(position), np.asarray(omega, dtype=float)))


def _runs_motion(centrifuge: machine.Centrifuge, groups: RowGroups) -> machine.CentrifugeRuns:
    """The machine running the runs of ``groups`` (keys position, rate), segments in their order."""
    return centrifuge.runs(tuple((int(p), float(w)) for p, w in zip(*groups.keys, strict=True)))


def _coverage_messages(runs: RunMeans) -> list[str]:
    """Warnings about the test's coverage (rates), before the fit says what is lost."""
    out = []
    if np.unique(np.abs(runs.omega)).size == 1:
        out.append(
            f"only one main-axis rate ({abs(runs.omega[0]):g} rad/s) in the data; DF and the "
            "square terms DII, DOO, DSS then mix as in a 1 g tumble (run at least two rates)"
        )
    return out


def run_means(
    position: ArrayLike,
    omega: ArrayLike,
    t: ArrayLike,
    output_rate_rad_s: ArrayLike,
    f_ios_m_s2: ArrayLike,
    omega_ios_rad_s: ArrayLike,
) -> RunMeans:
    """Group samples into runs (position, rate) and take whole-revolution means.

    The output, the input rate on I and the ten regressors (built from each sample's specific
    force, *not* from the averaged force) are averaged over the same samples, so the averaged
    model ``mean(output) - mean(w_I) = mean(Phi) @ D`` holds exactly whatever the sampling.

    Parameters
    ----------
    position : array_like of int, shape (n,)
        Position 1..9 of each sample.
    omega : array_like, shape (n,)
        Signed main-axis rate [rad/s] (positive counter-clockwise, negative clockwise seen from
        above); samples with the same (position, omega) form one run.
    t : array_like, shape (n,)
        Time [s] (each run's revolutions are counted from its own first sample).
    output_rate_rad_s : array_like, shape (n,)
        Gyro output converted to rate [rad/s].
    f_ios_m_s2 : array_like, shape (n, 3)
        Specific force on I, O, S [m/s^2] from any kinematic model.
    omega_ios_rad_s : array_like, shape (n, 3)
        Inertial angular rate on I, O, S [rad/s]; only the I component enters the reduction.

    Raises
    ------
    DataError
        Mismatched shapes, non-finite values, unknown positions, a zero rate, or a run
        shorter than one whole revolution.
    """
    pos = np.asarray(position)
    w = np.asarray(omega, dtype=float)
    tt = np.asarray(t, dtype=float)
    y = np.asarray(output_rate_rad_s, dtype=float)
    f = np.asarray(f_ios_m_s2, dtype=float)
    wi = np.asarray(omega_ios_rad_s, dtype=float)
    n = tt.shape[0] if tt.ndim == 1 else -1
    if n < 1 or any(a.shape != (n,) for a in (pos, w, y)) or (n, 3) != f.shape or (
            (n, 3) != wi.shape):
        raise DataError(
            "position, omega, t and output need shape (n,) and the specific force and angular "
            f"rate shape (n, 3); got {pos.shape}, {w.shape}, {tt.shape}, {y.shape}, {f.shape}, "
            f"{wi.shape}"
        )
    for name, a in (("omega", w), ("t", tt), ("output", y), ("specific force", f),
                    ("angular rate", wi)):
        if np.isfinite(np.min(a)) and np.isfinite(np.max(a)):  # no temporary for good data
            continue
        bad = np.flatnonzero(~np.all(np.isfinite(a.reshape(n, -1)), axis=1))
        raise DataError(
            f'column "{name}" has {bad.size} NaN/inf value(s) (first at data row '
            f"{bad[0] + 1}); remove or repair those rows"
        )
    pos_i = _positions(pos)
    _check_rates(w)
    return _reduce_runs(group_rows(pos_i, w), tt, y,
                        lambda r, rows: (f[rows], wi[rows, 0]))


def _check_rates(omega: NDArray[np.float64]) -> None:
    """A zero main-axis rate is refused, naming its first row."""
    if np.all(omega != 0.0):
        return
    row = int(np.flatnonzero(omega == 0.0)[0])
    raise DataError(
        f"main-axis rate omega must be nonzero [rad/s], got 0 at data row {row + 1}; give "
        "the arm's signed rate (positive counter-clockwise, negative clockwise seen from above)"
    )


#: The specific force [m/s^2] and input rate on I [rad/s] of the given rows of run ``r``.
RunInputs = Callable[[int, "slice | NDArray[np.intp]"], tuple[NDArray[np.float64],
                                                              NDArray[np.float64]]]


def _reduce_runs(groups: RowGroups, t: NDArray[np.float64], y: NDArray[np.float64],
                 inputs: RunInputs) -> RunMeans:
    """:func:`run_means` of checked columns, the inputs of each run's kept rows from ``inputs``.

    Run by run, so that nothing of the whole test's length is built but the residuals within
    runs; the kinematics are asked for the kept samples of one run at a time.
    """
    run_pos, run_w = groups.keys
    m = len(groups)
    out: dict[str, Any] = {
        "revolutions": np.zeros(m, dtype=np.int64),
        "n_samples": np.zeros(m, dtype=np.int64),
        "n_dropped": np.zeros(m, dtype=np.int64),
        "noise": np.zeros(m),
        "output": np.zeros(m),
        "input": np.zeros(m),
        "phi": np.zeros((m, len(COEFFICIENTS))),
        "structural": np.zeros((m, len(COEFFICIENTS))),
        "first": np.zeros(m, dtype=np.int64),
        "dof": np.zeros(m, dtype=np.int64),
    }
    within: list[NDArray[np.float64]] = []
    longest = int(np.max(np.diff(groups.bounds))) if m else 0
    scratch = np.empty(2 * longest)  # the cosines and sines of a run, reused run to run
    for r in range(m):
        rows = groups.span(r)
        t_run = t[rows]
        mask, n_rev = whole_cycle_mask(t_run, run_w[r])
        where = f"run at position {int(run_pos[r])}, omega {run_w[r]:g} rad/s"
        if n_rev < 1:
            span = float(t_run.max() - t_run.min())
            raise DataError(
                f"{where} covers {span:g} s, less than one whole revolution "
                f"({_TWO_PI / abs(run_w[r]):g} s); record at least one full revolution per run "
                "(the method averages whole revolutions)"
            )
        keep = _kept_rows(rows, mask)
        f, w_in = inputs(r, keep)
        try:
            red = _run_reduction(t[keep], float(run_w[r]), y[keep], f, w_in, scratch)
        except DataError as exc:
            raise DataError(f"{where}: {exc}") from None
        kept = red.within.size
        out["revolutions"][r] = n_rev
        out["n_samples"][r] = kept
        out["n_dropped"][r] = t_run.size - kept
        out["noise"][r] = red.noise_factor
        out["output"][r] = red.output
        out["input"][r] = red.input
        out["phi"][r] = red.regressors
        out["structural"][r] = red.structural
        out["first"][r] = rows.start if isinstance(rows, slice) else rows.min()
        out["dof"][r] = kept - 5
        within.append(red.within)
    return RunMeans(
        position=run_pos.astype(np.int64),
        omega=run_w.astype(float),
        revolutions=out["revolutions"],
        n_samples=out["n_samples"],
        n_dropped=out["n_dropped"],
        noise_factor=out["noise"],
        output_rate_rad_s=out["output"],
        input_rate_rad_s=out["input"],
        regressors=out["phi"],
        f_mean_g=out["phi"][:, 1:4].copy(),
        structural_regressors=out["structural"],
        first_row=out["first"],
        within_residuals_rad_s=np.concatenate(within),
        within_dof=out["dof"],
    )


def _kept_rows(rows: slice | NDArray[np.intp], mask: NDArray[np.bool_]
               ) -> slice | NDArray[np.intp]:
    """The rows of a run that ``mask`` keeps: a slice again when they are its first ones."""
    if isinstance(rows, slice):
        k = int(np.count_nonzero(mask))
        if k == mask.size or not mask[k:].any():  # whole revolutions from the first sample
            return slice(rows.start, rows.start + k)
        return np.flatnonzero(mask) + rows.start
    return rows[mask]


@dataclass(frozen=True)
class _Reduction:
    """One run's whole-revolution means (:func:`_run_reduction`)."""

    noise_factor: float
    output: float
    input: float
    regressors: NDArray[np.float64]
    structural: NDArray[np.float64]
    within: NDArray[np.float64]


def _run_reduction(t: NDArray[np.float64], omega: float, y: NDArray[np.float64],
                   f: NDArray[np.float64], w_in: NDArray[np.float64],
                   scratch: NDArray[np.float64] | None = None) -> _Reduction:
    """Whole-revolution means, structural means and residuals of one run's kept samples.

    ``f`` is the specific force [m/s^2], ``y`` the output rate and ``w_in`` the input rate on
    I [rad/s]. One basis ``b = (1, cos a, sin a, cos 2a, sin 2a)``, ``a = |w| (t - t0)``
    (:func:`~inertest.estimation.reduction.harmonic_rows`), serves all three, in three passes
    over the samples (:mod:`inertest.estimation._whole_cycle_kernel`) that build nothing of the
    run's length but its cosines, sines and residuals:

    1. the Gram matrix ``G = sum b b^T``, whence the whole-cycle weights ``w = c . b``
       (:func:`~inertest.estimation.reduction.whole_cycle_weights`:
       ``c = e_0 / n + whole_cycle_correction(G)``); their sum is ``c . G[0]`` and the sum of
       their squares (the noise factor squared) ``c G c``;
    2. the weighted sums of the drift (the output's mean is the input's plus the drift's, so
       that their difference is the drift's, summed as such), the input rate, the force in g0
       and its products (the regressors' means,
       :func:`~inertest.models.sdf_gyro.regressors_from_moments`); the
       sums of ``f``, ``cos a f``, ``sin a f``, for the structural means
       (:attr:`RunMeans.structural_regressors`: the least-squares fit of a constant and the
       first harmonic to the force, ``G[:3, :3]^-1 sum b[:3] f``); and ``sum b d`` for the
       run model of the drift ``d`` (constant and two harmonics, ``G^-1 sum b d``);
    3. the residuals of the drift from its run model (:attr:`RunMeans.within_residuals_rad_s`,
       ``n - 5`` degrees of freedom: the basis has full rank once the weights exist).

    The sense of the arm only turns the sign of the sines, which changes no fit. ``scratch``
    (at least 2 n values) receives the cosines and sines (a new array when None).
    """
    from inertest.estimation import _whole_cycle_kernel as kernel  # numba: only when fitted

    n = t.size
    gram = np.zeros((5, 5))
    cos_sin = (np.empty(2 * n) if scratch is None else scratch[: 2 * n]).reshape(2, n)
    kernel.gram(t, abs(omega), float(np.min(t)), cos_sin, gram)
    weights = whole_cycle_correction(gram, n, omega, 2)
    weights[0] += 1.0 / n
    sums = np.zeros(25)
    kernel.weighted_sums(cos_sin, y, w_in, f, 1.0 / G0, weights, sums)
    fio, fos, fsi, fii, foo, fss = sums[5:11]
    second = np.array([[fii, fio, fsi], [fio, foo, fos], [fsi, fos, fss]])
    c3 = np.linalg.solve(gram[:3, :3], sums[11:20].reshape(3, 3))  # rows 1, cos, sin
    m2 = np.outer(c3[0], c3[0]) + 0.5 * (np.outer(c3[1], c3[1]) + np.outer(c3[2], c3[2]))
    within = np.empty(n)
    kernel.basis_residuals(cos_sin, y, w_in, np.linalg.solve(gram, sums[20:25]), within)
    return _Reduction(noise_factor=float(np.sqrt(weights @ gram @ weights)),
                      output=float(sums[1] + sums[0]), input=float(sums[1]),
                      regressors=regressors_from_moments(float(weights @ gram[0]), sums[2:5],
                                                         second),
                      structural=regressors_from_moments(1.0, c3[0], m2), within=within)


def _drop_rounding_columns(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Zero the columns that are rounding noise (a structurally zero regressor).

    The least-squares solver scales every column to unit norm, which would blow a column of
    1e-17s up into a spurious, perfectly "identifiable" regressor.
    """
    out = a.copy()
    out[:, np.max(np.abs(a), axis=0) <= 1e-12 * np.max(np.abs(a))] = 0.0
    return out


def _structural_zero_columns(runs: RunMeans) -> NDArray[np.bool_]:
    """Regressors whose exact whole-cycle means are zero in every run, by the test's design.

    Besides rounding, the Earth's rotation puts a whisker into regressors that the geometry of
    the positions measured leaves at zero (e.g. the Coriolis term ``2 W x v`` has a vertical
    first harmonic ``~ 2 W cos(L) w R`` that correlates with the centripetal force and gives the
    cross products a mean ``~ (R w^2)^2 W / |w|``). Such a column would pass for information with
    an uncertainty ~1e5 times the others, so an element counts as zero when it is below
    ``2 s (2 W / |w| + W^2 / w^2)`` with ``s = (fI^2 + fO^2 + fS^2)`` of its run (``>= (R w^2)^2``
    in g0^2). Genuine means are at least ~(g/g0)^2 / 2, far above this below ~100 g.
    """
    a = np.abs(runs.structural_regressors)
    sq = [COEFFICIENTS.index(n) for n in ("DII", "DOO", "DSS")]
    w = np.abs(runs.omega)
    tol = 2.0 * a[:, sq].sum(axis=1) * (2.0 * OMEGA_IE / w + (OMEGA_IE / w) ** 2)
    tol = np.maximum(tol, 1e-12 * a.max())
    return np.all(a <= tol[:, None], axis=0)


def _structural_null_space(runs: RunMeans) -> NDArray[np.float64]:
    """Orthonormal basis (10, k) of the directions the runs cannot determine even in principle."""
    a = runs.structural_regressors.copy()
    a[:, _structural_zero_columns(runs)] = 0.0
    a = _drop_rounding_columns(a)
    # The solver's null space (column-scaled SVD); the observations do not matter for it.
    return weighted_least_squares(a, np.zeros(a.shape[0]), sigma=1.0).null_space


def fit_inputs(
    position: ArrayLike,
    omega: ArrayLike,
    t: ArrayLike,
    output_rate_rad_s: ArrayLike,
    f_ios_m_s2: ArrayLike,
    omega_ios_rad_s: ArrayLike,
    *,
    sigma_rad_s: float | None = None,
    noise_model: str = "white",
) -> tuple[LinearFit, Identification]:
    """Whole-cycle identification of the ten drift coefficients from per-sample inputs.

    Groups the samples into runs, takes whole-revolution means (:func:`run_means`), subtracts the
    mean input rate on I and solves ``mean drift = mean(Phi) @ D`` (seed 004, eqs. 22-24), one
    observation per run, under a noise model with the run as the unit of independence
    (:func:`inertest.estimation.identify.solve`).

    Parameters
    ----------
    position, omega, t, output_rate_rad_s, f_ios_m_s2, omega_ios_rad_s
        As in :func:`run_means` (inputs from any kinematic model, ideal or erroneous).
    sigma_rad_s : float, optional
        White noise per sample [rad/s]. Each run mean then has ``sigma / sqrt(n_kept)``.
        When omitted it is estimated (see ``noise_model``); the runs must outnumber the
        identifiable quantities.
    noise_model : str
        ``white`` (default here, as the centrifuge study uses it; :func:`fit` takes the
        plan's, default ``auto``): the classical weighted least squares of the run means, the
        noise per sample (when not given) from their residuals. The others treat the samples
        with the run as the unit of independence (:func:`_sample_rows`): the white noise per
        sample from the scatter within runs about the run model, and a component between runs
        by REML from the run means: ``position-offsets`` (an offset per run), ``random-walk``
        or ``flicker`` (over the samples of the runs in time order, i.e. the order of their
        first data row); the run means are then fitted by generalised least squares. ``auto``
        picks one of these or white noise by AIC (``white`` when ``sigma_rad_s`` is given);
        when white noise wins it is pooled from every kept sample, with the lack-of-fit F test
        of the run means against the scatter within runs as its check.

    Returns
    -------
    fit : LinearFit
        SI solution (rad/s, rad/s/g, rad/s/g^2 in the order of ``COEFFICIENTS``); its residuals
        are per run [rad/s].
    identification : Identification
        Coefficients with standard uncertainties [deg/h, deg/h/g, deg/h/g^2], combinations and
        statements of what the runs cannot separate, the noise model used, its components
        (``white`` per sample, ``position offset`` per run, ``random walk`` step per sample,
        ``flicker`` per sample) [deg/h] and its checks. With ``sigma_rad_s`` omitted,
        ``noise_sigma`` is the estimated white noise per sample [deg/h].
    """
    runs = run_means(position, omega, t, output_rate_rad_s, f_ios_m_s2, omega_ios_rad_s)
    return _identify_runs(runs, sigma_rad_s, check_noise_model(noise_model))


def _identify_runs(
    runs: RunMeans, sigma_rad_s: float | None, noise_model: str
) -> tuple[LinearFit, Identification]:
    if sigma_rad_s is not None and (not np.isfinite(sigma_rad_s) or sigma_rad_s <= 0):
        raise InputError(f"noise sigma must be finite and positive, got {sigma_rad_s}")
    A, y = runs.regressors, runs.drift_rad_s
    # Directions that the runs cannot determine in principle (e.g. a cross term whose whole-cycle
    # mean is zero at every position measured) are removed from the sampled design: otherwise
    # tiny leakage (rounding, harmonics above the second on a real machine) would "determine"
    # them with a huge, meaningless uncertainty. With all nine positions at two rates there are
    # none and A is unchanged.
    null = _structural_null_space(runs)
    if null.shape[1]:
        A = _drop_rounding_columns(A - (A @ null) @ null.T)
    if sigma_rad_s is None and runs.position.size <= A.shape[1] - null.shape[1]:
        raise DataError(
            f"{runs.position.size} runs leave no degree of freedom to estimate the noise from the "
            "residuals; give the noise per sample (--sigma) or add runs (positions or rates)"
        )
    if noise_model == "white":
        # The classical solution: one reading per run, rows scaled by sqrt(n) (1/noise_factor)
        # so that the unit-weight sigma is the noise per sample, estimated from the run means'
        # residuals (robust to offsets between runs, which it counts as noise).
        root_n = 1.0 / runs.noise_factor
        A_rows: NDArray[np.float64] | PositionDesign = A * root_n[:, None]
        y_rows = y * root_n
    else:
        A_rows, y_rows = _sample_rows(runs, A, y)
    # Solve for x / s with s the known per-sample sigma (1 rad/s when unknown), so that the
    # observations are O(1) when the noise is known.
    known = sigma_rad_s is not None
    s = float(sigma_rad_s) if sigma_rad_s is not None else 1.0
    k = DEG_PER_H_TO_RAD_PER_S / s
    fit, ident = identify(
        A_rows,
        y_rows if s == 1.0 else y_rows / s,  # no copy of the rows when s is 1
        names=COEFFICIENTS,
        units=ENGINEERING_UNIT,
        si_per_unit={n: k for n in COEFFICIENTS},
        noise_unit="deg/h",
        si_per_noise_unit=k,
        sigma_si=1.0 if known else None,
        pivot_order=("DF", "DII", "DOO", "DSS", "DI", "DO", "DS", "DIO", "DOS", "DSI"),
        normalize_to="DF",
        explain=lambda f, a: explain_null_space(f, a, runs),
        noise_model=noise_model,
    )
    x = fit.x * s
    residuals = y - A @ x  # per run [rad/s]
    fit = replace(fit, x=x, covariance=fit.covariance * s * s, residuals=residuals,
                  sigma=fit.sigma * s)
    ident = replace(ident, residuals=residuals / DEG_PER_H_TO_RAD_PER_S)
    return fit, ident


def _sample_rows(
    runs: RunMeans, A: NDArray[np.float64], y: NDArray[np.float64]
) -> tuple[PositionDesign, NDArray[np.float64]]:
    """Rows for :func:`~inertest.estimation.identify.solve`: one per kept sample, runs as units.

    Each run contributes ``n_kept`` rows in time order (runs ordered by their first data row),
    all with the run's averaged regressors ``A[r]`` (a
    :class:`~inertest.estimation.units.PositionDesign`: the runs' rows and the run of each
    sample, never the full design), whose plain mean is the run's whole-cycle mean ``y[r]``
    and whose scatter about it is the run's samples about its run model
    (``within_residuals_rad_s``), scaled by ``sqrt((n - 1) / (n - 5))`` so that the pooled
    within-group variance that the solver takes (``n - 1`` degrees of freedom per group) is
    unbiased for the 5 parameters of the run model. So the solver sees the run means, their
    count of samples and the white noise within runs: its unit of independence is the run.
    A run of 5 samples has no scatter left and contributes none.
    """
    n = runs.n_samples
    order = np.argsort(runs.first_row, kind="stable")
    starts = np.cumsum(n) - n  # where each run's residuals begin (runs in their own order)
    dof = runs.within_dof
    scale = np.sqrt(np.where(dof > 0, (n - 1) / np.maximum(dof, 1), 0.0))
    rows = np.empty(int(n.sum()))
    i = 0
    for r in order:  # run by run, in time order: slices, no gathers over the record
        e = rows[i:i + n[r]]
        np.multiply(runs.within_residuals_rad_s[starts[r]:starts[r] + n[r]], scale[r], out=e)
        e -= np.mean(e) - y[r]
        i += n[r]
    labels = tuple(f"run at position {int(runs.position[r])}, omega {runs.omega[r]:g} rad/s"
                   for r in order)
    # Built directly: every run has rows, and its rows are one stretch in time order.
    return PositionDesign(rows=A[order], index=np.repeat(np.arange(order.size), n[order]),
                          labels=labels), rows


def explain_null_space(
    fit: LinearFit, A: NDArray[np.float64], runs: RunMeans
) -> tuple[str, ...]:
    """Plain statements of what the runs cannot separate, and why (positions or rates missing).

    Parameters
    ----------
    fit : LinearFit
        The least-squares solution (its null space is explained).
    A : ndarray, shape (m, 10)
        Design actually solved (only its shape is used).
    runs : RunMeans
        The runs, for the rates and positions measured.
    """
    null = fit.null_space
    if null.shape[1] == 0:
        return ()
    out: list[str] = []
    explained: list[NDArray[np.float64]] = []
    # Zero in the exact whole-cycle means (not just rounding noise in the sampled ones).
    zero = [int(i) for i in np.flatnonzero(_structural_zero_columns(runs))]
    if zero:
        out.append(
            f"{', '.join(COEFFICIENTS[i] for i in zero)}: their averaged regressors are zero in "
            "every run measured, so the data say nothing about them"
        )
        explained += [np.eye(A.shape[1])[i] for i in zero]
    # One rate: the averaged squares sum to s = ((R w^2)^2 + g^2) / g0^2 in every run (the
    # centripetal force turns in the horizontal plane, (R w^2)^2 / 2 on each horizontal axis), so
    # adding t to DII, DOO, DSS and -t s to DF changes no run mean.
    sq = [COEFFICIENTS.index(n) for n in ("DII", "DOO", "DSS")]
    total = runs.regressors[:, sq].sum(axis=1)
    if np.ptp(total) <= 1e-9 * max(float(np.max(np.abs(total))), 1.0):
        v = np.zeros(A.shape[1])
        v[COEFFICIENTS.index("DF")] = -float(total.mean())
        v[sq] = 1.0
        v /= np.linalg.norm(v)
        if np.linalg.norm(null.T @ v) > 1.0 - 1e-6:
            rates = ", ".join(f"{w:g}" for w in np.unique(runs.omega))
            out.append(
                f"DF, DII, DOO, DSS: not separable, because every run has the same mean "
                f"fI^2 + fO^2 + fS^2 = ((R w^2)^2 + g^2)/g0^2 = {total.mean():.6g} (one "
                f"main-axis rate: {rates} rad/s), as in a 1 g tumble; only the combinations "
                "listed are determined; run a second rate"
            )
            explained.append(v)
    # Whatever the statements above do not account for.
    rest = null
    if explained:
        q, _ = np.linalg.qr(np.column_stack(explained))
        rest = null - q @ (q.T @ null)
    share = _share_of_span(rest)
    if np.any(share > 1e-14):
        names = [COEFFICIENTS[i] for i in range(A.shape[1]) if share[i] > 1e-14]
        missing = sorted(set(machine.POSITIONS) - {int(p) for p in runs.position})
        why = (
            f"positions {', '.join(map(str, missing))} were not measured" if missing
            else "the runs measured do not separate them"
        )
        out.append(
            f"{', '.join(names)}: not separable because {why}; only the combinations listed "
            "are determined (measure all nine positions at two or more rates)"
        )
    return tuple(out)


def _share_of_span(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Squared length of each coordinate axis projected on the column space of ``m`` (p, k).

    ``P_ii`` of the orthogonal projector on span(m): 0 for a coefficient that the directions
    ``m`` do not involve. The span is the orthogonal complement of the null space of ``m^T``,
    found by the solver (:func:`~inertest.estimation.least_squares.weighted_least_squares`).
    A coefficient whose row of ``m`` is shorter than 1e-7 is not involved (rounding and leakage
    left by the projections above) and is dropped first: the solver scales every column of
    ``m^T`` to unit norm and would blow it up into a direction of its own.
    """
    mt = np.where(np.linalg.norm(m, axis=1)[:, None] > 1e-7, m, 0.0).T
    if not np.any(mt):
        return np.zeros(m.shape[0])
    complement = weighted_least_squares(mt, np.zeros(mt.shape[0]), sigma=1.0).null_space
    return 1.0 - np.sum(complement**2, axis=1)


def _positions(position: NDArray) -> NDArray[np.int64]:
    """Position numbers as integers 1..9; a clear error naming the bad values otherwise."""
    try:
        p = np.asarray(position, dtype=float)
    except (TypeError, ValueError):
        raise DataError(
            'column "position" must hold the position numbers 1..9 of the nine-position method'
        ) from None
    if p.size and 1 <= np.min(p) and np.max(p) <= 9:  # NaN fails these
        q = p.astype(np.int64)
        if np.array_equal(q, p):  # good data: no temporaries beyond these
            return q
    bad = ~np.isfinite(p) | (p != np.round(p)) | (p < 1) | (p > 9)
    if np.any(bad):
        values = ", ".join(f"{v:g}" for v in np.unique(p[bad])[:5])
        raise DataError(
            f'column "position" has unknown position number(s) {values} (first at data row '
            f"{int(np.flatnonzero(bad)[0]) + 1}); the nine-position method numbers them 1..9"
        )
    return p.astype(np.int64)
