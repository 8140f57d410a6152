"""Iterative calibration of a gyro triad in navigation mode (seed 003, sec. 1.3).

Seed ``003_f374f866dfe7c99f.txt``: after the open-loop calibration, the triad's output is
compensated with the current scale factors and misalignments and the system navigates while the
table turns the triad through exactly 360 deg about one axis, as fast as possible; the attitude
it computes is compared with the table's, and the difference is turned into corrections of the
scale factors and misalignments; this is repeated until the corrections vanish.

Here, for each iteration:

1. calibrated increments ``dtheta = A^-1 (dN - b dt)`` [rad] from the raw counts of each sample;
2. attitude by quaternion integration in the local-level frame, with the two-sample coning
   correction ``phi_k = dtheta_k + dtheta_{k-1} x dtheta_k / 12`` (Savage, *Strapdown Analytics*,
   2nd ed., eq. 7.1.1.1-11) and the Earth rate of the frame:
   ``C_nb(t_k) = R(-W_ie_n t_k) C_nb0 R(phi_1) ... R(phi_k)``, products by a parallel prefix scan
   of :class:`scipy.spatial.transform.Rotation`;
3. attitude error ``phi = rotvec(C_nb C_nb_table^T)`` [rad, ENU] at check instants against the
   table's attitude ``C_nb0 R_j(theta_table)``;
4. to first order the error grows as ``d phi/dt = C_nb (E w_b + dbeta)`` with ``E = A^-1 A_true -
   I`` and ``dbeta = A^-1 (b_true - b)``; least squares over the *increments* of ``phi`` between
   check instants (independent for white rate noise; the alignment error drops out) gives ``E``
   and ``dbeta``; then ``A <- A (I + E)``, ``b <- b + A dbeta``.

The linearisation neglects the products of errors and the Earth-rate coupling of ``phi``, so
the corrections are exact only at convergence: iterating is a Gauss-Newton solution of the
navigation equations. After a whole turn about ``j`` only ``E_jj`` (the scale factor) shows in
the end attitude; the misalignments ``E_ij`` show while the table turns (their error turns with
the body and cancels over the full turn), hence check instants during the rotation.

Identifiability: column ``j`` of ``E`` needs rotations about ``j``; the bias corrections need
time at rest or both directions. Units: raw counts in raw SI (count for pulses, rad for rate
outputs); ``A`` [raw per rad], ``b`` [raw per s].
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import Site, earth_rate_enu, normal_gravity
from inertest.equipment import rate_table as table
from inertest.errors import DataError, IdentifiabilityError, InputError
from inertest.estimation.least_squares import weighted_least_squares
from inertest.models import rate_gyro, triad
from inertest.models.imu import ImuCalibration
from inertest.models.triad import AXES, decompose
from inertest.plan import Instrument, Plan
from inertest.results import Estimate, Identification, envelope, instrument_block
from inertest.units import ARCSEC_TO_RAD, DEG_PER_H_TO_RAD_PER_S, MICRORAD_TO_RAD

__all__ = ["AXES", "decompose"]  # re-exported from the triad model
E_NAMES = tuple(f"E_{a}{b}" for a in AXES for b in AXES)
BIAS_NAMES = tuple(f"dB_{a}" for a in AXES)
RAD_TO_ARCSEC = 1.0 / ARCSEC_TO_RAD
#: Parameters in SI: the scale factor is reported in the raw-SI unit (count/rad, 1).
_SI_SCALE = triad.ScaleUnit("raw SI per rad/s", 1.0, 1.0, None)


@dataclass(frozen=True)
class RotationRecord:
    """One navigation-mode segment: a turn of the table about a body axis, and the counts.

    Attributes
    ----------
    label : str
    C_nb0 : ndarray, shape (3, 3)
        Attitude at the start (columns: triad axes in ENU).
    axis : int
        Body axis turned about (0, 1, 2).
    direction : int
        +1 or -1 (right-handed about the body axis or not).
    time_s : ndarray, shape (n,)
        End of each sample interval from the segment start [s]; the start is t = 0.
    table_angle_rad : ndarray, shape (n,)
        Table angle turned since the start at ``time_s`` [rad], >= 0 (the table readout).
    counts : ndarray, shape (n, 3)
        Raw counts of each gyro in each sample interval [raw SI].
    """

    label: str
    C_nb0: NDArray[np.float64]
    axis: int
    direction: int
    time_s: NDArray[np.float64] = field(repr=False)
    table_angle_rad: NDArray[np.float64] = field(repr=False)
    counts: NDArray[np.float64] = field(repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.time_s, dtype=float)
        n = t.size
        if n < 2 or np.any(np.diff(np.concatenate([[0.0], t])) <= 0):
            raise InputError(
                f'segment "{self.label}": time_s must increase from above 0 (the start), with at '
                "least two samples"
            )
        if np.shape(self.counts) != (n, 3) or np.shape(self.table_angle_rad) != (n,):
            raise InputError(f'segment "{self.label}": counts must be (n, 3) and table angle (n,)')
        if self.direction not in (1, -1) or self.axis not in (0, 1, 2):
            raise InputError(f'segment "{self.label}": axis must be 0-2 and direction +-1')

    @property
    def dt(self) -> NDArray[np.float64]:
        """Sample intervals [s]."""
        return np.diff(np.concatenate([[0.0], self.time_s]))

    def table_attitude(self) -> Rotation:
        """``C_nb`` from the table readout at each sample."""
        return table.attitude_history(self.C_nb0, self.axis, self.direction, self.table_angle_rad)


@dataclass(frozen=True)
class IterationRecord:
    """One pass of the iteration: the attitude errors seen and the corrections made.

    Attributes
    ----------
    iteration : int
        1 for the first pass (with the initial calibration).
    attitude_error_rms_arcsec, attitude_error_max_arcsec : float
        Over all check instants, of ``|phi|`` [arcsec].
    end_error_arcsec : ndarray, shape (segments, 3)
        ``phi`` (E, N, U) at the end of each segment, after the whole turn [arcsec].
    scale_correction_ppm : ndarray, shape (3,)
        ``E_ii`` [ppm] (relative scale-factor error corrected).
    misalignment_correction_urad : ndarray, shape (6,)
        ``E_ij`` [urad], order of :data:`inertest.models.triad.MISALIGNMENT_NAMES`.
    bias_correction_deg_h : ndarray, shape (3,)
        ``dbeta`` [deg/h] (zero when the bias is not estimated).
    """

    iteration: int
    attitude_error_rms_arcsec: float
    attitude_error_max_arcsec: float
    end_error_arcsec: NDArray[np.float64]
    scale_correction_ppm: NDArray[np.float64]
    misalignment_correction_urad: NDArray[np.float64]
    bias_correction_deg_h: NDArray[np.float64]

    def to_dict(self) -> dict[str, object]:
        """JSON-ready, units in the keys."""
        return {
            "iteration": self.iteration,
            "attitude_error_rms_arcsec": self.attitude_error_rms_arcsec,
            "attitude_error_max_arcsec": self.attitude_error_max_arcsec,
            "end_error_arcsec": self.end_error_arcsec.tolist(),
            "scale_correction_ppm": self.scale_correction_ppm.tolist(),
            "misalignment_correction_urad": self.misalignment_correction_urad.tolist(),
            "bias_correction_deg_h": self.bias_correction_deg_h.tolist(),
        }


@dataclass(frozen=True)
class NavigationCalibrationResult:
    """Outcome of :func:`iterate_calibration`.

    Attributes
    ----------
    forward : ndarray, shape (3, 3)
        Final ``A = K (I + M)`` [raw SI per rad/s].
    offset : ndarray, shape (3,)
        Final ``b`` [raw SI per s].
    initial_forward, initial_offset : ndarray
        The starting calibration.
    history : tuple of IterationRecord
    converged : bool
        The last correction was below the tolerance.
    scale, misalignment_rad, bias_rad_s : ndarray
        ``K`` (3,) [raw SI per rad/s], ``M`` off-diagonals (6,) [rad], ``B = A^-1 b`` (3,)
        [rad/s] of the final calibration.
    scale_std, misalignment_std_rad, bias_std_rad_s : ndarray
        Standard uncertainties from the last least-squares pass (white rate noise); the bias std
        is NaN when the bias was not estimated.
    noise_arcsec : float
        Scatter of the attitude-error increments between check instants [arcsec].
    dof : int
    covariance : ndarray, shape (12, 12)
        Covariance of ``K`` [raw SI per rad/s], ``M`` [urad], ``B`` [deg/h] (the bias rows and
        columns zero when the bias was not estimated).
    """

    forward: NDArray[np.float64]
    offset: NDArray[np.float64]
    initial_forward: NDArray[np.float64]
    initial_offset: NDArray[np.float64]
    history: tuple[IterationRecord, ...]
    converged: bool
    scale: NDArray[np.float64]
    misalignment_rad: NDArray[np.float64]
    bias_rad_s: NDArray[np.float64]
    scale_std: NDArray[np.float64]
    misalignment_std_rad: NDArray[np.float64]
    bias_std_rad_s: NDArray[np.float64]
    noise_arcsec: float
    dof: int
    covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros((12, 12)),
                                            repr=False)


def cumulative_rotation(increments: Rotation) -> Rotation:
    """Prefix products ``R_1, R_1 R_2, ..., R_1 ... R_n`` (Hillis-Steele scan, log2 n passes)."""
    q = increments
    n = len(q)
    shift = 1
    while shift < n:
        q = Rotation.concatenate([q[:shift], q[:-shift] * q[shift:]])
        shift *= 2
    return q


def integrate_attitude(
    record: RotationRecord, increments_rad: NDArray[np.float64], latitude_rad: float
) -> Rotation:
    """Navigation attitude ``C_nb`` at each sample from calibrated body increments [rad].

    Starts at the table's attitude ``C_nb0``; local-level (ENU) frame turning with the Earth.
    """
    d = np.asarray(increments_rad, dtype=float)
    prev = np.vstack([np.zeros((1, 3)), d[:-1]])
    phi = d + np.cross(prev, d) / 12.0  # two-sample coning correction
    body = cumulative_rotation(Rotation.from_rotvec(phi))
    nav = Rotation.from_rotvec(-np.outer(record.time_s, earth_rate_enu(latitude_rad)))
    return nav * Rotation.from_matrix(record.C_nb0) * body


def _check_instants(record: RotationRecord, interval_s: float) -> NDArray[np.intp]:
    t = record.time_s
    marks = np.arange(interval_s, t[-1] + 1e-12, interval_s)
    idx = np.unique(np.clip(np.searchsorted(t, marks - 1e-9), 0, t.size - 1))
    if idx.size == 0 or idx[-1] != t.size - 1:
        idx = np.append(idx, t.size - 1)
    return idx


def _check_during_turns(records: Sequence[RotationRecord], interval_s: float) -> None:
    """Misalignment errors turn with the body and cancel over a whole turn: compare during it."""
    seen = set()
    for rec in records:
        ang = rec.table_angle_rad[_check_instants(rec, interval_s)]
        full = rec.table_angle_rad.max()
        if np.any((ang > 0.125 * full) & (ang < 0.875 * full)):
            seen.add(rec.axis)
    for j in sorted({rec.axis for rec in records} - seen):
        a = AXES[j]
        turn_s = min(float(np.ptp(rec.time_s[(rec.table_angle_rad > 0)
                                             & (rec.table_angle_rad < rec.table_angle_rad.max())]))
                     for rec in records if rec.axis == j)
        others = ", ".join(f"M_{c}{a}" for c in AXES if c != a)
        raise IdentifiabilityError(
            f"no attitude comparison during the turns about {a}: the misalignments {others} "
            "cannot be found from attitudes at rest (their error turns with the body and cancels "
            f"over a whole turn); set check_interval_s below {turn_s / 4:.3g} s"
        )


def _errors_and_design(
    records: Sequence[RotationRecord], A: NDArray, b: NDArray, latitude_rad: float,
    interval_s: float, estimate_bias: bool,
) -> tuple[NDArray, NDArray, list[NDArray], NDArray]:
    """Increments of the attitude error between checks, their design, per-segment errors."""
    rows_y, rows_H, per_segment, all_err = [], [], [], []
    A_inv = np.linalg.inv(A)
    for rec in records:
        dt = rec.dt
        inc = (rec.counts - np.outer(dt, b)) @ A_inv.T  # calibrated increments [rad]
        nav = integrate_attitude(rec, inc, latitude_rad)
        truth = rec.table_attitude()
        idx = _check_instants(rec, interval_s)
        err = (nav[idx] * truth[idx].inv()).as_rotvec()
        per_segment.append(err)
        all_err.append(err)
        # First order: phi(t_k) = sum_{i<=k} C_nb(t_i) (E dtheta_i + dbeta dt_i).
        C = truth.as_matrix()  # (n, 3, 3)
        terms = np.einsum("nra,nb->nrab", C, inc).reshape(len(dt), 3, 9)
        if estimate_bias:
            terms = np.concatenate([terms, C * dt[:, None, None]], axis=2)
        cum = np.cumsum(terms, axis=0)[idx]
        d_err = np.diff(np.vstack([np.zeros((1, 3)), err]), axis=0)
        d_H = np.diff(np.concatenate([np.zeros((1, *cum.shape[1:])), cum]), axis=0)
        rows_y.append(d_err.reshape(-1))
        rows_H.append(d_H.reshape(-1, cum.shape[2]))
    return np.concatenate(rows_y), np.vstack(rows_H), per_segment, np.vstack(all_err)


def _check_turns(records: Sequence[RotationRecord]) -> None:
    """Column j of E is excited only by turns about j (the Earth rate is far too small)."""
    turned = {rec.axis for rec in records}
    for j, a in enumerate(AXES):
        if j not in turned:
            others = ", ".join(f"M_{c}{a}" for c in AXES if c != a)
            raise IdentifiabilityError(
                f"no navigation-mode rotation about {a}: the scale factor K_{a} and the "
                f"misalignments of {a} rate into the other gyros ({others}) cannot be corrected; "
                f"add a 360-degree rotation about {a}"
            )


def _check_labels(records: Sequence[RotationRecord], A: NDArray, b: NDArray) -> None:
    """The calibrated gyros must see each turn about the labelled axis, in its direction."""
    A_inv = np.linalg.inv(A)
    for rec in records:
        total = A_inv @ (rec.counts.sum(axis=0) - b * rec.time_s[-1])
        expect = np.zeros(3)
        expect[rec.axis] = rec.direction * rec.table_angle_rad[-1]
        # Half the turn: far above any usable initial calibration's error, far below a
        # swapped axis (sqrt(2) turns) or a reversed direction (two turns).
        if np.linalg.norm(total - expect) > 0.5 * max(abs(rec.table_angle_rad[-1]), 1e-3):
            seen = ", ".join(f"{np.degrees(v):+.1f}" for v in total)
            turned = np.degrees(expect[rec.axis])
            raise DataError(
                f'segment "{rec.label}": the table turned {turned:+.1f} deg about '
                f"{AXES[rec.axis]}, but the gyros (with the initial calibration) turned "
                f"({seen}) deg about x, y, z: check the axis and direction labels, the counts "
                "columns, or the initial calibration"
            )


def _explain_rank(records: Sequence[RotationRecord], estimate_bias: bool) -> None:
    _check_turns(records)
    if estimate_bias:
        raise IdentifiabilityError(
            "the segments do not separate the bias from the scale factors (each segment turns "
            "at a constant rate for its whole length in one direction); add time at rest before "
            "or after the turns, turn both ways, or do not estimate the bias"
        )
    raise IdentifiabilityError("the navigation-mode segments do not determine the corrections")


def iterate_calibration(
    records: Sequence[RotationRecord],
    forward: ArrayLike,
    offset: ArrayLike,
    *,
    latitude_rad: float,
    check_interval_s: float = 1.0,
    estimate_bias: bool = True,
    max_iterations: int = 10,
    tolerance: float = 1e-9,
) -> NavigationCalibrationResult:
    """Refine a gyro-triad calibration by navigating through known 360-degree rotations.

    Parameters
    ----------
    records : sequence of RotationRecord
        The navigation-mode segments (raw counts and table angles).
    forward, offset : array_like
        Initial ``A = K (I + M)`` (3, 3) [raw SI per rad/s] and ``b`` (3,) [raw SI per s], e.g.
        from the 360-degree rotation test.
    latitude_rad : float
    check_interval_s : float
        Spacing of the attitude comparisons [s] (the seed's monitor reports every 10 s).
    estimate_bias : bool
        Also correct the bias (the seed fits it during alignment instead).
    max_iterations : int
    tolerance : float
        Stop when every correction ``|E_ij|`` [-] and ``|dbeta| * 1 s`` [rad] is below this.

    Returns
    -------
    NavigationCalibrationResult
        The refined calibration and the history of errors and corrections per iteration.

    Raises
    ------
    IdentifiabilityError
        An axis is never turned about, or the bias cannot be separated.
    """
    if not records:
        raise InputError("navigation-mode calibration needs at least one rotation segment")
    if not np.isfinite(check_interval_s) or check_interval_s <= 0:
        raise InputError(f"check_interval_s must be positive, got {check_interval_s}")
    _check_turns(records)
    _check_during_turns(records, check_interval_s)
    A = np.array(forward, dtype=float)
    b = np.array(offset, dtype=float)
    _check_labels(records, A, b)
    A0, b0 = A.copy(), b.copy()
    history: list[IterationRecord] = []
    converged = False
    fit = None
    A_prev, b_prev = A, b
    for it in range(1, max_iterations + 1):
        y, H, per_seg, errs = _errors_and_design(records, A, b, latitude_rad, check_interval_s,
                                                 estimate_bias)
        fit = weighted_least_squares(H, y)
        if fit.rank < H.shape[1]:
            _explain_rank(records, estimate_bias)
        E = fit.x[:9].reshape(3, 3)
        dbeta = fit.x[9:12] if estimate_bias else np.zeros(3)
        mag = np.linalg.norm(errs, axis=1) * RAD_TO_ARCSEC
        history.append(IterationRecord(
            iteration=it,
            attitude_error_rms_arcsec=float(np.sqrt(np.mean(mag**2))),
            attitude_error_max_arcsec=float(mag.max()),
            end_error_arcsec=np.array([e[-1] for e in per_seg]) * RAD_TO_ARCSEC,
            scale_correction_ppm=np.diag(E) * 1e6,
            misalignment_correction_urad=triad.misalignment_values(E) / MICRORAD_TO_RAD,
            bias_correction_deg_h=dbeta / DEG_PER_H_TO_RAD_PER_S,
        ))
        A_prev, b_prev = A, b
        b = b + A @ dbeta
        A = A @ (np.eye(3) + E)
        if max(np.max(np.abs(E)), np.max(np.abs(dbeta))) < tolerance:
            converged = True
            break
    assert fit is not None
    p = fit.x
    cov = fit.covariance

    # The last pass corrected (A_prev, b_prev) by x = [E.ravel(), (dbeta)]: the triad model's
    # p = [S.ravel(), b] with S = A_prev (I + E), b = b_prev + A_prev dbeta is linear in x,
    # dp/dx = [[kron(A_prev, I), 0], [0, A_prev]]; then the model's Jacobian to (K, M, B).
    L = np.zeros((12, p.size))
    L[:9, :9] = np.kron(A_prev, np.eye(3))
    if estimate_bias:
        L[9:, 9:12] = A_prev
    p_model = triad.stack_parameters(A_prev @ (np.eye(3) + E), b_prev + A_prev @ dbeta)
    _, cov_eng = triad.propagate(p_model, L @ cov @ L.T, "gyroscope", _SI_SCALE)
    _, b_si = triad.bias_unit("gyroscope")
    std = np.sqrt(np.clip(np.diag(cov_eng), 0.0, None)) * np.repeat(
        [1.0, MICRORAD_TO_RAD, b_si], [3, 6, 3])
    k, m, bias = decompose(A, b)
    return NavigationCalibrationResult(
        forward=A, offset=b, initial_forward=A0, initial_offset=b0,
        history=tuple(history), converged=converged,
        scale=np.real(k), misalignment_rad=np.real(m), bias_rad_s=np.real(bias),
        scale_std=std[:3], misalignment_std_rad=std[3:9],
        bias_std_rad_s=std[9:12] if estimate_bias else np.full(3, np.nan),
        noise_arcsec=float(fit.sigma * RAD_TO_ARCSEC), dof=fit.dof, covariance=cov_eng,
    )


@dataclass(frozen=True)
class NavigationCalibration:
    """A gyro triad calibrated in navigation mode: the result of :func:`calibrate`.

    Attributes
    ----------
    site_latitude_deg, site_gravity_m_s2 : float
        Where the turns were run [deg], [m/s^2].
    instrument : Instrument
        The triad (its output unit sets the scale factor's unit).
    identification : Identification
        ``K_i`` [scale unit], ``M_ij`` [urad] and, when estimated, ``B_i`` [deg/h], with their
        covariance; the noise is the scatter of the attitude-error increments.
    calibration : ImuCalibration
        The refined correction (JSON ``calibration`` block, for ``inertest apply``).
    iteration : NavigationCalibrationResult
        The iterations in SI.
    scale_unit : str
        Unit of ``K_i``.
    """

    site_latitude_deg: float
    site_gravity_m_s2: float
    instrument: Instrument
    identification: Identification
    calibration: ImuCalibration
    iteration: NavigationCalibrationResult
    scale_unit: str

    kind = "navigation-calibration"

    @property
    def coefficients(self) -> dict[str, Estimate]:
        """The identifiable coefficients."""
        return self.identification.coefficients

    def to_pandas(self) -> object:
        """Coefficients as a DataFrame (:meth:`Identification.to_pandas`)."""
        return self.identification.to_pandas()

    def covariance_to_pandas(self) -> object:
        """Named covariance as a DataFrame (:meth:`Identification.covariance_to_pandas`)."""
        return self.identification.covariance_to_pandas()

    def to_dict(self) -> dict[str, object]:
        """The ``navigation-calibration`` result envelope."""
        it = self.iteration
        return envelope(
            self.kind,
            site={"latitude_deg": self.site_latitude_deg, "gravity_m_s2": self.site_gravity_m_s2},
            instrument=instrument_block(self.instrument),
            identification=self.identification.to_dict(),
            result={"converged": it.converged, "iterations": [h.to_dict() for h in it.history],
                    "noise": {"sigma": it.noise_arcsec, "unit": "arcsec per check interval"},
                    "dof": it.dof, "calibration": self.calibration.to_dict()})


def calibrate(
    plan: Plan, data: Mapping[str, object], initial: triad.TriadCalibration, *,
    check_interval_s: float = 1.0, estimate_bias: bool = True, max_iterations: int = 10,
) -> NavigationCalibration:
    """Refine a gyro-triad calibration by navigating through the turns in ``data``.

    Parameters
    ----------
    plan : Plan
        A ``gyro-triad-rotation`` plan (site, instrument).
    data : mapping
        The time series of the turns (:data:`NAV_COLUMNS`), raw counts in the plan's unit.
    initial : TriadCalibration
        The starting gyro calibration (raw unit per second to rad/s), e.g. of the 360-degree
        rotation test.
    check_interval_s, estimate_bias, max_iterations
        As :func:`iterate_calibration`.

    Returns
    -------
    NavigationCalibration
        With the identification in engineering units (its scale-factor unit from the plan's
        output) and the refined calibration.
    """
    per_si = rate_gyro.raw_rate_per_si(plan.instrument.output_unit)
    records = records_from_columns(data, raw_per_si=per_si)  # type: ignore[arg-type]
    it = iterate_calibration(records, initial.forward / per_si, initial.offset / per_si,
                             latitude_rad=plan.site.latitude_rad,
                             check_interval_s=check_interval_s, estimate_bias=estimate_bias,
                             max_iterations=max_iterations)
    raw_unit = rate_gyro.raw_rate_unit(plan.instrument.output_unit)
    su = triad.scale_unit(raw_unit, "gyroscope")
    final = triad.calibration_from_parameters(triad.stack_parameters(it.forward, it.offset),
                                              sensor="gyroscope", scale=su, raw_unit=raw_unit)
    b_unit, b_si = triad.bias_unit("gyroscope")
    names = [*triad.SCALE_NAMES, *triad.MISALIGNMENT_NAMES]
    values = [*(it.scale / su.si_per_unit), *(it.misalignment_rad / MICRORAD_TO_RAD)]
    units = [su.unit] * 3 + [triad.MISALIGNMENT_UNIT] * 6
    D = np.r_[np.full(3, 1.0 / su.si_per_unit), np.ones(9)]
    cov = it.covariance * np.outer(D, D)
    not_sep: tuple[str, ...] = ()
    if estimate_bias:
        names += list(triad.BIAS_NAMES)
        values += list(it.bias_rad_s / b_si)
        units += [b_unit] * 3
    else:
        cov = cov[:9, :9]
        not_sep = (f"biases {', '.join(triad.BIAS_NAMES)}: kept at the initial calibration "
                   "(not estimated)",)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    ident = Identification(
        coefficients={n: Estimate(n, float(v), float(e), u)
                      for n, v, e, u in zip(names, values, std, units, strict=True)},
        combinations=(), not_separable=not_sep, covariance=cov, names=tuple(names),
        noise_sigma=it.noise_arcsec, noise_unit="arcsec per check interval",
        sigma_from_residuals=True, dof=it.dof, rank=len(names), residuals=np.zeros(0))
    return NavigationCalibration(
        site_latitude_deg=plan.site.latitude_deg, site_gravity_m_s2=plan.site.gravity_m_s2,
        instrument=plan.instrument, identification=ident,
        calibration=ImuCalibration(gyroscope=final), iteration=it, scale_unit=su.unit)


def simulate_segment(
    label: str,
    C_nb0: ArrayLike,
    axis: int,
    direction: int,
    profile: table.RotationProfile,
    *,
    forward: ArrayLike,
    offset: ArrayLike,
    latitude_rad: float,
    rest_before_s: float = 5.0,
    rest_after_s: float = 5.0,
    sample_rate_hz: float = 100.0,
    noise: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> RotationRecord:
    """Counts of a virtual triad ``raw = A w + b`` through one turn, sample by sample.

    The table's motion is :class:`~inertest.equipment.rate_table.Turns` (one turn after
    ``rest_before_s``). The body rate is the table rate plus the Earth rate; the table part of
    each sample's increment comes exactly from the profile's angle, the Earth part
    ``C_ni(t)^T W_ie_n`` by 3-point Gauss-Legendre over the interval. ``noise``: white noise of each
    sample's count [raw SI], i.e. angle random walk.
    """
    C0 = np.asarray(C_nb0, dtype=float)
    site = Site(latitude_rad, float(normal_gravity(latitude_rad)))
    motion = table.Turns(site, {label: (C0, axis, direction)}, profile, rest_before_s)
    total = rest_before_s + profile.duration_s + rest_after_s
    fs = float(sample_rate_hz)
    n = int(np.ceil(total * fs - 1e-9))
    t = np.arange(1, n + 1) / fs
    t0 = t - 1.0 / fs
    ang = profile.angle(t - rest_before_s)
    # Table part exactly from the angle; the Earth part by 3-point Gauss-Legendre per interval.
    inc = np.zeros((n, 3))
    inc[:, axis] = direction * (ang - profile.angle(t0 - rest_before_s))
    w_n = earth_rate_enu(latitude_rad)
    x, wq = np.polynomial.legendre.leggauss(3)
    for xi, wi in zip(x, wq, strict=True):
        C_ni = motion.inputs(label, t0 + 0.5 * (xi + 1) / fs).C_ni
        inc += 0.5 * wi / fs * np.einsum("kji,j->ki", C_ni, w_n)  # C_ni^T W_ie_n
    A = np.asarray(forward, dtype=float)
    counts = inc @ A.T + np.outer(np.full(n, 1.0 / fs), np.asarray(offset, dtype=float))
    if noise:
        counts = counts + np.random.default_rng(rng).normal(0.0, noise, size=counts.shape)
    return RotationRecord(label=label, C_nb0=C0, axis=axis, direction=direction, time_s=t,
                          table_angle_rad=ang, counts=counts)


def simulate_segments(
    turns: Sequence[tuple[str, NDArray[np.float64], int, int]],
    profile: table.RotationProfile,
    *,
    forward: ArrayLike,
    offset: ArrayLike,
    latitude_rad: float,
    rest_s: float = 5.0,
    sample_rate_hz: float = 100.0,
    noise: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> list[RotationRecord]:
    """:func:`simulate_segment` for each ``(label, C_nb0, axis, direction)``, rest on both sides."""
    gen = np.random.default_rng(rng)
    return [
        simulate_segment(label, C0, axis, d, profile, forward=forward, offset=offset,
                         latitude_rad=latitude_rad, rest_before_s=rest_s, rest_after_s=rest_s,
                         sample_rate_hz=sample_rate_hz, noise=noise, rng=gen)
        for label, C0, axis, d in turns
    ]


#: Columns of a navigation-mode data file, in order.
NAV_COLUMNS = ("segment", "attitude", "axis", "direction", "time_s", "table_angle_deg",
               "counts_x", "counts_y", "counts_z")


def records_to_columns(
    records: Sequence[RotationRecord], attitudes: Sequence[str], *, raw_per_si: float
) -> dict[str, NDArray]:
    """Data-file columns (:data:`NAV_COLUMNS`) of segments; ``attitudes`` their start letters."""
    cols: dict[str, list[NDArray]] = {k: [] for k in NAV_COLUMNS}
    for rec, att in zip(records, attitudes, strict=True):
        n = rec.time_s.size
        cols["segment"].append(np.full(n, rec.label))
        cols["attitude"].append(np.full(n, att))
        cols["axis"].append(np.full(n, AXES[rec.axis]))
        cols["direction"].append(np.full(n, float(rec.direction)))
        cols["time_s"].append(rec.time_s)
        cols["table_angle_deg"].append(np.degrees(rec.table_angle_rad))
        for j, a in enumerate(AXES):
            cols[f"counts_{a}"].append(rec.counts[:, j] * raw_per_si)
    return {k: np.concatenate(v) for k, v in cols.items()}


def records_from_columns(
    columns: Mapping[str, ArrayLike], *, raw_per_si: float
) -> list[RotationRecord]:
    """Segments from data-file columns (:data:`NAV_COLUMNS`), in order of first appearance.

    ``segment`` labels the rows of one turn; ``attitude``, ``axis`` and ``direction`` must be
    constant within it; ``time_s`` is the end of each sample interval from the segment start,
    ``table_angle_deg`` the table readout [deg] (>= 0, turned since the start) and
    ``counts_*`` the raw counts in each interval [count; output unit x s for rate outputs].
    """
    missing = [c for c in NAV_COLUMNS if c not in columns]
    if missing:
        raise DataError(
            f"navigation-mode data lacks column(s) {', '.join(missing)}; it needs "
            f"{', '.join(NAV_COLUMNS)}"
        )
    text = {c: np.asarray(columns[c]).astype(str) for c in ("segment", "attitude", "axis")}
    num = {}
    for c in NAV_COLUMNS[3:]:
        try:
            a = np.asarray(columns[c], dtype=float)
        except (TypeError, ValueError):
            raise DataError(f'column "{c}" must be numeric') from None
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise DataError(f'column "{c}" has NaN/inf (first at data row {bad[0] + 1})')
        num[c] = a
    labels, first = np.unique(text["segment"], return_index=True)
    out = []
    for lab in labels[np.argsort(first)]:
        rows = np.flatnonzero(text["segment"] == lab)
        for c in ("attitude", "axis"):
            if np.unique(text[c][rows]).size != 1:
                raise DataError(f'segment "{lab}": column {c} changes within the segment')
        if np.unique(num["direction"][rows]).size != 1:
            raise DataError(f'segment "{lab}": column direction changes within the segment')
        try:
            C0 = table.triad_attitude(text["attitude"][rows[0]])
            axis = table.axis_index(text["axis"][rows[0]])
            out.append(RotationRecord(
                label=str(lab), C_nb0=C0, axis=axis, direction=int(num["direction"][rows[0]]),
                time_s=num["time_s"][rows],
                table_angle_rad=np.radians(num["table_angle_deg"][rows]),
                counts=np.column_stack([num[f"counts_{a}"][rows] for a in AXES]) / raw_per_si,
            ))
        except InputError as exc:
            raise DataError(f'segment "{lab}": {exc}') from None
    return out
