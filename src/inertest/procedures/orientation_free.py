"""IMU calibration without known orientations: the multi-position method of Tedaldi et al.

Source: D. Tedaldi, A. Pretto, E. Menegatti, "A robust and easy to implement method for IMU
calibration without external equipments", ICRA 2014, pp. 3042-3049,
doi:10.1109/ICRA.2014.6907297 (reference implementation: A. Pretto's imu_tk, BSD). The IMU is
left still for ``T_init`` (about 50 s), then turned by hand into many attitudes (Tedaldi
recommend 36-50), each held still for a few seconds; nobody measures the attitudes.

Steps (every number SI inside; conventions of :mod:`inertest.models.triad`)
---------------------------------------------------------------------------
1. **Static intervals** (:func:`inertest.estimation.static_detection.detect_static_intervals`,
   Tedaldi Sec. III-C): the variance magnitude of the accelerometer over a ``window_s`` window
   below ``threshold_factor`` x that of the initial period; intervals shorter than
   ``min_interval_s`` dropped. Each interval's mean raw reading ``m_k`` is kept.
   ``threshold_factor = "auto"`` (Tedaldi Sec. IV; imu_tk tries k = 2..10): the detection and
   the accelerometer fit of step 2 are run for each k in :data:`AUTO_THRESHOLD_FACTORS` and
   the k with the lowest accelerometer residual variance ``sum r^2 / (m - 9)`` is kept (imu_tk
   compares the total cost; per degree of freedom, fewer intervals are not favoured by
   having fewer terms). Every candidate's count and residual is reported.
2. **Accelerometer** (Tedaldi Sec. III-A, cost function of the accelerometer): with the triad
   model ``raw = S u + b``, ``S = K (I + M)``, the specific force at rest has the magnitude of
   local gravity ``g`` (the plan's site), so ``S``, ``b`` minimise
   ``sum_k (|S^-1 (m_k - b)| - g)^2`` (scipy.optimize.least_squares, started from an
   algebraic ellipsoid fit of the ``m_k``, so no initial guess is needed).
   **Frame ambiguity.** ``|S^-1 (m - b)|`` is unchanged by ``S -> S R^T`` for any rotation
   ``R``: the norm fixes the accelerometer triad only up to a rotation of its reference frame,
   three of the nine entries of ``S``. The gauge is fixed as Tedaldi do (their misalignment
   matrix ``T^a`` is upper triangular; imu_tk sets the lower-left terms to zero):
   ``reference_axis = "z"`` (default): ``S`` upper triangular, ``M_yx = M_zx = M_zy = 0``: the
   z accelerometer defines the reference z axis and the y accelerometer lies in the y-z plane;
   ``reference_axis = "x"``: ``S`` lower triangular, ``M_xy = M_xz = M_yz = 0``: the x
   accelerometer defines x and y lies in the x-y plane. The three fixed misalignments are
   conventions, not measurements: they are not reported as estimates (``not_separable``).
   Nine parameters (3 K, 3 M, 3 b) need at least nine attitudes.
3. **Gyroscope** (Tedaldi Sec. III-B): bias ``b_g`` = mean raw gyro over the initial static
   period; ``S_g`` (all nine entries: the gyro is referred to the accelerometer frame of step
   2, so all six gyro misalignments are determined) minimises
   ``sum_k |C_k^T u_k - u_{k+1}|^2``, where ``u_k`` is the calibrated gravity direction
   (unit vector, body axes) of static interval k and ``C_k`` the body rotation from the end
   of interval k to the start of k+1, integrated from the calibrated rates
   ``w = S_g^-1 (raw - b_g)``: per sample step the rotation vector
   ``(w_j + w_{j+1}) dt / 2 + (w_j x w_{j+1}) dt^2 / 12`` (trapezoid with the two-sample coning
   term, second order like the RK4 quaternion integration of Tedaldi/imu_tk), composed with
   ``scipy.spatial.transform.Rotation``. Time steps from the data's ``t_s`` column when present.
   The Earth rate is not modelled (the initial-period bias holds its projection at the start
   attitude; over a 3 s turn it moves gravity by < 0.013 deg, below MEMS noise).
4. **Uncertainties** (:func:`joint_covariance`): both estimates are linearised in three
   independent noise sources: the noise of the static interval means (white, variance of
   each interval's samples / n), of the initial-period gyro bias, and the rotation noise of
   each integrated motion (angle random walk: the initial period's rate noise times the sum
   of the squared trapezoid weights). The accelerometer solution moves with the means; every
   gravity direction ``u_k`` moves with its own mean *and* with the accelerometer solution
   (an error shared by all of them); the gyro solution moves with the ``u_k``, the bias and
   the motion noise (implicit differentiation of its normal equations). The covariance of
   that one linear map holds both triads and their cross-covariance. The noise levels come
   from the residuals: the sample variances of the means are scaled by ``lambda`` and the
   angle random walk by ``mu`` so that each fit's expected residual sum of squares equals
   the observed one (the real Xsens recording: ``lambda`` ~ 14, ``mu`` ~ 30: model errors
   larger than white noise, hence larger and honest stds). Propagated to K, M, B by the
   triad model's Jacobian. Checked by Monte Carlo (tests: std / scatter in 0.8-1.25 for every
   coefficient; accelerometer-gyro correlations).

Identifiability. Fewer than nine static attitudes raise
:class:`~inertest.errors.IdentifiabilityError`; so does a design whose Jacobian is
numerically singular (attitudes too similar). Either message, and a note on a fit that
succeeds with poor coverage, says which attitudes are missing: for each axis direction
(+x up, x down, ...) the nearest attitude's angle; directions farther than
:data:`COVERAGE_ANGLE_DEG` are named ("no attitude with z down (nearest 75 deg away); add ...").

Data columns: ``acc_x, acc_y, acc_z`` [acc_unit], ``gyr_x, gyr_y, gyr_z`` [gyr_unit], one row
per sample at ``sample_rate_hz`` (a ``count`` gyro column is a rate reading per sample);
optional ``t_s`` [s]. The imu_tk text files (t, x, y, z per line, two files) are converted by
``examples/orientation_free/imu_tk_to_table.py``.

Results: ``Ka_*`` [count/(m/s^2) or 1], ``Ma_ij`` (the three of the gauge) [urad], ``Ba_*``
[mg], ``Kg_*`` [count/(deg/s) or 1], ``Mg_ij`` [urad], ``Bg_*`` [deg/h], the ``calibration``
block, the static intervals found and the checks: rms of ``|a| - g`` over the static intervals
and rms angle between each carried gravity direction and the next, before (plan's nominal
guesses) and after calibration.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import scipy.optimize
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from inertest.errors import DataError, IdentifiabilityError, PlanError
from inertest.estimation.static_detection import StaticDetection, detect_static_intervals
from inertest.models import triad
from inertest.models.imu import ImuCalibration
from inertest.models.triad import AXES
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure
from inertest.procedures.spec import check_sample_rate, check_time_gaps, require_columns
from inertest.results import Estimate, Identification
from inertest.results.triad import TriadEstimates, TriadResult
from inertest.units import ACCEL_UNITS, COUNT_UNITS, MILLI_G_TO_M_PER_S2, RATE_UNITS

KIND = "orientation-free"
ACC_COLUMNS = ("acc_x", "acc_y", "acc_z")
GYR_COLUMNS = ("gyr_x", "gyr_y", "gyr_z")
#: Fewest static attitudes: the accelerometer has nine parameters (Tedaldi recommend 36-50).
#: Threshold factors tried by ``threshold_factor = "auto"`` (Tedaldi Sec. IV, imu_tk: 2..10).
AUTO_THRESHOLD_FACTORS = (2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0)
MIN_ATTITUDES = 9
RECOMMENDED_ATTITUDES = 36
#: An axis direction (x up, x down, ...) farther than this from every attitude is "missing".
COVERAGE_ANGLE_DEG = 60.0
#: Column-scaled Jacobian condition number beyond which the design is taken as singular.
MAX_CONDITION = 1e7
#: Verdict tolerances of the checks: calibrated rms |a| - g [mg], rms carried angle [deg].
GRAVITY_TOLERANCE_MG = 10.0
TRANSPORT_TOLERANCE_DEG = 1.0
#: Entries of S left free by each gauge, and the misalignments the gauge fixes to zero.
_FREE = {"z": ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)),
         "x": ((0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (2, 2))}
_SPREAD = "add attitudes spread over the whole sphere"
_FIXED_MIS = {"z": ("M_yx", "M_zx", "M_zy"), "x": ("M_xy", "M_xz", "M_yz")}


def _prefixed(names: tuple[str, ...], letter: str) -> tuple[str, ...]:
    return tuple(f"{n[0]}{letter}{n[1:]}" for n in names)


@dataclass(frozen=True)
class OrientationFreeSpec:
    """Parameters of an orientation-free calibration (``[procedure]`` table).

    Attributes
    ----------
    sample_rate_hz : float
        [Hz].
    acc_unit, gyr_unit : str
        Units of the raw columns (``count`` or a specific-force / rate unit).
    init_duration_s : float
        Initial static period ``T_init`` [s]: detector threshold and gyro bias.
    threshold_factor : float or "auto"
        ``k`` of the detector threshold ``k varsigma_init`` [1] (Tedaldi: 2..10), or
        ``"auto"``: the k of :data:`AUTO_THRESHOLD_FACTORS` with the lowest accelerometer
        residual (module docstring, step 1).
    window_s : float
        Detector variance window [s].
    min_interval_s : float
        Shortest static interval kept [s].
    reference_axis : {"z", "x"}
        Gauge of the accelerometer frame (module docstring): ``z`` as Tedaldi/imu_tk.
    gyr_scale_guess : float or None
        Nominal gyro scale factor [count/(deg/s)] (start of the gyro fit and the "before"
        check); required for a count gyro, 1 for a physical unit.
    acc_scale_guess : float or None
        Nominal accelerometer scale factor [count/(m/s^2)] for the "before" check (default:
        the one common scale that makes the mean |a| = g).
    acc_bias_guess : float
        Nominal raw offset of every accelerometer channel [acc_unit] (e.g. 32768 for an
        offset-binary 16-bit output) for the "before" check and the coverage report.
    n_attitudes, static_s, motion_s : int, float, float
        Simulation only: attitudes after the initial period, time held at each, turn time.
    """

    kind: ClassVar[str] = KIND
    sample_rate_hz: float
    acc_unit: str = "count"
    gyr_unit: str = "count"
    init_duration_s: float = 50.0
    threshold_factor: float | str = 6.0
    window_s: float = 1.0
    min_interval_s: float = 1.0
    reference_axis: str = "z"
    gyr_scale_guess: float | None = None
    acc_scale_guess: float | None = None
    acc_bias_guess: float = 0.0
    n_attitudes: int = 40
    static_s: float = 4.0
    motion_s: float = 2.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> OrientationFreeSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        table = dict(params)
        auto = table.get("threshold_factor") == "auto"
        if auto:
            del table["threshold_factor"]
        kw = read_fields(table, FIELDS, f"[procedure] of kind {KIND}", ignore=("kind",))
        if auto:
            kw["threshold_factor"] = "auto"
        spec = cls(**kw)
        if spec.gyr_scale_guess is None and spec.gyr_unit not in RATE_UNITS:
            raise PlanError(
                f"[procedure] of kind {KIND} needs gyr_scale_guess [count/(deg/s)] for a "
                f"{spec.gyr_unit} gyro output (the nominal scale from the data sheet, e.g. "
                "109.2 for the Xsens MTi of imu_tk)")
        return spec

    @property
    def acc_scale(self) -> triad.ScaleUnit:
        """How the accelerometer scale factors are reported."""
        return triad.scale_unit(self.acc_unit, "accelerometer")

    @property
    def gyr_scale(self) -> triad.ScaleUnit:
        """How the gyro scale factors are reported (a count column: a rate reading)."""
        return triad.scale_unit(self.gyr_unit, "gyroscope")


FIELDS = (
    Field("sample_rate_hz", positive=True, unit="Hz", doc="sample rate in Hz"),
    Field("acc_unit", "text", default="count", choices=(*COUNT_UNITS, *ACCEL_UNITS)),
    Field("gyr_unit", "text", default="count", choices=(*COUNT_UNITS, *RATE_UNITS)),
    Field("init_duration_s", default=50.0, positive=True, unit="s",
          doc="initial static period"),
    Field("threshold_factor", default=6.0, positive=True,
          doc='detector threshold factor k, or "auto" (k = 2..10, lowest residual)'),
    Field("window_s", default=1.0, positive=True, unit="s", doc="detector window"),
    Field("min_interval_s", default=1.0, positive=True, unit="s",
          doc="shortest static interval"),
    Field("reference_axis", "text", default="z", choices=("z", "x"),
          doc="accelerometer axis that defines the frame"),
    Field("gyr_scale_guess", default=None, positive=True, unit="count/(deg/s)",
          doc="nominal gyro scale factor"),
    Field("acc_scale_guess", default=None, positive=True, unit="count/(m/s^2)",
          doc="nominal accelerometer scale factor"),
    Field("acc_bias_guess", default=0.0, unit="acc_unit", doc="nominal raw offset"),
    Field("n_attitudes", "integer", default=40, positive=True, doc="simulated attitudes"),
    Field("static_s", default=4.0, positive=True, unit="s", doc="simulated time per attitude"),
    Field("motion_s", default=2.0, positive=True, unit="s", doc="simulated turn time"),
)


@dataclass(frozen=True)
class ThresholdCandidate:
    """One factor tried by ``threshold_factor = "auto"``.

    Attributes
    ----------
    threshold_factor : float
        ``k`` [1].
    intervals : int
        Static intervals found with it.
    residual_rms_m_s2 : float
        ``sqrt(sum r^2 / (m - 9))`` of the accelerometer fit [m/s^2]; NaN when it has fewer
        than ten intervals or the fit is not identifiable.
    """

    threshold_factor: float
    intervals: int
    residual_rms_m_s2: float


@dataclass(frozen=True)
class StaticInterval:
    """One static attitude found by the detector.

    Attributes
    ----------
    start_s, end_s : float
        Times of its first and last sample [s] (from ``t_s``, else the sample index / rate).
    acc_mean, gyr_mean : ndarray, shape (3,)
        Mean raw readings [acc_unit], [gyr_unit].
    n : int
        Samples.
    """

    start_s: float
    end_s: float
    acc_mean: NDArray[np.float64]
    gyr_mean: NDArray[np.float64]
    n: int

    @property
    def duration_s(self) -> float:
        """``end_s - start_s`` [s]."""
        return self.end_s - self.start_s


@dataclass(frozen=True, kw_only=True)
class OrientationFreeResult(TriadResult):
    """Outcome of :func:`fit` (a :class:`~inertest.results.triad.TriadResult`).

    Attributes
    ----------
    intervals : tuple of StaticInterval
    detection : StaticDetection
    gravity_error_m_s2, gravity_error_before_m_s2 : ndarray, shape (m,)
        ``|a| - g`` of each interval mean after / before calibration [m/s^2].
    transport_angle_deg, transport_angle_before_deg : ndarray, shape (m - 1,)
        Angle between each gravity direction carried by the integrated gyro and the next
        interval's [deg], calibrated gyro / nominal gyro (same gravity directions).
    reference_axis : str
        The accelerometer gauge (module docstring).
    noise_scales : tuple of float
        ``(lambda, mu)`` of :class:`NoisePropagation`: residual-estimated over white-noise
        predicted variance of the interval means and of the integrated motions [1].
    threshold_search : tuple of ThresholdCandidate
        With ``threshold_factor = "auto"``: every factor tried (the chosen one is
        ``detection.threshold_factor``); empty otherwise.

    Notes
    -----
    ``identification.covariance`` is the joint covariance of all coefficients (accelerometer
    then gyro, :func:`joint_covariance`), with the accelerometer-gyro cross block;
    :meth:`details` reports that block as ``acc_gyro_cross_covariance``.
    """

    intervals: tuple[StaticInterval, ...] = field(repr=False)
    detection: StaticDetection = field(repr=False)
    gravity_error_m_s2: NDArray[np.float64] = field(repr=False)
    gravity_error_before_m_s2: NDArray[np.float64] = field(repr=False)
    transport_angle_deg: NDArray[np.float64] = field(repr=False)
    transport_angle_before_deg: NDArray[np.float64] = field(repr=False)
    reference_axis: str = "z"
    noise_scales: tuple[float, float] = (1.0, 1.0)
    threshold_search: tuple[ThresholdCandidate, ...] = ()
    procedure: str = KIND

    def summary(self) -> dict[str, dict[str, float | str]]:
        """RMS of both checks before/after: ``{check: {"before", "after", "unit"}}``."""
        def rms(x: NDArray[np.float64]) -> float:
            return float(np.sqrt(np.mean(np.square(x))))
        return {
            "gravity_norm_rms": {"before": rms(self.gravity_error_before_m_s2) /
                                 MILLI_G_TO_M_PER_S2,
                                 "after": rms(self.gravity_error_m_s2) / MILLI_G_TO_M_PER_S2,
                                 "unit": "mg"},
            "gravity_transport_rms": {"before": rms(self.transport_angle_before_deg),
                                      "after": rms(self.transport_angle_deg), "unit": "deg"},
        }

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` in the envelope)."""
        d = super().details()
        tri = d["triads"]
        if isinstance(tri, dict) and "accelerometer" in tri:  # no numbers for the gauge terms
            acc = dict(tri["accelerometer"])
            acc["misalignment"] = {k: v for k, v in acc["misalignment"].items()
                                   if k not in _FIXED_MIS[self.reference_axis]}
            acc.pop("covariance", None)
            tri["accelerometer"] = acc
        d["reference_axis"] = self.reference_axis
        detector: dict[str, object] = {
            "threshold_factor": self.detection.threshold_factor,
            "threshold": {"value": self.detection.threshold, "unit": "raw^2"},
            "init_variance_magnitude": {"value": self.detection.init_variance_magnitude,
                                        "unit": "raw^2"},
            "window": {"value": self.detection.window, "unit": "sample"},
            "short_intervals_dropped": self.detection.n_short,
            "threshold_choice": "auto" if self.threshold_search else "given",
        }
        if self.threshold_search:
            detector["candidates"] = [
                {"threshold_factor": c.threshold_factor, "intervals": c.intervals,
                 "acc_residual_rms": {"value": c.residual_rms_m_s2 / MILLI_G_TO_M_PER_S2
                                      if np.isfinite(c.residual_rms_m_s2) else None,
                                      "unit": "mg"}}
                for c in self.threshold_search]
        d["detector"] = detector
        g = self.site_gravity_m_s2
        d["static_intervals"] = [
            {"start": {"value": iv.start_s, "unit": "s"}, "end": {"value": iv.end_s, "unit": "s"},
             "duration": {"value": iv.duration_s, "unit": "s"},
             "mean_abs_a": {"value": g + float(e), "unit": "m/s^2"}}
            for iv, e in zip(self.intervals, self.gravity_error_m_s2, strict=True)]
        d["summary"] = self.summary()
        ident = self.identification
        names = list(ident.names)
        ia = [i for i, nm in enumerate(names) if nm[1] == "a"]
        ig = [i for i, nm in enumerate(names) if nm[1] == "g"]
        co = self.coefficients
        d["acc_gyro_cross_covariance"] = {
            "rows": [names[i] for i in ia], "columns": [names[j] for j in ig],
            "value": ident.covariance[np.ix_(ia, ig)].tolist(),
            "unit": "row unit x column unit",
            "units": {"rows": [co[names[i]].unit for i in ia],
                      "columns": [co[names[j]].unit for j in ig]},
        }
        d["noise_scales"] = {"acc_interval_means": self.noise_scales[0],
                             "gyro_motions": self.noise_scales[1], "unit": "1"}
        return d

    def to_dict(self) -> dict[str, object]:
        """The envelope, with the two physical checks appended to ``checks``."""
        doc = super().to_dict()
        s = self.summary()
        checks = doc["checks"]
        assert isinstance(checks, list)
        g, t = s["gravity_norm_rms"], s["gravity_transport_rms"]
        checks.append({"name": "static |a| = g", "verdict": "pass" if float(g["after"]) <
                       GRAVITY_TOLERANCE_MG else "fail", "tolerance": GRAVITY_TOLERANCE_MG, **g})
        checks.append({"name": "gyro carries gravity to the next attitude",
                       "verdict": "pass" if float(t["after"]) < TRANSPORT_TOLERANCE_DEG
                       else "fail", "tolerance": TRANSPORT_TOLERANCE_DEG, **t})
        return doc


