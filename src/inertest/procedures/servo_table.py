"""Servo-table (long-term) drift test of an SDF floated gyro.

Seed ``000_dad8be616c6569c7.txt`` (section on 转台伺服试验, the servo turntable test simulating a
platform INS) and IEEE Std 517-1974 (the classical long-term drift test). The gyro's input axis I
lies along the table axis and its output drives the table so that the output stays at null; the
table then turns at ``dtheta/dt = -(W . a) - s drift(f(theta))`` (see
:mod:`inertest.equipment.servo_table`), and the encoder angle against time is the record.

Reduction: the ANGLE series is fitted, not differentiated rates. Integrating the servo equation
from the first reading of each mounting::

    theta_k + (W . a)(t_k - t_0) = theta_0 - s * sum_j c_j Phi_j(t_k),
    Phi_j(t_k) = integral_{t_0}^{t_k} phi_j(f(theta(t))) dt

with ``phi_j`` the regressors of the SDF drift model evaluated at the measured angles (cumulative
Simpson rule; the angle noise in ``phi_j`` is negligible beside its effect on ``theta_k``). Encoder
noise and quantisation are then white in the observations, so ordinary least squares gives an
honest covariance; differencing the angles instead would make neighbouring rates correlated
(MA(1)). The unknown start angle ``theta_0`` of each mounting is removed by centring each
mounting's rows (Frisch-Waugh), which costs one degree of freedom per mounting (not subtracted
from the reported dof: a relative bias of the noise estimate below 1e-3 for any real record).

What the polar table determines, with gamma = g/g0, latitude L and ``psi`` the table angle from
the mounting's O direction (H: 0, E: 90 deg, L: 180 deg, W: 270 deg)::

    drift = DF + s gamma sL DI + gamma^2 sL^2 DII + gamma^2 cL^2 (DOO + DSS)/2
            + gamma cL (DO + s gamma sL DIO) cos psi - gamma cL (s DS + gamma sL DSI) sin psi
            - s gamma^2 cL^2 DOS/2 sin 2psi + gamma^2 cL^2 (DOO - DSS)/2 cos 2psi

so mountings with I+ and I- give DI, DO, DS, DIO, DSI, DOS, DOO - DSS and the one combination
``DF + gamma^2 sL^2 DII + gamma^2 cL^2 (DOO + DSS)/2``. The vertical table keeps O and S
horizontal (fO = fS = 0): it gives ``DF + gamma^2 DII`` and, with I+ and I-, DI; nothing else.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import cumulative_simpson

from inertest.equipment.servo_table import DIRECTIONS, TABLE_AXES, Mounting, ServoTable
from inertest.errors import DataError, InertestWarning, InputError, PlanError
from inertest.estimation.harmonics import harmonic_design, harmonic_names
from inertest.estimation.identify import identify
from inertest.estimation.least_squares import LinearFit
from inertest.models.sdf_gyro import (
    COEFFICIENTS,
    ENGINEERING_UNIT,
    coefficients_from_deg_h,
    drift_regressors,
)
from inertest.noise import oadev
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import require_columns
from inertest.results import Estimate, LinearTestResult
from inertest.units import ARCSEC_TO_RAD, DEG_PER_H_TO_RAD_PER_S, DEG_TO_RAD, HOUR_TO_S

KIND = "servo-table"
_K = DEG_PER_H_TO_RAD_PER_S
#: Length of the blocks over which the drift-against-angle curve is shown [s].
CURVE_BLOCK_S = 600.0

FIELDS: tuple[Field, ...] = (
    Field("table_axis", "text", "polar", choices=TABLE_AXES,
          doc="polar (toward the north celestial pole) or vertical"),
    Field("mountings", "texts", (), doc="mountings, e.g. I+H, I-H (polar) or I+N, I-N (vertical)"),
    Field("duration_h", "number", 24.0, "h", positive=True, doc="record length per mounting"),
    Field("sample_interval_s", "number", 10.0, "s", positive=True,
          doc="time between encoder readings"),
    Field("encoder_noise_arcsec", "number", 0.0, "arcsec", minimum=0.0,
          doc="white noise of an encoder reading (simulation)"),
    Field("encoder_resolution_arcsec", "number", 0.0, "arcsec", minimum=0.0,
          doc="quantisation step of the encoder, 0 for none (simulation)"),
    Field("drift_random_walk_deg_h_per_sqrt_h", "number", 0.0, "deg/h/sqrt(h)", minimum=0.0,
          doc="random-walk drift of the gyro (simulation)"),
    Field("stability_interval_h", "number", 1.0, "h", positive=True,
          doc="interval of the drift-stability series"),
)


@dataclass(frozen=True)
class ServoTableSpec:
    """Parameters of a servo-table plan (``[procedure]`` table).

    Attributes
    ----------
    table_axis : {"polar", "vertical"}
    mountings : tuple of str
        Mountings (one data block each); default ``I+H, I-H`` (polar), ``I+N, I-N`` (vertical).
    duration_h : float
        Record length per mounting [h] (simulation).
    sample_interval_s : float
        Time between encoder readings [s] (simulation).
    encoder_noise_arcsec, encoder_resolution_arcsec : float
        White noise per reading and quantisation step of the encoder [arcsec] (simulation).
    drift_random_walk_deg_h_per_sqrt_h : float
        Random-walk drift of the virtual gyro [deg/h/sqrt(h)] (simulation).
    stability_interval_h : float
        Interval of the long-term drift-stability series [h].
    """

    kind: ClassVar[str] = KIND
    table_axis: str = "polar"
    mountings: tuple[str, ...] = ("I+H", "I-H")
    duration_h: float = 24.0
    sample_interval_s: float = 10.0
    encoder_noise_arcsec: float = 0.0
    encoder_resolution_arcsec: float = 0.0
    drift_random_walk_deg_h_per_sqrt_h: float = 0.0
    stability_interval_h: float = 1.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> ServoTableSpec:
        """Build from the ``[procedure]`` table of a plan file."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}", ignore=("kind",))
        if not v["mountings"]:
            first = DIRECTIONS[v["table_axis"]][0]
            v["mountings"] = (f"I+{first}", f"I-{first}")
        try:
            from inertest.earth import Site
            # The labels do not depend on latitude; check them at 45 deg.
            ServoTable(Site.at(45.0), v["table_axis"], tuple(v["mountings"]))
        except InputError as exc:
            raise PlanError(str(exc)) from None
        if v["sample_interval_s"] >= v["duration_h"] * HOUR_TO_S / 2:
            raise PlanError("sample_interval_s must be well below duration_h; record more readings")
        return cls(**v)




@dataclass(frozen=True)
class DriftCurve:
    """Drift against table angle of one mounting, over blocks of :data:`CURVE_BLOCK_S`.

    ``angle_deg`` the mean table angle of each block (mod 360) [deg], ``drift_deg_h`` the drift
    from the angle change over the block [deg/h], ``fitted_deg_h`` the fitted harmonic curve
    at the same angles [deg/h].
    """

    angle_deg: NDArray[np.float64]
    drift_deg_h: NDArray[np.float64]
    fitted_deg_h: NDArray[np.float64]

    def to_dict(self) -> dict[str, object]:
        """Lists for JSON."""
        return {"angle_deg": self.angle_deg.tolist(), "drift_deg_h": self.drift_deg_h.tolist(),
                "fitted_deg_h": self.fitted_deg_h.tolist()}


@dataclass(frozen=True)
class DriftStability:
    """Long-term drift stability of one mounting (IEEE Std 517 style).

    Attributes
    ----------
    interval_h : float
        Length of each interval [h].
    time_h : ndarray
        Middle of each interval since the mounting's start [h].
    drift_deg_h : ndarray
        Drift over each interval with the harmonic model removed [deg/h].
    std_deg_h : float
        Standard deviation of the series [deg/h].
    trend : Estimate
        Slope of a straight line through the series [deg/h per h], with its std.
    allan_tau_h, allan_dev_deg_h : ndarray
        Overlapping Allan deviation of the series (:func:`inertest.noise.oadev`) [h, deg/h].
    """

    interval_h: float
    time_h: NDArray[np.float64]
    drift_deg_h: NDArray[np.float64]
    std_deg_h: float
    trend: Estimate | None
    allan_tau_h: NDArray[np.float64]
    allan_dev_deg_h: NDArray[np.float64]

    def to_dict(self) -> dict[str, object]:
        """Plain values with units for JSON."""
        return {
            "interval": {"value": self.interval_h, "unit": "h"},
            "time_h": self.time_h.tolist(),
            "drift_deg_h": self.drift_deg_h.tolist(),
            "std": {"value": self.std_deg_h, "unit": "deg/h"},
            "trend": None if self.trend is None else self.trend.to_dict(),
            "allan": {"tau_h": self.allan_tau_h.tolist(),
                      "dev_deg_h": self.allan_dev_deg_h.tolist()},
        }