# ---------------------------------------------------------------------------------------------
# accelerometer


def ellipsoid_start(means: NDArray[np.float64], g: float, axis: str
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """``S`` (triangular in the gauge) and ``b`` from an algebraic ellipsoid fit, or None.

    The quadric ``m^T A m + c^T m + d = 0`` through the interval means (smallest singular
    vector, points centred and scaled first) gives the centre ``b = -A^-1 c / 2`` and
    ``S^-T S^-1 = A / (g^2 (b^T A b - d))``; its Cholesky factor is ``S^-1`` up to ``g``.
    None when the quadric is not an ellipsoid (attitudes too few or too similar).
    """
    c0 = means.mean(axis=0)
    sc = float(np.std(means - c0)) or 1.0
    x = (means - c0) / sc
    D = np.column_stack([x[:, 0]**2, x[:, 1]**2, x[:, 2]**2, 2 * x[:, 0] * x[:, 1],
                         2 * x[:, 0] * x[:, 2], 2 * x[:, 1] * x[:, 2], x, np.ones(len(x))])
    _, sv, vt = np.linalg.svd(D, full_matrices=False)
    if sv[-2] < 1e-9 * sv[0]:
        return None
    v = vt[-1]
    A = np.array([[v[0], v[3], v[4]], [v[3], v[1], v[5]], [v[4], v[5], v[2]]])
    try:
        centre = -0.5 * np.linalg.solve(A, v[6:9])
    except np.linalg.LinAlgError:
        return None
    rhs = centre @ A @ centre - v[9]
    Q = A / rhs
    if not np.all(np.linalg.eigvalsh(Q) > 0):
        return None
    P = np.eye(3)[::-1]
    if axis == "z":  # S^-1 upper triangular: Q = U^T U
        T = np.linalg.cholesky(Q).T * g
    else:  # S^-1 lower triangular: Q = (P L^T P)^T (P L^T P)
        T = P @ np.linalg.cholesky(P @ Q @ P).T @ P * g
    return (np.asarray(np.linalg.inv(T) * sc, dtype=float),
            np.asarray(c0 + centre * sc, dtype=float))  # back to raw units


def _unpack_acc(theta: NDArray, axis: str) -> tuple[NDArray, NDArray]:
    S = np.zeros((3, 3), dtype=theta.dtype)
    for k, (i, j) in enumerate(_FREE[axis]):
        S[i, j] = theta[k]
    return S, theta[6:9]


def fit_accelerometer(
    means: NDArray[np.float64], g: float, axis: str, *, centre: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]:
    """``p = [S.ravel(), b]`` [raw SI], its covariance (12x12), residuals [m/s^2], cond.

    Minimises ``sum (|S^-1 (m_k - b)| - g)^2`` over the gauge's six entries of ``S`` and
    ``b`` (Tedaldi Sec. III-A). Raises :class:`IdentifiabilityError` (with the coverage
    message) when the attitudes cannot determine them.
    """
    start = ellipsoid_start(means, g, axis)
    if start is None:
        raise IdentifiabilityError(
            f"the {len(means)} static attitudes do not determine the accelerometer (their "
            "readings do not span an ellipsoid: attitudes too similar); "
            + (coverage_message(means, None, axis, centre=centre) or _SPREAD))
    S0, b0 = start
    theta0 = np.r_[[S0[i, j] for i, j in _FREE[axis]], b0]

    def resid(theta: NDArray) -> NDArray:
        S, b = _unpack_acc(theta, axis)
        u = np.linalg.solve(S, (means - b).T).T
        return np.asarray(np.linalg.norm(u, axis=1) - g)

    sol = scipy.optimize.least_squares(resid, theta0, x_scale="jac", method="lm",
                                       xtol=1e-15, ftol=1e-15, gtol=1e-15)
    J = sol.jac
    col = np.linalg.norm(J, axis=0)
    cond = float(np.linalg.cond(J / np.where(col > 0, col, 1.0)))
    S, b = _unpack_acc(sol.x, axis)
    if not np.isfinite(cond) or cond > MAX_CONDITION:
        raise IdentifiabilityError(
            f"the {len(means)} static attitudes are too similar to determine the "
            f"accelerometer (design condition number {cond:.3g}); "
            + (coverage_message(means, (S, b), axis) or _SPREAD))
    r = sol.fun
    dof = len(means) - 9
    s2 = float(r @ r) / dof if dof > 0 else 0.0
    cov_t = s2 * np.linalg.pinv(J.T @ J)
    E = np.zeros((12, 9))  # p = E theta (the free entries of S, then b)
    for k, (i, j) in enumerate(_FREE[axis]):
        E[3 * i + j, k] = 1.0
    E[9:, 6:] = np.eye(3)
    return triad.stack_parameters(S, b), E @ cov_t @ E.T, r, cond


def coverage(directions: NDArray[np.float64]) -> list[tuple[str, float]]:
    """For +x, -x, +y, -y, +z, -z (up): the angle to the nearest attitude [deg]."""
    out = []
    for i, a in enumerate(AXES):
        for sign, word in ((1, "up"), (-1, "down")):
            c = np.clip(np.max(sign * directions[:, i]), -1.0, 1.0)
            out.append((f"{a} {word}", float(np.degrees(np.arccos(c)))))
    return out


def coverage_message(means: NDArray[np.float64],
                     model: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
                     axis: str, *, centre: float = 0.0) -> str | None:
    """Which attitudes are missing ("no attitude with z down ...; add ..."), or None.

    The gravity direction of each attitude comes from ``model`` (``S``, ``b``) when given,
    else from the raw means less ``centre`` (the plan's ``acc_bias_guess``).
    """
    if model is not None:
        u = np.linalg.solve(model[0], (means - model[1]).T).T
    else:
        u = means - centre
    d = u / np.linalg.norm(u, axis=1, keepdims=True)
    missing = [(w, ang) for w, ang in coverage(d) if ang > COVERAGE_ANGLE_DEG]
    if not missing:
        return None
    which = ", ".join(f"{w} (nearest attitude {ang:.0f} deg away)" for w, ang in missing)
    return (f"no attitude with {which}; add attitudes with "
            f"{', '.join(w for w, _ in missing)} (each held still > min_interval_s), "
            f"{RECOMMENDED_ATTITUDES}-50 attitudes spread over the sphere in all")


# ---------------------------------------------------------------------------------------------
# gyroscope


def _step_rotvecs(rate: NDArray[np.float64], dt: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-step rotation vectors ``(w_j + w_{j+1}) dt/2 + (w_j x w_{j+1}) dt^2/12`` (n-1, 3)."""
    w0, w1 = rate[:-1], rate[1:]
    return np.asarray(0.5 * (w0 + w1) * dt[:, None] + np.cross(w0, w1) * (dt[:, None] ** 2
                                                                            / 12.0))


def integrate_rotation(rate: NDArray[np.float64], dt: NDArray[np.float64]) -> Rotation:
    """Body rotation ``C(t0)^T C(t1)`` over samples ``rate`` (n, 3) [rad/s], steps ``dt`` (n-1,).

    Per step the rotation vector ``(w_j + w_{j+1}) dt/2 + (w_j x w_{j+1}) dt^2/12`` (exact for
    a rate linear in time to second order), composed in time order by a pairwise tree of
    :class:`~scipy.spatial.transform.Rotation` products (``C = C_1 C_2 ... C_n``).
    """
    if rate.shape[0] < 2:
        return Rotation.identity()
    return _compose_blocks(_step_rotvecs(rate, dt)[None])[0]


def _compose_blocks(phi: NDArray[np.float64]) -> Rotation:
    """``C = C_1 C_2 ... C_L`` of each row of step rotation vectors ``phi`` (n_blocks, L, 3).

    Each row is padded with identities to a power of two; the step rotations (from
    :class:`~scipy.spatial.transform.Rotation`) are multiplied as direction-cosine matrices,
    all rows together, by pairwise products in time order (the pairs never straddle two
    rows); the result is re-orthonormalised by ``Rotation.from_matrix``.
    """
    nb, length, _ = phi.shape
    size = 1 << max(0, int(np.ceil(np.log2(max(length, 1)))))
    pad = np.zeros((nb, size, 3))
    pad[:, :length] = phi
    mats = Rotation.from_rotvec(pad.reshape(-1, 3)).as_matrix().reshape(nb, size, 3, 3)
    while mats.shape[1] > 1:
        mats = mats[:, 0::2] @ mats[:, 1::2]
    return Rotation.from_matrix(mats[:, 0])


def motion_rotations(
    S_g: NDArray[np.float64], b_g: NDArray[np.float64], gyr: NDArray[np.float64],
    dt: NDArray[np.float64], spans: list[tuple[int, int]],
) -> Rotation:
    """``C_k`` of every motion (stacked) from the calibrated rates ``S_g^-1 (raw - b_g)``.

    The motion k runs over samples ``spans[k] = (i0, i1)`` inclusive; all motions are
    integrated together (:func:`integrate_rotation`'s rule, vectorised over the motions).
    """
    lo = min(i0 for i0, _ in spans)
    hi = max(i1 for _, i1 in spans)
    w = (gyr[lo:hi + 1] - b_g) @ np.linalg.inv(S_g).T
    steps = _step_rotvecs(w, dt[lo:hi])
    length = max(i1 - i0 for i0, i1 in spans)
    phi = np.zeros((len(spans), max(length, 1), 3))
    for k, (i0, i1) in enumerate(spans):
        phi[k, :i1 - i0] = steps[i0 - lo:i1 - lo]
    return _compose_blocks(phi)


def transport_residuals(
    S_g: NDArray[np.float64], b_g: NDArray[np.float64], gyr: NDArray[np.float64],
    dt: NDArray[np.float64], spans: list[tuple[int, int]], up: NDArray[np.float64],
) -> NDArray[np.float64]:
    """``C_k^T u_k - u_{k+1}`` for every motion k (flattened, 3 per motion) [1]."""
    rots = motion_rotations(S_g, b_g, gyr, dt, spans)
    return np.asarray((rots.inv().apply(up[:-1]) - up[1:]).ravel())


@dataclass(frozen=True)
class _GyroFit:
    """Solution of the gyro transport fit and its Jacobians at the solution."""

    S_g: NDArray[np.float64]
    residuals: NDArray[np.float64]  # (3 (m-1),)
    jac: NDArray[np.float64]  # d r / d vec(S_g), (3 (m-1), 9)
    jac_up: NDArray[np.float64]  # d r / d up, (3 (m-1), 3 m)
    jac_b: NDArray[np.float64]  # d r / d b_g, (3 (m-1), 3)
    jac_w: NDArray[np.float64]  # d r / d (rotation noise of each motion), (3 (m-1), 3 (m-1))
    cond: float


def fit_gyroscope(
    S0: NDArray[np.float64], b_g: NDArray[np.float64], gyr: NDArray[np.float64],
    dt: NDArray[np.float64], spans: list[tuple[int, int]], up: NDArray[np.float64],
) -> _GyroFit:
    """``S_g`` [raw SI per rad/s] minimising ``sum |C_k^T u_k - u_{k+1}|^2`` (Tedaldi III-B).

    Also the Jacobians of the residuals the covariance needs (:func:`joint_covariance`):
    with respect to ``vec S_g`` (the fit's), the gravity directions (exact: ``C_k^T`` and
    ``-I``), the bias (finite differences) and a small rotation ``dphi_k`` of each motion in
    its end frame (``C_k -> C_k Exp(dphi_k)``: ``d r_k = [v_k x] dphi_k``, ``v_k = C_k^T u_k``).
    """
    def resid(x: NDArray) -> NDArray:
        return transport_residuals(x.reshape(3, 3), b_g, gyr, dt, spans, up)

    sol = scipy.optimize.least_squares(resid, S0.ravel(), x_scale="jac", method="lm")
    J = sol.jac
    col = np.linalg.norm(J, axis=0)
    cond = float(np.linalg.cond(J / np.where(col > 0, col, 1.0)))
    if not np.isfinite(cond) or cond > MAX_CONDITION:
        raise IdentifiabilityError(
            f"the {len(spans)} turns between static attitudes do not determine the gyro scale "
            f"factors and misalignments (condition number {cond:.3g}): turn the IMU about all "
            "three axes between the attitudes")
    S_g = sol.x.reshape(3, 3)
    r0 = transport_residuals(S_g, b_g, gyr, dt, spans, up)
    n_mot = len(spans)
    rots = motion_rotations(S_g, b_g, gyr, dt, spans)
    CT = rots.inv().as_matrix()
    Ju = np.zeros((3 * n_mot, 3 * (n_mot + 1)))
    Jw = np.zeros((3 * n_mot, 3 * n_mot))
    for k in range(n_mot):
        Ju[3 * k:3 * k + 3, 3 * k:3 * k + 3] = CT[k]
        Ju[3 * k:3 * k + 3, 3 * k + 3:3 * k + 6] = -np.eye(3)
        Jw[3 * k:3 * k + 3, 3 * k:3 * k + 3] = _skew(CT[k] @ up[k])
    Jb = np.empty((3 * n_mot, 3))
    h = 1e-3 * float(np.max(np.abs(np.linalg.inv(S_g)))) ** -1 * 1e-3  # ~1e-6 rad/s
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        Jb[:, i] = (transport_residuals(S_g, b_g + e, gyr, dt, spans, up)
                    - transport_residuals(S_g, b_g - e, gyr, dt, spans, up)) / (2 * h)
    return _GyroFit(S_g=S_g, residuals=r0, jac=J, jac_up=Ju, jac_b=Jb, jac_w=Jw, cond=cond)


def _skew(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass(frozen=True)
class NoisePropagation:
    """Joint covariance of the accelerometer and gyro parameters and the noise scales used.

    Attributes
    ----------
    covariance : ndarray, shape (24, 24)
        Of ``[S_a.ravel(), b_a, S_g.ravel(), b_g]`` [raw SI units].
    acc_noise_scale : float
        ``lambda``: residual-estimated / sample-variance-predicted accelerometer noise
        variance of the interval means [1].
    gyro_noise_scale : float
        ``mu``: residual-estimated / white-noise-predicted variance of the rotation noise of
        each motion [1] (1 for pure angle random walk; larger with model errors).
    """

    covariance: NDArray[np.float64]
    acc_noise_scale: float
    gyro_noise_scale: float


def joint_covariance(
    means: NDArray[np.float64], var_means: NDArray[np.float64], S_a: NDArray[np.float64],
    b_a: NDArray[np.float64], axis: str, r_a: NDArray[np.float64], gf: _GyroFit,
    var_bg: NDArray[np.float64], var_rot: NDArray[np.float64],
) -> NoisePropagation:
    """Covariance of both triads, propagated from every noise source to both fits.

    Both estimates are linearised in three independent noise sources:

    - ``e_m`` (3m): noise of the static interval means ``m_k``, covariance
      ``lambda diag(var_means)``;
    - ``e_b`` (3): noise of the initial-period gyro bias, covariance ``diag(var_bg)``;
    - ``e_w`` (3 per motion): rotation noise of each integrated motion (angle random walk),
      covariance ``mu var_rot[k] I``.

    Accelerometer (Tedaldi Sec. III-A, residual ``r_k = |S_a^-1 (m_k - b_a)| - g``):
    ``d theta_a = T_a e_m``, ``T_a = -(J_a^T J_a)^-1 J_a^T dr/dm``. The gravity directions
    ``u_k = S_a^-1 (m_k - b_a) / |.|`` move with their own mean and with ``theta_a`` (shared
    by all of them): ``d u = U e_m``, ``U = Q S_a^-1 (block diagonal) + Q H T_a``. Gyro
    (Sec. III-B, implicit differentiation of the normal equations at the solution):
    ``d vec S_g = -A (J_u U e_m + J_b e_b + J_w e_w)``, ``A = (J^T J)^-1 J^T``; ``d b_g = e_b``.
    The covariance ``L Sigma L^T`` of the stacked map ``L`` holds the cross-covariance of the
    accelerometer and gyro estimates. ``lambda`` and ``mu`` are the noise levels estimated from
    each fit's residuals (``E r^T r = tr(R Sigma_r R^T)`` with ``R = I - J A``; the gyro's
    share of the gravity-direction and bias noise subtracted first); ``lambda = 1`` when the
    accelerometer has no residual degrees of freedom. Data without any sample noise (a
    noise-free simulation) get equal weights, their level wholly from the residuals.
    """
    m = means.shape[0]
    free = _FREE[axis]
    if not np.any(var_means > 0):  # noise-free (simulated) means: equal weights, level from r
        var_means = np.ones_like(var_means)
    if not np.any(var_rot > 0):
        var_rot = np.ones_like(var_rot)
    Sinv = np.linalg.inv(S_a)
    u = (means - b_a) @ Sinv.T
    nu = np.linalg.norm(u, axis=1)
    n = u / nu[:, None]
    wv = n @ Sinv  # rows: n_k^T S_a^-1 = d r_k / d m_k
    # accelerometer Jacobians: theta = free entries of S_a, then b_a
    Ja = np.empty((m, 9))
    for c, (i, j) in enumerate(free):
        Ja[:, c] = -wv[:, i] * u[:, j]
    Ja[:, 6:] = -wv
    Dm = np.zeros((m, 3 * m))
    for k in range(m):
        Dm[k, 3 * k:3 * k + 3] = wv[k]
    Na = np.linalg.pinv(Ja.T @ Ja)
    Ta = -Na @ Ja.T @ Dm  # (9, 3m)
    Sig_m0 = np.diag(var_means.ravel())
    Ra = np.eye(m) - Ja @ Na @ Ja.T
    pred = float(np.trace(Ra @ Dm @ Sig_m0 @ Dm.T @ Ra.T))
    lam = float(r_a @ r_a) / pred if m > 9 and pred > 0 else 1.0
    Sig_m = lam * Sig_m0
    # gravity directions: own mean + the shared accelerometer solution
    U = np.zeros((3 * m, 3 * m))
    H = np.zeros((3 * m, 9))
    for k in range(m):
        Q = (np.eye(3) - np.outer(n[k], n[k])) / nu[k]
        U[3 * k:3 * k + 3, 3 * k:3 * k + 3] = Q @ Sinv
        for c, (i, j) in enumerate(free):
            H[3 * k:3 * k + 3, c] = -Q @ Sinv[:, i] * u[k, j]
        H[3 * k:3 * k + 3, 6:] = -Q @ Sinv
    U = U + H @ Ta
    # gyro
    J = gf.jac
    A = np.linalg.pinv(J.T @ J) @ J.T
    Rg = np.eye(J.shape[0]) - J @ A
    Gm = gf.jac_up @ U  # d r_g / d e_m
    Sig_w0 = np.diag(np.repeat(var_rot, 3))
    known = Gm @ Sig_m @ Gm.T + gf.jac_b @ np.diag(var_bg) @ gf.jac_b.T
    rr_known = float(np.trace(Rg @ known @ Rg.T))
    pred_w = float(np.trace(Rg @ gf.jac_w @ Sig_w0 @ gf.jac_w.T @ Rg.T))
    rr = float(gf.residuals @ gf.residuals)
    mu = max(rr - rr_known, 0.0) / pred_w if J.shape[0] > 9 and pred_w > 0 else 1.0
    # stacked map from the sources [e_m, e_b, e_w] to [p_a (12), p_g (12)]
    nw = J.shape[0]
    L = np.zeros((24, 3 * m + 3 + nw))
    for c, (i, j) in enumerate(free):
        L[3 * i + j, :3 * m] = Ta[c]
    L[9:12, :3 * m] = Ta[6:]
    L[12:21, :3 * m] = -A @ Gm
    L[12:21, 3 * m:3 * m + 3] = -A @ gf.jac_b
    L[12:21, 3 * m + 3:] = -A @ gf.jac_w
    L[21:24, 3 * m:3 * m + 3] = np.eye(3)
    Sig = np.zeros((L.shape[1], L.shape[1]))
    Sig[:3 * m, :3 * m] = Sig_m
    Sig[3 * m:3 * m + 3, 3 * m:3 * m + 3] = np.diag(var_bg)
    Sig[3 * m + 3:, 3 * m + 3:] = mu * Sig_w0
    cov = L @ Sig @ L.T
    return NoisePropagation(covariance=0.5 * (cov + cov.T), acc_noise_scale=lam,
                            gyro_noise_scale=mu)


def _detect(acc: NDArray[np.float64], spec: OrientationFreeSpec, k: float) -> StaticDetection:
    return detect_static_intervals(
        acc, sample_rate_hz=spec.sample_rate_hz, init_duration_s=spec.init_duration_s,
        threshold_factor=k, window_s=spec.window_s, min_duration_s=spec.min_interval_s)


def choose_threshold(
    acc: NDArray[np.float64], spec: OrientationFreeSpec, g: float, *, centre: float = 0.0,
) -> tuple[StaticDetection, tuple[ThresholdCandidate, ...]]:
    """Tedaldi's automatic threshold (Sec. IV): the k giving the lowest accelerometer residual.

    For each ``k`` in :data:`AUTO_THRESHOLD_FACTORS`: static intervals, their means and the
    accelerometer fit (:func:`fit_accelerometer`); kept: the lowest residual variance per
    degree of freedom (ties: the smaller k). ``acc`` (n, 3) [raw SI]; ``centre`` the plan's
    nominal offset [raw SI] for the coverage message.

    Raises
    ------
    IdentifiabilityError
        When no k gives at least ten intervals with an identifiable fit (lists each k's count).
    """
    found: list[tuple[StaticDetection, ThresholdCandidate]] = []
    for k in AUTO_THRESHOLD_FACTORS:
        det = _detect(acc, spec, k)
        rms = float("nan")
        if det.count > MIN_ATTITUDES:
            means = np.array([acc[a:b].mean(axis=0) for a, b in det.intervals])
            try:
                _, _, r, _ = fit_accelerometer(means, g, spec.reference_axis, centre=centre)
                rms = float(np.sqrt(r @ r / (det.count - 9)))
            except IdentifiabilityError:
                pass
        found.append((det, ThresholdCandidate(k, det.count, rms)))
    ok = [(c.residual_rms_m_s2, i) for i, (_, c) in enumerate(found)
          if np.isfinite(c.residual_rms_m_s2)]
    if not ok:
        counts = ", ".join(f"k={c.threshold_factor:g}: {c.intervals}" for _, c in found)
        raise IdentifiabilityError(
            f"threshold_factor = \"auto\" found no factor giving more than {MIN_ATTITUDES} "
            f"static attitudes with an identifiable accelerometer fit ({counts}); record more "
            "attitudes, each held still longer than min_interval_s, or lower min_interval_s")
    best = min(ok)[1]
    return found[best][0], tuple(c for _, c in found)


def _trapezoid_weight2(dt: NDArray[np.float64]) -> float:
    """``sum_j c_j^2`` [s^2] of the trapezoid weights ``c_j`` over a motion's steps ``dt``.

    The angle-random-walk variance of the integrated rotation is this times the per-sample
    rate variance (white rate noise, each sample weighted by half of each adjoining step).
    """
    if dt.size == 0:
        return 0.0
    c = np.r_[dt, 0.0] / 2 + np.r_[0.0, dt] / 2
    return float(c @ c)


def _angles_deg(res: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle between unit vectors whose difference is ``res`` (3 per motion) [deg]."""
    chord = np.linalg.norm(res.reshape(-1, 3), axis=1)
    return np.asarray(2 * np.degrees(np.arcsin(np.clip(chord / 2, 0.0, 1.0))))


# ---------------------------------------------------------------------------------------------
# fit


def _time_steps(data: Mapping[str, object], n: int, fs: float) -> NDArray[np.float64]:
    if "t_s" in data:
        t = np.asarray(data["t_s"], dtype=float)
        dt = np.diff(t)
        if t.size == n and np.all(np.isfinite(dt)) and np.all(dt > 0):
            check_sample_rate(data, fs, source=KIND)  # type: ignore[arg-type]
            check_time_gaps(t, name="t_s", source=KIND)
            return dt
        raise DataError("column t_s must increase strictly, one time per sample [s]; "
                        "repair it or drop it (then 1 / sample_rate_hz is used)")
    return np.full(n - 1, 1.0 / fs)


@dataclass(frozen=True)
class RecordingObservations:
    """A hand-held recording reduced to its static intervals.

    ``acc``, ``gyr`` (n, 3) [raw SI], ``dt`` (n - 1,) sample steps [s], ``t`` (n,) times [s],
    ``detection`` the static intervals found, ``threshold_search`` the candidates tried
    (``threshold_factor = "auto"``), ``means``, ``gyro_means`` (m, 3) per interval [raw SI].
    """

    acc: NDArray[np.float64]
    gyr: NDArray[np.float64]
    dt: NDArray[np.float64]
    t: NDArray[np.float64]
    detection: StaticDetection
    threshold_search: tuple[ThresholdCandidate, ...]
    means: NDArray[np.float64]
    gyro_means: NDArray[np.float64]


class OrientationFree(Procedure[OrientationFreeSpec, RecordingObservations,
                                OrientationFreeResult]):
    """IMU, multi-position without known orientations (Tedaldi et al., ICRA 2014).

    Data columns ``acc_x..acc_z`` [acc_unit], ``gyr_x..gyr_z`` [gyr_unit], optional ``t_s``
    [s]. No known ``sigma``: the noise comes from the residuals. There is no machine: the
    attitudes are found in the data (static detection), the accelerometer triad by |a| = g,
    the gyro triad by carrying gravity from one attitude to the next.
    """

    kind = KIND
    title = "IMU, multi-position without known orientations (Tedaldi)"
    spec = OrientationFreeSpec
    model = "inertest.models.imu"
    method = "Levenberg-Marquardt (accelerometer: |a| = g; gyroscope: gravity transport)"
    sigma_note = "estimates the noise from the residuals"
    report = "inertest.report.orientation_free:orientation_free_sections"

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: None
               ) -> RecordingObservations:
        """The static intervals of the recording and their means."""
        spec: OrientationFreeSpec = plan.procedure
        g = plan.site.gravity_m_s2
        cols = require_columns(data, ACC_COLUMNS + GYR_COLUMNS, (), procedure=KIND)
        sa, sg = spec.acc_scale, spec.gyr_scale
        ra, rg = sa.raw_si_per_raw, sg.raw_si_per_raw
        acc = np.column_stack([cols[c] for c in ACC_COLUMNS]) * ra
        gyr = np.column_stack([cols[c] for c in GYR_COLUMNS]) * rg
        n = acc.shape[0]
        fs = spec.sample_rate_hz
        dt = _time_steps(data, n, fs)
        t = np.r_[0.0, np.cumsum(dt)] + (float(np.asarray(data["t_s"])[0]) if "t_s" in data else 0)
        search: tuple[ThresholdCandidate, ...] = ()
        if spec.threshold_factor == "auto":
            det, search = choose_threshold(acc, spec, g, centre=spec.acc_bias_guess * ra)
        else:
            det = _detect(acc, spec, float(spec.threshold_factor))
        iv = det.intervals
        m = det.count
        if m < MIN_ATTITUDES:
            raise IdentifiabilityError(
                f"found {m} static attitude(s) (threshold_factor {det.threshold_factor:g}, "
                f"min_interval_s {spec.min_interval_s:g} s); the accelerometer's 9 parameters need "
                f"at least {MIN_ATTITUDES} (Tedaldi recommend {RECOMMENDED_ATTITUDES}-50): record "
                "more attitudes, each held still, or raise threshold_factor / lower "
                "min_interval_s if the IMU was still longer than found")
        means = np.array([acc[a:b].mean(axis=0) for a, b in iv])
        gmeans = np.array([gyr[a:b].mean(axis=0) for a, b in iv])
        return RecordingObservations(acc, gyr, dt, t, det, search, means, gmeans)

    def identify(self, plan: Plan, obs: RecordingObservations, *, sigma: float | None,
                 noise_model: str | None) -> OrientationFreeResult:
        """Calibrate the accelerometer and gyro triads from the static intervals."""
        spec: OrientationFreeSpec = plan.procedure
        g = plan.site.gravity_m_s2
        sa, sg = spec.acc_scale, spec.gyr_scale
        ra, rg = sa.raw_si_per_raw, sg.raw_si_per_raw
        acc, gyr, dt, t, det = obs.acc, obs.gyr, obs.dt, obs.t, obs.detection
        means, gmeans, search = obs.means, obs.gyro_means, obs.threshold_search
        iv, m = det.intervals, det.count
        p_a, _, r_a, _ = fit_accelerometer(means, g, spec.reference_axis,
                                               centre=spec.acc_bias_guess * ra)
        S_a, b_a = p_a[:9].reshape(3, 3), p_a[9:]
        messages: list[str] = []
        cov_msg = coverage_message(means, (S_a, b_a), spec.reference_axis)
        if cov_msg is not None:
            messages.append("poor coverage of the sphere, the estimates may be weak: " + cov_msg)
        if m < RECOMMENDED_ATTITUDES:
            messages.append(f"{m} static attitudes found; Tedaldi et al. recommend "
                            f"{RECOMMENDED_ATTITUDES}-50 for a robust calibration")

        # gyroscope: bias from the initial static period, S_g from the gravity transport
        n_init = det.n_init
        b_g = gyr[:n_init].mean(axis=0)
        var_bg = gyr[:n_init].var(axis=0, ddof=1) / n_init
        u_cal = np.linalg.solve(S_a, (means - b_a).T).T
        up = u_cal / np.linalg.norm(u_cal, axis=1, keepdims=True)
        spans = [(int(iv[k, 1] - 1), int(iv[k + 1, 0])) for k in range(m - 1)]
        # nominal gyro: the plan's scale guess [count/(deg/s)] in raw SI, or 1 for a physical unit
        k_g0 = 1.0 if spec.gyr_scale_guess is None else spec.gyr_scale_guess * sg.si_per_unit
        S_g0 = np.eye(3) * k_g0
        # noise: of each interval mean (white, from its own samples), of the initial-period gyro
        # bias, and of each integrated motion (angle random walk of the calibrated rates)
        var_means = np.array([acc[a:b].var(axis=0, ddof=1) / (b - a) for a, b in iv])
        var_raw_g = gyr[:n_init].var(axis=0, ddof=1)
        gf = fit_gyroscope(S_g0, b_g, gyr, dt, spans, up)
        S_g, r_g = gf.S_g, gf.residuals
        Sg_inv = np.linalg.inv(S_g)
        var_rate = float(np.trace(Sg_inv @ np.diag(var_raw_g) @ Sg_inv.T)) / 3  # per axis
        var_rot = np.array([var_rate * _trapezoid_weight2(dt[i0:i1]) for i0, i1 in spans])
        prop = joint_covariance(means, var_means, S_a, b_a, spec.reference_axis, r_a, gf,
                                var_bg, var_rot)
        cov_a = prop.covariance[:12, :12]
        cov_g = prop.covariance[12:, 12:]
        p_g = triad.stack_parameters(S_g, b_g)

        # checks before/after
        if spec.acc_scale_guess is not None:
            k_a0 = spec.acc_scale_guess * sa.si_per_unit
        else:  # one common scale that makes the mean |a| = g
            k_a0 = float(np.mean(np.linalg.norm(means - spec.acc_bias_guess * ra, axis=1))) / g
        err_before = np.linalg.norm(means - spec.acc_bias_guess * ra, axis=1) / k_a0 - g
        err_after = np.linalg.norm(u_cal, axis=1) - g
        ang_after = _angles_deg(r_g)
        ang_before = _angles_deg(transport_residuals(S_g0, b_g, gyr, dt, spans, up))

        # results in THE triad model's conventions
        tri_a = TriadEstimates.from_parameters(p_a, cov_a, sensor="accelerometer", scale=sa)
        tri_g = TriadEstimates.from_parameters(p_g, cov_g, sensor="gyroscope", scale=sg)
        fixed = set(_FIXED_MIS[spec.reference_axis])
        names_a = [nm for nm in triad.parameter_names() if nm not in fixed]
        all_a = triad.parameter_names()
        idx_a = [all_a.index(nm) for nm in names_a]
        cov_ea = tri_a.covariance[np.ix_(idx_a, idx_a)]
        coefficients: dict[str, Estimate] = {}
        for tri, names, letter in ((tri_a, names_a, "a"), (tri_g, list(all_a), "g")):
            for nm in names:
                e = tri.all_estimates()[nm]
                key = f"{nm[0]}{letter}{nm[1:]}"
                coefficients[key] = Estimate(key, e.value, e.std, e.unit)
        _, Je_a = triad.engineering_jacobian(p_a, "accelerometer", sa)
        _, Je_g = triad.engineering_jacobian(p_g, "gyroscope", sg)
        cross = (Je_a @ prop.covariance[:12, 12:] @ Je_g.T)[idx_a]
        cov_out = np.block([[cov_ea, cross], [cross.T, tri_g.covariance]])
        fixed_names = ", ".join(f"M{'a'}{nm[1:]}" for nm in _FIXED_MIS[spec.reference_axis])
        frame = ("the z accelerometer defines the z axis and y lies in the y-z plane"
                 if spec.reference_axis == "z" else
                 "the x accelerometer defines the x axis and y lies in the x-y plane")
        not_sep = (
            f"accelerometer frame orientation: |a| = g determines the triad only up to a rotation "
            f"of its reference frame; the gauge of Tedaldi et al. (reference_axis = "
            f"{spec.reference_axis}: {frame}) sets {fixed_names} = 0 by definition, so they are "
            "not estimates; the gyro misalignments Mg_ij refer to this same frame",
        )
        for msg in (triad.reversed_axes_message(p_a, "accelerometer", "acc_{}"),
                    triad.reversed_axes_message(p_g, "gyroscope", "gyr_{}")):
            if msg is not None:
                messages.append(msg)
        rms_ang = float(np.sqrt(np.mean(np.square(ang_after)))) if ang_after.size else 0.0
        if rms_ang >= TRANSPORT_TOLERANCE_DEG:
            messages.append(f"check failed: the calibrated gyro carries gravity to the next "
                            f"attitude with an rms error of {rms_ang:.3g} deg (tolerance "
                            f"{TRANSPORT_TOLERANCE_DEG:g} deg): do not use the gyro calibration; "
                            "look for gaps, saturation or a wrong sample rate in the recording")
        ident = Identification(
            coefficients=coefficients, combinations=(), not_separable=not_sep,
            covariance=cov_out, names=tuple(coefficients), noise_sigma=float(
                np.sqrt(r_a @ r_a / (m - 9))) if m > 9 else float("nan"),
            noise_unit="m/s^2", sigma_from_residuals=True, dof=m - 9, rank=len(coefficients),
            residuals=r_a,
        )
        calibration = ImuCalibration(
            accelerometer=triad.calibration_from_parameters(p_a, sensor="accelerometer", scale=sa,
                                                            raw_unit=spec.acc_unit),
            gyroscope=triad.calibration_from_parameters(p_g, sensor="gyroscope", scale=sg,
                                                        raw_unit=spec.gyr_unit),
        )
        intervals = tuple(
            StaticInterval(float(t[a]), float(t[b - 1]), means[k] / ra, gmeans[k] / rg, int(b - a))
            for k, (a, b) in enumerate(iv))
        return OrientationFreeResult(
            site_latitude_deg=plan.site.latitude_deg, site_gravity_m_s2=g, identification=ident,
            calibration=calibration, triads=(tri_a, tri_g), residual_output=r_a,
            output_unit="m/s^2", messages=tuple(messages), intervals=intervals, detection=det,
            gravity_error_m_s2=err_after, gravity_error_before_m_s2=err_before,
            transport_angle_deg=ang_after, transport_angle_before_deg=ang_before,
            reference_axis=spec.reference_axis, noise_scales=(prop.acc_noise_scale,
                                                              prop.gyro_noise_scale),
            threshold_search=search,
        )

    def synthesize(self, plan: Plan, motion: None, truth: Mapping[str, float], *, noise: float,
                   rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """A virtual hand-held session with random attitudes and raised-cosine turns.

        Still for ``init_duration_s``, then ``n_attitudes`` random attitudes held ``static_s``
        each, reached by raised-cosine turns of ``motion_s`` about a fixed body axis (pure
        rotation about the IMU; no Earth rate). ``truth``: ``Ka_*``, ``Ma_ij`` [urad],
        ``Ba_*`` [mg], ``Kg_*``, ``Mg_ij`` [urad], ``Bg_*`` [deg/h] (the fit's units; scale
        factors required for count outputs), optional ``acc_noise``, ``gyr_noise`` [raw unit
        per sample] (default ``noise``). Misalignments outside the gauge rotate the frame: the
        fit then reports the rotated equivalent.

        Returns columns ``t_s``, ``acc_x..acc_z``, ``gyr_x..gyr_z``.
        """
        spec: OrientationFreeSpec = plan.procedure
        gen = np.random.default_rng(rng)
        known = set(_prefixed(triad.parameter_names(), "a") + _prefixed(triad.parameter_names(),
                                                                        "g"))
        unknown = sorted(set(truth) - known - {"acc_noise", "gyr_noise"})
        if unknown:
            raise PlanError(f"truth has unknown name(s) {', '.join(unknown)}; {KIND} knows Ka_x.., "
                            "Ma_xy.. [urad], Ba_x.. [mg], Kg_x.., Mg_xy.., Bg_x.. [deg/h], "
                            "acc_noise, gyr_noise")
        sa, sg = spec.acc_scale, spec.gyr_scale
        p_a = triad.parameters_from_engineering(truth, "accelerometer", sa, prefix="a")
        p_g = triad.parameters_from_engineering(truth, "gyroscope", sg, prefix="g")
        s_a = float(truth.get("acc_noise", noise))
        s_g = float(truth.get("gyr_noise", noise))
        g = plan.site.gravity_m_s2
        fs = spec.sample_rate_hz
        n_init = int(round(spec.init_duration_s * fs))
        n_static = int(round(spec.static_s * fs))
        n_move = int(round(spec.motion_s * fs))
        att = Rotation.random(spec.n_attitudes + 1, random_state=gen)  # C_nb of each attitude
        att = Rotation.concatenate([Rotation.identity(), att[1:]])
        f_parts, w_parts = [], []
        up = np.array([0.0, 0.0, g])
        f_parts.append(np.tile(att[0].inv().apply(up), (n_init, 1)))
        w_parts.append(np.zeros((n_init, 3)))
        tau = (np.arange(n_move) + 0.5) / n_move  # sample mid-points of the turn
        for k in range(spec.n_attitudes):
            phi = (att[k].inv() * att[k + 1]).as_rotvec()  # body-frame turn C_k^T C_{k+1}
            s = tau - np.sin(2 * np.pi * tau) / (2 * np.pi)
            rate = (1 - np.cos(2 * np.pi * tau)) * fs / n_move
            C = att[k] * Rotation.from_rotvec(np.outer(s, phi))
            f_parts.append(C.inv().apply(up))
            w_parts.append(np.outer(rate, phi))
            f_parts.append(np.tile(att[k + 1].inv().apply(up), (n_static, 1)))
            w_parts.append(np.zeros((n_static, 3)))
        f = np.vstack(f_parts)
        w = np.vstack(w_parts)
        acc = triad.output(f, p_a[:9].reshape(3, 3), p_a[9:]) / sa.raw_si_per_raw
        gyr = triad.output(w, p_g[:9].reshape(3, 3), p_g[9:]) / sg.raw_si_per_raw
        if s_a > 0:
            acc = acc + gen.normal(0.0, s_a, acc.shape)
        if s_g > 0:
            gyr = gyr + gen.normal(0.0, s_g, gyr.shape)
        out: dict[str, NDArray] = {"t_s": np.arange(len(f)) / fs}
        for k in range(3):
            out[ACC_COLUMNS[k]] = acc[:, k]
        for k in range(3):
            out[GYR_COLUMNS[k]] = gyr[:, k]
        return out


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = OrientationFree()