@dataclass(frozen=True, kw_only=True)
class ServoTableResult(LinearTestResult):
    """Outcome of :func:`fit` for a servo-table drift test.

    Attributes
    ----------
    identification : Identification
        Coefficients, combinations and what the mountings cannot separate (angle-series fit).
    table_axis : str
    earth_rate_along_axis_deg_h : float
        ``W . a`` [deg/h].
    harmonics : dict
        Per mounting, the drift against table angle as B0, S1, C1, S2, C2 [deg/h] with std
        (from the fitted model, so exactly consistent with the coefficients).
    curves : dict of DriftCurve
        Per mounting, block drift against table angle with the fitted curve.
    stability : dict of DriftStability
        Per mounting, the long-term drift stability after the harmonic model is removed.
    residual_output : ndarray
        Angle residual per reading [arcsec].
    """

    table_axis: str
    earth_rate_along_axis_deg_h: float
    harmonics: dict[str, tuple[Estimate, ...]]
    curves: dict[str, DriftCurve] = field(repr=False)
    stability: dict[str, DriftStability] = field(repr=False)
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        return {
            "table_axis": self.table_axis,
            "earth_rate_along_axis": {"value": self.earth_rate_along_axis_deg_h,
                                      "unit": "deg/h"},
            "harmonics": {m: {t.name: t.to_dict() for t in terms}
                          for m, terms in self.harmonics.items()},
            "drift_curves": {m: c.to_dict() for m, c in self.curves.items()},
            "stability": {m: s.to_dict() for m, s in self.stability.items()},
        }


def _table(plan: Plan) -> ServoTable:
    spec: ServoTableSpec = plan.procedure
    try:
        return ServoTable(plan.site, spec.table_axis, tuple(spec.mountings))
    except InputError as exc:
        raise PlanError(str(exc)) from None


def _check_revolution(table: ServoTable, duration_s: float, label: str) -> None:
    """A polar record must last one nominal revolution for the harmonics to be separable."""
    if table.table_axis != "polar":
        return
    rev_s = 2 * np.pi / abs(table.earth_rate_along_axis)
    if duration_s < rev_s:
        raise DataError(
            f"mounting {label} lasts {duration_s / HOUR_TO_S:.2f} h, less than one table "
            f"revolution ({rev_s / HOUR_TO_S:.2f} h at the Earth rate); record at least one "
            "revolution per mounting")


@dataclass(frozen=True)
class ServoObservations:
    """Servo-table angle series as integrated-regressor rows (module docstring), per mounting.

    ``mounting``, ``t`` [s], ``theta`` (unwrapped angle [rad]) per reading; ``A``, ``y`` the
    centred design and observation of each mounting's rows; ``table`` the servo table with the
    data's mountings, ``parsed`` the mountings.
    """

    mounting: NDArray
    t: NDArray[np.float64]
    theta: NDArray[np.float64]
    A: NDArray[np.float64]
    y: NDArray[np.float64]
    labels: list[str]
    table: ServoTable
    parsed: Mapping[str, Mounting]


class ServoTableDrift(Procedure[ServoTableSpec, ServoObservations, ServoTableResult]):
    """Floated gyro on a servo table (seed 000; IEEE Std 517 long-term drift test).

    Data columns ``mounting`` (str), ``time_s`` [s] and ``table_angle_deg`` [deg, cumulative,
    right-handed about +a]; one row per encoder reading, in time order within a mounting; the
    mountings are read from the data. A known ``sigma`` is the encoder noise per reading
    [arcsec]; estimated from the residuals when omitted.

    The angle series is fitted with integrated regressors (module docstring), so the std of
    every estimate is honest for white encoder noise and quantisation. A random drift of the
    gyro (random walk, flicker) makes the angle residuals correlated: the model checks of the
    identification then say so, and the stability series shows it.
    """

    kind = KIND
    title = "Floated gyro, servo-table drift test"
    spec = ServoTableSpec
    model = "inertest.models.sdf_gyro"
    method = "least squares on the integrated angle series (white encoder noise)"
    report = "inertest.report.servo_table:servo_table_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> ServoTable:
        """The servo table at the plan's site with the plan's mountings."""
        return _table(plan)

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: ServoTable
               ) -> ServoObservations:
        """Each mounting's angle series as integrated regressors, its start angle removed."""
        cols = require_columns(data, ("time_s", "table_angle_deg"), ("mounting",), procedure=KIND)
        mounting, t, ang = cols["mounting"], cols["time_s"], cols["table_angle_deg"]
        labels = list(dict.fromkeys(mounting.tolist()))
        try:
            table = dataclasses.replace(motion, mountings=tuple(labels))
            parsed = {m: table.mounting(m) for m in labels}
        except InputError as exc:
            raise DataError(f"{exc} (column mounting)") from None
        wa = table.earth_rate_along_axis
        n = t.size
        A = np.zeros((n, len(COEFFICIENTS)))
        y = np.zeros(n)
        theta = np.zeros(n)
        for m in labels:
            sel = np.flatnonzero(mounting == m)
            tm = t[sel]
            bad = np.flatnonzero(np.diff(tm) <= 0)
            if bad.size:
                raise DataError(
                    f"mounting {m}: time_s does not increase at data row {sel[bad[0] + 1] + 1}; "
                    "sort the readings by time (one block per mounting)")
            if sel.size < 8:
                raise DataError(f"mounting {m} has {sel.size} readings; record at least 8")
            _check_revolution(table, tm[-1] - tm[0], m)
            th = np.unwrap(ang[sel] * DEG_TO_RAD)
            theta[sel] = th
            phi = drift_regressors(table.specific_force_g(m, th))
            Phi = cumulative_simpson(phi, x=tm - tm[0], axis=0, initial=0.0)
            s = parsed[m].sign
            yy = th + wa * (tm - tm[0])
            AA = -s * Phi
            # Remove the unknown start angle (Frisch-Waugh): centre the mounting's rows.
            y[sel] = yy - yy.mean()
            A[sel] = AA - AA.mean(axis=0)
        return ServoObservations(mounting, t, theta, A, y, labels, table, parsed)

    def identify(self, plan: Plan, obs: ServoObservations, *, sigma: float | None,
                 noise_model: str | None) -> ServoTableResult:
        """The drift coefficients, the harmonics, drift curves and stability per mounting."""
        if sigma is not None and (not np.isfinite(sigma) or sigma <= 0):
            raise InputError(f"sigma must be a positive encoder noise in arcsec, got {sigma}")
        spec: ServoTableSpec = plan.procedure
        site = plan.site
        mounting, t, theta, A, y = obs.mounting, obs.t, obs.theta, obs.A, obs.y
        labels, table, parsed = obs.labels, obs.table, obs.parsed
        wa = table.earth_rate_along_axis
        messages: list[str] = []
        sigma_si = None if sigma is None else sigma * ARCSEC_TO_RAD
        gamma = site.gravity_g
        lsq, ident = identify(
            A, y, names=COEFFICIENTS, units=ENGINEERING_UNIT,
            si_per_unit={c: _K for c in COEFFICIENTS}, noise_unit="arcsec",
            si_per_noise_unit=ARCSEC_TO_RAD, sigma_si=sigma_si,
            pivot_order=("DF", "DOO", "DSS", "DII"), normalize_to="DF",
            explain=lambda f, d: _explain(f, d, table, parsed, gamma), noise_model="white",
        )
        if ident.checks is not None and not ident.checks.fits:
            # solve() has warned already; say what it most likely means here.
            messages.append(
                "the angle residuals are not white encoder noise (random drift of the gyro?); "
                "the stds assume white encoder noise, see the drift-stability series")
        harmonics = {m: _harmonic_terms(table, m, lsq) for m in labels}
        curves, stability = {}, {}
        for m in labels:
            sel = np.flatnonzero(mounting == m)
            s = parsed[m].sign
            curves[m] = _curve(t[sel], theta[sel], s, wa, harmonics[m])
            stab, msg = _stability(t[sel], lsq.residuals[sel], s, spec.stability_interval_h, m)
            if stab is not None:
                stability[m] = stab
            if msg:
                messages.append(msg)
                warnings.warn(msg, InertestWarning, stacklevel=3)
        return ServoTableResult(
            site_latitude_deg=site.latitude_deg,
            site_gravity_m_s2=site.gravity_m_s2,
            identification=ident,
            table_axis=spec.table_axis,
            earth_rate_along_axis_deg_h=wa / _K,
            harmonics=harmonics,
            curves=curves,
            stability=stability,
            residual_output=lsq.residuals / ARCSEC_TO_RAD,
            output_unit="arcsec",
            messages=tuple(messages),
            instrument=plan.instrument,
        )

    def synthesize(self, plan: Plan, motion: ServoTable, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """Encoder readings of a servo table driven by a virtual gyro.

        ``truth``: drift coefficients [deg/h, deg/h/g, deg/h/g^2]; missing names are 0.
        ``noise``: encoder noise per reading [arcsec]; when 0 the plan's
        ``encoder_noise_arcsec``. ``rng``: random source (encoder noise, random-walk drift).

        Returns columns ``mounting``, ``time_s`` [s] (continuous over the mountings, run one
        after the other) and ``table_angle_deg`` [deg] (cumulative, 0 at each mounting's start
        before noise). The servo loop is integrated exactly (:meth:`ServoTable.servo_angle`);
        the random-walk drift is generated at the reading times and interpolated linearly
        between them.
        """
        spec: ServoTableSpec = plan.procedure
        table = motion
        if not np.isfinite(noise) or noise < 0:
            raise PlanError(f"noise must be finite and >= 0 arcsec, got {noise}")
        sigma = noise if noise > 0 else spec.encoder_noise_arcsec
        gen = np.random.default_rng(rng)
        c = coefficients_from_deg_h(truth)
        dt = spec.sample_interval_s
        t_local = np.arange(0.0, spec.duration_h * HOUR_TO_S + dt / 2, dt)
        _check_revolution(table, t_local[-1] - t_local[0], spec.mountings[0])
        n, nm = t_local.size, len(spec.mountings)
        t_all = np.concatenate([t_local + k * (t_local[-1] + dt) for k in range(nm)])
        k_rw = spec.drift_random_walk_deg_h_per_sqrt_h * _K / np.sqrt(HOUR_TO_S)
        walk = None
        if k_rw > 0:
            steps = gen.normal(0.0, k_rw * np.sqrt(np.diff(t_all, prepend=t_all[0])))
            walk = np.cumsum(steps)
        angles = []
        for k, m in enumerate(spec.mountings):
            seg = slice(k * n, (k + 1) * n)
            extra = None
            if walk is not None:
                ts, ws = t_local, walk[seg].copy()

                def extra(tt: float, ts=ts, ws=ws) -> float:
                    return float(np.interp(tt, ts, ws))
            angles.append(table.servo_angle(m, t_local, c, extra_drift=extra))
        theta = np.concatenate(angles) / ARCSEC_TO_RAD
        if sigma > 0:
            theta = theta + gen.normal(0.0, sigma, theta.size)
        q = spec.encoder_resolution_arcsec
        if q > 0:
            theta = q * np.round(theta / q)
        mounting = np.repeat(np.array([table.mounting(m).label for m in spec.mountings]), n)
        return {"mounting": mounting, "time_s": t_all, "table_angle_deg": theta / 3600.0}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = ServoTableDrift()


def _harmonic_terms(table: ServoTable, m: str, lsq: LinearFit) -> tuple[Estimate, ...]:
    """B0..C2 of the fitted drift against table angle, with std from the covariance."""
    th = np.arange(8) * np.pi / 4
    D = drift_regressors(table.specific_force_g(m, th))
    P = np.linalg.pinv(harmonic_design(th, 2)) @ D
    values = P @ lsq.x / _K
    cov = P @ lsq.covariance @ P.T / _K**2
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return tuple(Estimate(nm, float(v), float(sd), "deg/h")
                 for nm, v, sd in zip(harmonic_names(2), values, std, strict=True))


def _evaluate(terms: tuple[Estimate, ...], angle_rad: NDArray[np.float64]) -> NDArray[np.float64]:
    return harmonic_design(angle_rad, 2) @ np.array([e.value for e in terms])


def _curve(
    t: NDArray[np.float64], theta: NDArray[np.float64], s: int, wa: float,
    terms: tuple[Estimate, ...],
) -> DriftCurve:
    step = max(1, int(round(CURVE_BLOCK_S / float(np.median(np.diff(t))))))
    idx = np.arange(0, t.size, step)
    if idx.size < 2:
        idx = np.array([0, t.size - 1])
    d_theta, d_t = np.diff(theta[idx]), np.diff(t[idx])
    drift = -s * (d_theta / d_t + wa) / _K
    mid = 0.5 * (theta[idx][1:] + theta[idx][:-1])
    return DriftCurve(np.degrees(np.mod(mid, 2 * np.pi)), drift, _evaluate(terms, mid))


def _stability(
    t: NDArray[np.float64], resid_rad: NDArray[np.float64], s: int, interval_h: float, m: str,
) -> tuple[DriftStability | None, str]:
    """Per-interval drift with the model removed: ``-s * (residual angle change) / interval``."""
    T = interval_h * HOUR_TO_S
    # First reading at or after each multiple of the interval; a partial last one is dropped.
    edges = np.searchsorted(t - t[0], np.arange(0.0, t[-1] - t[0] + 1e-6 * T, T) - 1e-6 * T)
    edges = edges[edges < t.size]
    if edges.size < 4:
        return None, (f"mounting {m}: fewer than 3 intervals of {interval_h:g} h; no "
                      "drift-stability series (shorten stability_interval_h)")
    dt = np.diff(t[edges])
    series = -s * np.diff(resid_rad[edges]) / dt / _K
    mid_h = (0.5 * (t[edges][1:] + t[edges][:-1]) - t[0]) / HOUR_TO_S
    X = np.column_stack([np.ones_like(mid_h), mid_h - mid_h.mean()])
    coef, *_ = np.linalg.lstsq(X, series, rcond=None)
    dof = series.size - 2
    trend = None
    if dof > 0:
        s2 = float(np.sum((series - X @ coef) ** 2) / dof)
        trend = Estimate("drift trend", float(coef[1]),
                         float(np.sqrt(s2 / np.sum((mid_h - mid_h.mean()) ** 2))), "deg/h/h")
    dev = oadev(series, 1.0 / T, "octave")
    return DriftStability(interval_h, mid_h, series, float(np.std(series, ddof=1)), trend,
                          np.asarray(dev.taus) / HOUR_TO_S, np.asarray(dev.dev)), ""


def _explain(
    fit: LinearFit, A: NDArray[np.float64], table: ServoTable,
    parsed: Mapping[str, Mounting], gamma: float,
) -> tuple[str, ...]:
    """What the mountings cannot separate, and why."""
    null = fit.null_space.shape[1]
    if null == 0:
        return ()
    signs = {p.sign for p in parsed.values()}
    out = []
    if table.table_axis == "vertical":
        out.append(
            "DO, DS, DIO, DOS, DSI, DOO, DSS: on a vertical table O and S stay horizontal "
            "(fO = fS = 0) at every angle, so these terms never act; DF and DII enter only as "
            f"DF + {gamma**2:.6f}*DII (fI = +-g/g0)")
        if len(signs) == 1:
            out.append("DI: with I along one direction of the axis only, fI is constant and DI "
                       "adds to DF; mount the gyro with I reversed (I+ and I-) to separate it")
        return tuple(out)
    lat = table.site.latitude_rad
    sl2, cl2 = np.sin(lat) ** 2 * gamma**2, np.cos(lat) ** 2 * gamma**2
    out.append(
        "DF, DII, DOO, DSS: with I along the polar axis fI = +-(g/g0) sinL is constant and "
        "fO^2 + fS^2 = (g/g0)^2 cos^2L at every table angle, so they act only through "
        f"DF + {sl2:.6f}*DII + {cl2 / 2:.6f}*(DOO + DSS) and DOO - DSS; "
        "only the combinations listed are determined")
    expected = 2
    if len(signs) == 1:
        out.append(
            "DI, DIO, DSI: with I along one direction of the axis only, DI adds to DF, DIO to "
            "DO and DSI to DS; mount the gyro with I reversed (I+ and I-) to separate them")
        expected = 5
    if null > expected:
        names = [COEFFICIENTS[i] for i in range(A.shape[1])
                 if np.linalg.norm(fit.null_space[i]) > 1e-7]
        out.append(f"{', '.join(names)}: the record does not separate these (at the equator "
                   "I sees no gravity); only the combinations listed are determined")
    return tuple(out)
