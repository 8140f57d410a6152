"""Ferraris calibration of an IMU (accelerometer and gyro triads) without a turntable.

The session (:mod:`inertest.equipment.ferraris_session`): six static faces, each axis up
(``x_p``) and down (``x_a``), and three hand-made turns of ``rotation_deg`` about x, y, z
(Ferraris et al., 1995, Sensors and Materials 7(5) 311-330; ``imucal.FerrarisCalibration``).

Output models (seed ``003_f374f866dfe7c99f.txt``, eq. (1), written for the raw output)::

    acc:  raw_a = A_a f + b_a,                      A_a = K_a (I + M_a),  b_a = A_a B_a
    gyro: raw_g = A_g w + b_g + G f,                A_g = K_g (I + M_g),  b_g = A_g B_g

``f`` specific force [m/s^2] and ``w`` rate [rad/s] on the case axes defined by its faces,
``K`` diagonal scale factors, ``M`` misalignment (zero diagonal, ``M_ij`` = axis i's sensitivity
to input along j), ``B`` the input-referred biases, ``G`` the gyro g-sensitivity (optional).

Solution (closed form, every coefficient from the parts that determine it):

* ``A_a e_j = (u(j_p) - u(j_a)) / (2 g)``: column j from the up/down difference of face means;
* ``b_a,i = (u_i(i_p) + u_i(i_a)) / 2``: each bias **only from the two faces where axis i is
  vertical** (not from the plain mean of all six faces, as the issue asks);
* ``b_g,i`` likewise from the gyro means of faces ``i_p``, ``i_a`` (this also cancels the
  vertical Earth rate and the diagonal g-sensitivity);
* ``G e_j = (m(j_p) - m(j_a)) / (2 g)`` (gyro means m; raw per m/s^2 of calibrated acceleration),
  when ``g_sensitivity = true``;
* ``A_g (theta e_j + E_j) = W_j``: ``W_j`` the integral over turn j of ``raw_g - b_g - G a_cal``,
  ``theta = rotation_deg`` and ``E_j = W_ie sin L T_j u_j`` the vertical Earth rate over the turn
  (``u_j`` the up direction from the calibrated accelerometers, ``T_j`` the turn's duration):
  without it the scale factors would be off by ``W_ie sin L T / theta`` (89 ppm for a 10 s turn
  at 50 deg latitude; set ``earth_rate = false`` to compare with tools that ignore it).

Why only the vertical faces for the bias (hand-placed faces are never level). A face tilted by
``t`` (rad, perpendicular to its axis) changes the reading of a *horizontal* axis k by
``K_k g t_k`` -- first order -- but the reading of the *vertical* axis only by ``K g (1 - cos t)``
-- second order. With tilts of 1 deg: the plain six-face mean puts up to
``g sin(1 deg) * 4/6 = 11.6 mg`` into a bias; the vertical-face estimate at most
``g (1 - cos 1 deg) / 2 = 0.076 mg`` (2 deg: 0.30 mg; scale factor ``(1 - cos t)/2`` = 76 ppm at
1 deg). Modelling the tilts themselves is not possible from six faces: with the frame fixed,
``A`` (9) + ``b`` (3) + two tilt angles per face (12) = 24 unknowns minus 3 for the frame = 21
against 18 face readings. What six faces do show is the *disagreement* of the tilts of each face
pair: the six off-axis pair sums ``(u_k(i_p) + u_k(i_a))/2 - b_k`` (k != i) are the redundancy
of the design (they are the fit's residuals). Their size gives the tilt scatter ``tau``
(``E[d^2] = g^2 tau^2 / 2``), which enters the misalignment uncertainty (std >= ``tau/sqrt 2``):
the misalignments are defined only as well as the faces were set.

Uncertainty: first-order propagation (numerical Jacobian of the closed form) of the covariance
of the inputs -- face means, turn integrals -- under the plan's ``noise_model`` of each raw
channel (channels independent), plus the face tilt scatter (above):

* ``white`` (default): face means with their within-face sample variance / n, turn integrals
  with the pooled static noise times sqrt(n) / rate. The tilt scatter is counted only when the
  six pair sums exceed their noise (chi-square at :data:`TILT_ALPHA`).
* ``position-offsets``: the IMU re-settles on every face and turn: an offset per part and
  channel (turn integral: offset x duration), its variance from the six redundant pair sums of
  each sensor less their white part (within-face variance from the samples); horizontal face
  tilts are indistinguishable from offsets there and are counted in them.
* ``random-walk``, ``flicker``: a drift of each channel's bias over the session. Its level and
  the white level are estimated from the samples within the faces
  (:func:`inertest.estimation.identify.solve`, REML, with blocks of each face as units and the
  face means as the model) and propagated to every face mean and turn integral with the
  drift's kernel over the data row index (so faces and turns far apart in time are correlated
  as the drift says); rows must be in time order at ``sample_rate_hz``.

Monte Carlo (tests): reported std / scatter 0.9-1.2 for each case with its model (the white
model gave 0.02-0.2 under offsets, a random walk or flicker). The horizontal Earth rate, unknown
in heading, enters the gyro pair sums used for the offsets (< ``W_ie cos L``).

Model checks (``checks`` of the result; a warning when the session does not fit): the design
has no redundant residual left after the per-face fit, so the checks use what the model says
the session must show, each against its variance under the noise model: the six accelerometer
off-axis pair sums (the noise plus face tilts of the plan's ``face_tilt_deg``, 1 sigma per
horizontal axis); the six gyro pair sums (the noise plus the horizontal Earth rate of an unknown
heading, variance ``(W_ie cos L)^2 / 2``); and each turn's ``|integral of a_cal dt| / T - g``
(a turn about the vertical keeps g along one body direction, and the hand's own acceleration
integrates to the zero velocity change; allowance :data:`TURN_GRAVITY_ALLOWANCE_M_S2` for the
wobble of a hand turn). Chi-square of the 15 (``dof`` less the fitted offset levels under
``position-offsets``, where the pair sums also gave the offsets) and outliers by marginal
``z`` (Bonferroni, >= 4). A face recorded partly on another face, a face not lying flat, or a
turn label running into the next face are named; imucal's two real sessions are consistent.
The calibrated faces' ``|a| - g`` is reported separately: it is second order in the pair sums.

Identifiability: the design is exactly the one above -- each axis up and down determines its
accelerometer column, bias and gyro bias (and G column); each turn its gyro column. A missing
part raises :class:`~inertest.errors.IdentifiabilityError` naming the coefficients it would
determine; faces or turns that change the wrong axis, or a turn of the wrong sign, raise
:class:`~inertest.errors.DataError` naming the likely mislabelling.

Not modelled: the horizontal Earth rate (the heading of the faces is unknown, so it cannot be
removed). During turn j it rotates in the body by the turned angle ``phi(t)`` and cancels only
where the turn runs at a uniform rate; over the whole part (rests included) it leaves an angle
perpendicular to the turn axis, along the horizontal Earth rate's direction at the start, of
``W_ie cos L T_eff`` with ``T_eff = |integral of exp(-i phi(t)) dt|`` over the part (at most the
part's length). Divided by ``theta`` it is a spurious gyro misalignment in column j::

    |M_.j| = W_ie cos L T_eff / |theta|     (column j's off-axis part, pointing north at the start)

For the simulated turn (a raised-cosine rate over ``T = turn_duration_s`` with ``t_r = rest_s``
at rest on either side, :func:`~inertest.equipment.ferraris_session.turns_motion`)
``T_eff = 2 t_r + J_1(1) T`` (``J_1(1) = 0.4401``, Bessel): the example plan (T = 4 s,
t_r = 1 s, 49.6 deg latitude) gives ``T_eff = 3.76 s`` and 28 urad (in ``Mg_zx``, ``Mg_xy``,
``Mg_yz`` for the simulation's faces at heading 0); any hand profile of a 6 s part gives at
most 45 urad (``W_ie cos L x 6 s / 2 pi``). Keep the rests short to keep it small; the scale
factors are unaffected to first order.
In ``G`` the horizontal Earth rate is up to ``W_ie cos L`` per g (9.7 deg/h/g at 50 deg: below
the noise of a MEMS session, not of a FOG triad). Nor is the wobble of a hand turn modelled.

Results (units and conventions of :mod:`inertest.models.triad`): ``Ka_*`` [count/(m/s^2)],
``Kg_*`` [count/(deg/s): a count column is a rate reading per sample] (``1`` with a ppm
deviation when the raw unit is physical), misalignments ``Ma_ij``, ``Mg_ij`` [urad], biases
``Ba_*`` [mg], ``Bg_*`` [deg/h], g-sensitivity ``Gg_ij`` [deg/h/g], and the ``calibration`` block.

Data columns: ``part`` (x_p, x_a, y_p, y_a, z_p, z_a, x_rot, y_rot, z_rot; other labels are
ignored), ``acc_x``, ``acc_y``, ``acc_z`` [acc_unit], ``gyr_x``, ``gyr_y``, ``gyr_z``
[gyr_unit], one row per sample at ``sample_rate_hz``; other columns are ignored.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
import scipy.special
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import OMEGA_IE, earth_rate_enu
from inertest.equipment import ferraris_session as session
from inertest.equipment.motion import Inputs, run_starts
from inertest.errors import DataError, IdentifiabilityError, InertestWarning, PlanError
from inertest.estimation.identify import solve as identify_solve
from inertest.estimation.model_checks import CHECK_ALPHA, misfit_message, outlier_threshold
from inertest.estimation.noise_models import MODELS
from inertest.models import triad
from inertest.models.imu import ImuCalibration
from inertest.models.triad import AXES, TriadCalibration
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import require_columns
from inertest.results import Estimate, Identification, ModelChecks, Outlier
from inertest.results.triad import TriadEstimates, TriadResult
from inertest.units import (
    ACCEL_UNITS,
    COUNT_UNITS,
    DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2,
    DEG_TO_RAD,
    G0,
    MICRORAD_TO_RAD,
    MILLI_G_TO_M_PER_S2,
    RATE_UNITS,
)

KIND = "ferraris"
ACC_COLUMNS = ("acc_x", "acc_y", "acc_z")
GYR_COLUMNS = ("gyr_x", "gyr_y", "gyr_z")
_OFF = tuple((i, j) for i in range(3) for j in range(3) if i != j)


def _prefixed(names: tuple[str, ...], letter: str) -> tuple[str, ...]:
    """``K_x`` -> ``Ka_x`` (accelerometer) or ``Kg_x`` (gyro): one IMU result holds both."""
    return tuple(f"{n[0]}{letter}{n[1:]}" for n in names)


ACC_NAMES = _prefixed(triad.parameter_names(False), "a")
GYR_NAMES = _prefixed(triad.parameter_names(False), "g")
G_NAMES = _prefixed(triad.G_SENSITIVITY_NAMES, "g")
#: Tolerance of the calibrated face gravity check [m/s^2] (10 mg): a face whose |a| misses g by
#: more moved during the recording or is mislabelled (tilt and MEMS noise give < 1 mg).
FACE_GRAVITY_TOLERANCE_M_S2 = 10e-3 * G0
#: Significance level at which the face-pair disagreement is taken as face tilt.
TILT_ALPHA = 0.01
#: Allowance (1 sigma) for a hand turn's ``|integral a dt| / T - g`` [m/s^2]: a wobble of the
#: turn axis by ``w`` rad RMS lowers it by ``g w^2 / 2`` (3 deg: 1.4 mg), the centripetal
#: acceleration of a sensor off the turn axis raises it to second order; imucal's two real
#: sessions show 0.4-1.6 mg.
TURN_GRAVITY_ALLOWANCE_M_S2 = 2e-3 * G0
#: Noise models of a raw channel (module docstring, "Noise models").
NOISE_MODELS = ("white", "position-offsets", "random-walk", "flicker")
#: Blocks each face's samples are cut into to estimate a drift from the scatter of block means.
_BLOCKS_PER_FACE = 8


@dataclass(frozen=True)
class FerrarisSpec:
    """Parameters of a Ferraris session (``[procedure]`` table).

    Attributes
    ----------
    sample_rate_hz : float
        Sample rate of the recording [Hz] (the turns are integrated with it).
    rotation_deg : float
        Signed angle of each turn about its +axis (right-handed) [deg]; -360 for clockwise turns.
    acc_unit, gyr_unit : str
        Units of the raw columns: ``count`` or a specific-force / rate unit.
    g_sensitivity : bool
        Estimate the gyro g-sensitivity ``G`` from the faces (default false).
    earth_rate : bool
        Remove the vertical Earth rate ``W_ie sin L`` integrated over each turn (default true;
        the vertical is found from the accelerometers during the turn, the latitude from the
        plan's site). Simulation: include the Earth rate.
    tilt_correction : bool
        Correct the accelerometer scale factors for the second order of the face tilts,
        ``E[1 - cos t]`` from the tilt scatter of the pair sums (default true; false to compare
        with tools that ignore it, such as imucal).
    noise_model : str
        Noise of each raw channel behind the uncertainties (:data:`NOISE_MODELS`, module
        docstring): ``white`` (default), ``position-offsets``, ``random-walk``, ``flicker``.
    face_tilt_deg : float
        Expected tilt of a hand-set face about each horizontal axis, 1 sigma [deg] (default
        1): the model checks test the face-pair disagreement against it (a face whose pair
        sums exceed it was not lying flat, moved, or is mislabelled).
    face_duration_s, turn_duration_s, rest_s : float
        Simulation only: time on each face, duration of each turn and rest before and after it.
    """

    kind: ClassVar[str] = KIND
    sample_rate_hz: float
    rotation_deg: float = 360.0
    acc_unit: str = "count"
    gyr_unit: str = "count"
    g_sensitivity: bool = False
    earth_rate: bool = True
    tilt_correction: bool = True
    noise_model: str = "white"
    face_tilt_deg: float = 1.0
    face_duration_s: float = 5.0
    turn_duration_s: float = 4.0
    rest_s: float = 1.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> FerrarisSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        kw = read_fields(params, FIELDS, f"[procedure] of kind {KIND}", ignore=("kind",))
        if abs(kw["rotation_deg"]) < 90:
            raise PlanError(
                "rotation_deg must be the signed turn angle in deg (e.g. 360 or -360), "
                f"got {params['rotation_deg']!r}"
            )
        return cls(**kw)

    @property
    def acc_scale(self) -> triad.ScaleUnit:
        """How the accelerometer scale factors are reported (``count/(m/s^2)`` or ``1``)."""
        return triad.scale_unit(self.acc_unit, "accelerometer")

    @property
    def gyr_scale(self) -> triad.ScaleUnit:
        """How the gyro scale factors are reported (``count/(deg/s)`` or ``1``).

        A ``count`` gyro column is a rate reading per sample (:mod:`inertest.models.triad`).
        """
        return triad.scale_unit(self.gyr_unit, "gyroscope")


FIELDS = (
    Field("sample_rate_hz", positive=True, unit="Hz", doc="sample rate in Hz"),
    Field("rotation_deg", default=360.0, unit="deg", doc="signed turn angle"),
    Field("acc_unit", "text", default="count", choices=(*COUNT_UNITS, *ACCEL_UNITS)),
    Field("gyr_unit", "text", default="count", choices=(*COUNT_UNITS, *RATE_UNITS)),
    Field("g_sensitivity", "bool", default=False, doc="estimate the gyro g-sensitivity"),
    Field("earth_rate", "bool", default=True, doc="remove the vertical Earth rate"),
    Field("tilt_correction", "bool", default=True,
          doc="correct the scale factors for the faces' tilt, E[1 - cos t]"),
    Field("noise_model", "text", default="white", choices=(
        "white", "position-offsets", "random-walk", "flicker"),
          doc="noise of each raw channel behind the uncertainties"),
    Field("face_tilt_deg", default=1.0, minimum=0.0, unit="deg",
          doc="expected tilt of a hand-set face (1 sigma), for the model checks"),
    Field("face_duration_s", default=5.0, positive=True, unit="s", doc="time on each face"),
    Field("turn_duration_s", default=4.0, positive=True, unit="s", doc="duration of a turn"),
    Field("rest_s", default=1.0, minimum=0.0, unit="s", doc="rest before and after a turn"),
)


@dataclass(frozen=True)
class FaceStats:
    """Per-part statistics of the recording (raw units).

    Attributes
    ----------
    acc_mean, gyr_mean : ndarray, shape (6, 3)
        Mean raw output on each face (order of ``session.FACE_LABELS``).
    acc_std, gyr_std : ndarray, shape (6, 3)
        Sample standard deviation on each face.
    n_face : ndarray, shape (6,)
        Samples per face.
    turn_gyr_integral, turn_acc_integral : ndarray, shape (3, 3)
        Row j: sum of the raw samples of turn j divided by the sample rate [raw unit x s].
    n_turn : ndarray, shape (3,)
        Samples per turn.
    rows : tuple of ndarray
        Data rows (time order) of each face and turn (order of ``session.PARTS``).
    """

    acc_mean: NDArray[np.float64]
    gyr_mean: NDArray[np.float64]
    acc_std: NDArray[np.float64]
    gyr_std: NDArray[np.float64]
    n_face: NDArray[np.float64]
    turn_gyr_integral: NDArray[np.float64]
    turn_acc_integral: NDArray[np.float64]
    n_turn: NDArray[np.float64]
    rows: tuple[NDArray[np.intp], ...] = field(default=(), repr=False)


@dataclass(frozen=True, kw_only=True)
class FerrarisResult(TriadResult):
    """Outcome of a Ferraris session (a :class:`~inertest.results.triad.TriadResult`).

    Attributes
    ----------
    identification : Identification
        Scale factors ``Ka_*`` [count/(m/s^2), or 1 for a physical raw unit], ``Kg_*``
        [count/(deg/s) or 1], misalignments ``Ma_ij``, ``Mg_ij`` [urad], input-referred biases
        ``Ba_*`` [mg], ``Bg_*`` [deg/h] and, if asked, ``Gg_ij`` [deg/h/g]; the residuals are
        the six off-axis face-pair sums [acc_unit].
    calibration : ImuCalibration
        ``calibrated = matrix @ (raw - offset)`` (gyro: ``raw - G @ a_cal - offset``), SI.
    triads : tuple of TriadEstimates
        The same estimates per triad (JSON ``"triads"``).
    stats : FaceStats
    face_gravity_error_m_s2 : ndarray, shape (6,)
        ``|a_cal| - g`` of each face mean after calibration [m/s^2].
    turn_angle_deg : ndarray, shape (3, 3)
        Row j: calibrated rotation vector over turn j without the Earth rate [deg].
    tilt_scatter_deg : float
        Estimated standard deviation of the face tilts from the pair disagreement [deg].
    rotation_deg : float
        The plan's turn angle [deg].
    noise_components : dict
        Per sensor (``accelerometer``, ``gyroscope``): standard deviation of each component of
        the noise model, RMS over its channels [raw unit]: ``white`` and ``random walk`` (step)
        and ``flicker`` per sample, ``position offset`` per part.
    """

    stats: FaceStats = field(repr=False)
    face_gravity_error_m_s2: NDArray[np.float64] = field(repr=False)
    turn_angle_deg: NDArray[np.float64] = field(repr=False)
    tilt_scatter_deg: float
    rotation_deg: float
    noise_components: dict[str, dict[str, float]] = field(default_factory=dict)
    stats_units: tuple[str, str] = ("count", "count")
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d = super().details()
        d["calibration"] = self.calibration.to_dict()
        d["checks"] = {
            "face_gravity_error": {
                "values": dict(zip(session.FACE_LABELS,
                                   (self.face_gravity_error_m_s2 / MILLI_G_TO_M_PER_S2).tolist(),
                                   strict=True)),
                "tolerance": FACE_GRAVITY_TOLERANCE_M_S2 / MILLI_G_TO_M_PER_S2,
                "unit": "mg",
            },
            "turn_angle": {
                "values": dict(zip(session.TURN_LABELS, self.turn_angle_deg.tolist(),
                                   strict=True)),
                "expected": self.rotation_deg,
                "unit": "deg",
            },
            "face_tilt_scatter": {"value": self.tilt_scatter_deg, "unit": "deg"},
        }
        units = {"accelerometer": self.stats_units[0], "gyroscope": self.stats_units[1]}
        d["noise"] = {"model": self.identification.noise_model, **{
            sensor: {k: {"value": v, "unit": units[sensor]} for k, v in comps.items()}
            for sensor, comps in self.noise_components.items()}}
        return d


# ---------------------------------------------------------------------------------------------
# reduction


def part_stats(data: Mapping[str, object], spec: FerrarisSpec) -> FaceStats:
    """Means, spreads and turn integrals of each part; errors name missing or empty parts."""
    cols = require_columns(data, ACC_COLUMNS + GYR_COLUMNS, ("part",), procedure=KIND)
    # The labels are read per run of equal labels (a part is recorded in one go): one string
    # comparison over the rows, then each distinct label matched once, exactly or normalised
    # (case, blanks). Row-wise string operations were most of the time.
    label = np.asarray(cols["part"])
    starts = run_starts(label)
    stops = np.append(starts[1:], label.size)
    run_label = label[starts].tolist()
    code_of: dict[object, int] = {}
    for name in set(run_label):
        text = str(name)
        code_of[name] = (session.PARTS.index(text) if text in session.PARTS else
                         session.PARTS.index(text.strip().lower())
                         if text.strip().lower() in session.PARTS else -1)
    run_code = [code_of[name] for name in run_label]
    _check_parts_present({session.PARTS[k] for k in set(run_code) if k >= 0}, spec)
    runs_of: list[list[int]] = [[] for _ in session.PARTS]
    for r, k in enumerate(run_code):
        if k >= 0:
            runs_of[k].append(r)
    rows = tuple(np.concatenate([np.arange(starts[r], stops[r]) for r in runs])
                 if runs else np.empty(0, dtype=np.intp) for runs in runs_of)
    raw = np.column_stack([cols[c] for c in ACC_COLUMNS + GYR_COLUMNS])  # acc, then gyro

    def part(k: int) -> NDArray[np.float64]:
        """The raw rows of part k: a view when they are one run (no copy)."""
        runs = runs_of[k]
        return raw[starts[runs[0]]:stops[runs[0]]] if len(runs) == 1 else raw[rows[k]]

    fs = spec.sample_rate_hz
    mean, sd, nf = [], [], []
    for f, face in enumerate(session.FACE_LABELS):
        n = rows[f].size
        if n < 2:
            raise IdentifiabilityError(
                f"face {face} has {n} sample(s); record at least 2 (a few seconds) at rest"
            )
        v = part(f)
        mu = v.sum(axis=0) / n
        dv = v - mu
        mean.append(mu)
        sd.append(np.sqrt(np.einsum("ij,ij->j", dv, dv) / (n - 1)))  # std(ddof=1), two-pass
        nf.append(n)
    turn = np.array([part(k).sum(axis=0) / fs for k in range(6, len(session.PARTS))])
    m, d = np.array(mean), np.array(sd)
    return FaceStats(m[:, :3], m[:, 3:], d[:, :3], d[:, 3:], np.array(nf, float),
                     turn[:, 3:], turn[:, :3], np.array([r.size for r in rows[6:]], float), rows)


def _check_parts_present(present: set[str], spec: FerrarisSpec) -> None:
    for a in AXES:
        others = [b for b in AXES if b != a]
        for s, word, sign in (("p", "up", "+g"), ("a", "down", "-g")):
            if f"{a}_{s}" not in present:
                raise IdentifiabilityError(
                    f"no rows with part {a}_{s}: without the face with {a} {word} the "
                    f"accelerometer's {a} column (Ka_{a}, Ma_{others[0]}{a}, Ma_{others[1]}{a}) "
                    f"and the biases Ba_{a}, Bg_{a} cannot be found (axis {a} must be seen up "
                    f"and down); record the {a}_{s} face ({a} axis {word}, acc_{a} reading {sign})"
                )
        if f"{a}_rot" not in present:
            raise IdentifiabilityError(
                f"no rows with part {a}_rot: without a turn about {a} the gyro's {a} column "
                f"(Kg_{a}, Mg_{others[0]}{a}, Mg_{others[1]}{a}) cannot be found; record a turn "
                f"of {spec.rotation_deg:g} deg about the {a} axis labelled {a}_rot"
            )


def _check_labels(stats: FaceStats, spec: FerrarisSpec) -> None:
    """Catch swapped faces, mislabelled axes and a wrong turn sign before solving."""
    diff = stats.acc_mean[0::2] - stats.acc_mean[1::2]  # row j: u(j_p) - u(j_a)
    norms = np.linalg.norm(diff, axis=1)
    for j, a in enumerate(AXES):
        k = int(np.argmax(np.abs(diff[j])))
        if norms[j] < 0.5 * norms.max():
            raise IdentifiabilityError(
                f"faces {a}_p and {a}_a give nearly the same specific force ({norms[j]:.4g} "
                f"against {norms.max():.4g} {spec.acc_unit} for the other axes): the {a} axis "
                f"was not turned over, so Ka_{a} and the {a} column cannot be found; record "
                f"{a}_p with {a} up and {a}_a with {a} down"
            )
        if k != j:
            raise DataError(
                f"faces {a}_p/{a}_a change acc_{AXES[k]} most ({diff[j, k]:.6g} {spec.acc_unit}) "
                f"and acc_{a} only by {diff[j, j]:.6g}: the faces or the acc columns are "
                f"mislabelled; {a}_p must be the face with +{a} up (acc_{a} reading +g)"
            )
        # acc_j reading less on j_p than on j_a is a negative scale factor: a reversed axis or
        # a negated channel (or swapped face labels, which the data cannot tell apart); it is
        # calibrated as such and reported by fit() (triad model: K < 0 is legal).
    theta = spec.rotation_deg
    w = stats.turn_gyr_integral - stats.n_turn[:, None] / spec.sample_rate_hz * _face_gyro_bias(
        stats.gyr_mean)
    for j, a in enumerate(AXES):
        k = int(np.argmax(np.abs(w[j])))
        if k != j:
            raise DataError(
                f"turn {a}_rot turned mostly gyr_{AXES[k]} ({w[j, k]:.6g} {spec.gyr_unit} s "
                f"against {w[j, j]:.6g} on gyr_{a}): the turn or the gyro columns are mislabelled"
            )
    # Every turn the other way: the turns were made opposite to rotation_deg. Some only: those
    # gyro axes are reversed (negative scale factor), calibrated and reported by fit().
    if np.all(np.diag(w) * theta < 0):
        raise DataError(
            f"turns x_rot, y_rot, z_rot all integrate to the opposite sign of rotation_deg = "
            f"{theta:g}: set rotation_deg = {-theta:g} if the turns were made the other way "
            "(negative = clockwise about the +axis), or fix the labels"
        )


def _face_gyro_bias(gyr_mean: NDArray[np.float64]) -> NDArray[np.float64]:
    """Gyro bias i from the two faces where axis i is vertical [raw] (batched: (..., 6, 3))."""
    ax = np.arange(3)
    out: NDArray[np.float64] = (gyr_mean[..., 2 * ax, ax] + gyr_mean[..., 2 * ax + 1, ax]) / 2
    return out


# ---------------------------------------------------------------------------------------------
# closed-form solution


def _solve(
    acc_mean: NDArray[np.float64], gyr_mean: NDArray[np.float64],
    turn_gyr: NDArray[np.float64], turn_acc: NDArray[np.float64], turn_s: NDArray[np.float64],
    span: NDArray[np.float64], theta: NDArray[np.float64], with_g: bool, omega_up: float,
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray, NDArray]:
    """``A_a, b_a, A_g, b_g, G, E, a_turn`` from the part statistics (see the module docstring).

    ``E`` row j: vertical Earth-rate angle over turn j on the body axes [rad],
    ``omega_up T_j u_j`` with ``u_j`` the mean calibrated specific-force direction (up).
    ``a_turn`` row j: the calibrated specific force integrated over turn j [m/s^2 s].
    The horizontal Earth rate turns with the body during a turn and only partly cancels; it is
    not modelled (the heading is unknown) and leaves a spurious gyro misalignment
    ``W_ie cos L T_eff / theta`` (module docstring: 28 urad for the example plan).

    Every input may carry leading batch axes (``acc_mean`` (..., 6, 3), ``turn_gyr``
    (..., 3, 3)): the Jacobian evaluates all perturbed inputs in one call.
    """
    def tr(m: NDArray) -> NDArray:
        return np.swapaxes(m, -1, -2)

    ax = np.arange(3)
    A_a = tr(acc_mean[..., 0::2, :] - acc_mean[..., 1::2, :]) / span
    b_a = (acc_mean[..., 2 * ax, ax] + acc_mean[..., 2 * ax + 1, ax]) / 2
    b_g = _face_gyro_bias(gyr_mean)
    if with_g:
        G = tr(gyr_mean[..., 0::2, :] - gyr_mean[..., 1::2, :]) / span
    else:
        G = np.zeros(A_a.shape)
    cal_a = np.linalg.inv(A_a)
    acc_int = (turn_acc - turn_s[:, None] * b_a[..., None, :]) @ tr(cal_a)  # a_cal, per turn
    W = turn_gyr - turn_s[:, None] * b_g[..., None, :] - acc_int @ tr(G)
    up = acc_int / np.linalg.norm(acc_int, axis=-1, keepdims=True)
    E = omega_up * turn_s[:, None] * up
    # A_g Theta = W^T with Theta's column j the body angle of turn j: theta_j e_j + E_j.
    A_g = tr(np.linalg.solve(np.diag(theta) + E, W))
    return A_a, b_a, A_g, b_g, G, E, acc_int


def _engineering(
    A: NDArray[np.float64], b: NDArray[np.float64], G: NDArray[np.float64] | None,
    sensor: str, scale: triad.ScaleUnit,
) -> NDArray[np.float64]:
    """:func:`inertest.models.triad.engineering` of ``S = A``, ``b`` (raw units), batched.

    ``A`` (..., 3, 3), ``b`` (..., 3), ``G`` (..., 3, 3) or None; returns (..., 12 or 21):
    ``K`` [scale unit], ``M_ij = A_ij / A_ii`` [urad], ``B = A^-1 b`` [mg or deg/h] and
    ``A^-1 G`` [deg/h/g]. The raw-to-SI factor of the parameters cancels in all but ``K``.
    """
    r = scale.raw_si_per_raw
    d = np.diagonal(A, axis1=-2, axis2=-1)
    mis = np.stack([A[..., i, j] / d[..., i] for i, j in triad.OFF_DIAGONAL], axis=-1)
    rhs = b[..., None] if G is None else np.concatenate([b[..., None], G], axis=-1)
    sol = np.linalg.solve(A, rhs)  # A^-1 [b | G]: one factorisation
    out = [d * r / scale.si_per_unit, mis / MICRORAD_TO_RAD,
           sol[..., 0] / triad.bias_unit(sensor)[1]]
    if G is not None:
        out.append(sol[..., 1:].reshape(*A.shape[:-2], 9)
                   / DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2)
    return np.concatenate(out, axis=-1)


def _parameters(
    A_a: NDArray, b_a: NDArray, A_g: NDArray, b_g: NDArray, G: NDArray, with_g: bool,
    spec: FerrarisSpec,
) -> tuple[NDArray, NDArray]:
    """Triad-model parameter vectors ``[S.ravel(), b, (G.ravel())]`` in raw SI."""
    ra, rg = spec.acc_scale.raw_si_per_raw, spec.gyr_scale.raw_si_per_raw
    p_a = triad.stack_parameters(A_a * ra, b_a * ra)
    p_g = triad.stack_parameters(A_g * rg, b_g * rg, G * rg if with_g else None)
    return p_a, p_g


@functools.lru_cache(maxsize=32)
def _kinematics(motion: session.FerrarisSession, earth_rate: bool
                ) -> tuple[NDArray, NDArray, float]:
    """Specific-force span of each face pair, signed turn angles [rad], vertical Earth rate.

    From the session's motions: ``f_j(j_p) - f_j(j_a) = 2 g`` [m/s^2], each turn's signed
    table angle, the Earth rate on the up axis of a face [rad/s] (0 without ``earth_rate``).
    Cached per session (the same for every fit of a plan; arrays read-only).
    """
    faces, turns = motion.faces, motion.turns
    f_face = np.array([faces.inputs(label).f_i[0] for label in session.FACE_LABELS])
    span = np.array([f_face[2 * j, j] - f_face[2 * j + 1, j] for j in range(3)])
    theta = np.array([turns.starts[label][2] * turns.profile.angle_rad
                      for label in session.TURN_LABELS])
    omega_up = float(faces.inputs("z_p").omega_i[0, 2]) if earth_rate else 0.0
    span.flags.writeable = False
    theta.flags.writeable = False
    return span, theta, omega_up


def _pack(s: FaceStats) -> NDArray[np.float64]:
    return np.concatenate([s.acc_mean.ravel(), s.gyr_mean.ravel(),
                           s.turn_gyr_integral.ravel(), s.turn_acc_integral.ravel()])


@dataclass(frozen=True)
class SessionObservations:
    """A Ferraris session reduced: face means and turn integrals, with the session's kinematics.

    ``data`` (the columns, for the noise model's per-sample statistics), ``stats`` (per face
    and turn), ``span`` (3,) specific-force span of each face pair [m/s^2], ``theta`` (3,)
    signed turn angles [rad], ``omega_up`` Earth rate on the up axis of a face [rad/s].
    """

    data: Mapping[str, object]
    stats: FaceStats
    span: NDArray[np.float64]
    theta: NDArray[np.float64]
    omega_up: float


class Ferraris(Procedure[FerrarisSpec, SessionObservations, FerrarisResult]):
    """IMU, Ferraris session (Ferraris et al. 1995): both triads from six faces and three turns.

    Data columns ``part``, ``acc_x..acc_z`` [acc_unit], ``gyr_x..gyr_z`` [gyr_unit]. No known
    ``sigma``: the noise of every axis is estimated from the static faces.
    """

    kind = KIND
    title = "IMU, Ferraris session"
    spec = FerrarisSpec
    model = "inertest.models.imu"
    method = "closed form (face sums and differences, turn integrals); covariance by a " \
        "central-difference Jacobian over every input"
    noise_models = NOISE_MODELS
    sigma_note = "estimates the noise of every axis from the static faces"
    report = "inertest.report.ferraris:ferraris_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None
               ) -> session.FerrarisSession:
        """The session: six level faces at heading 0 and three raised-cosine turns."""
        spec: FerrarisSpec = plan.procedure
        fs = spec.sample_rate_hz
        # The rests a whole number of samples, as the simulated session records them.
        return session.FerrarisSession(plan.site, spec.rotation_deg * DEG_TO_RAD,
                                       spec.turn_duration_s, int(round(spec.rest_s * fs)) / fs)

    def reduce(self, plan: Plan, data: Mapping[str, object],
               motion: session.FerrarisSession) -> SessionObservations:
        """Face means and turn integrals of each part, checked, and the session's kinematics.

        The kinematics: the specific-force span of each face pair (f_j(j_p) - f_j(j_a) = 2 g),
        each turn's signed table angle and the vertical Earth rate (on the up axis of a face).
        The vertical during a hand turn comes from the accelerometers.
        """
        spec: FerrarisSpec = plan.procedure
        stats = part_stats(data, spec)
        _check_labels(stats, spec)
        span, theta, omega_up = _kinematics(motion, spec.earth_rate)
        return SessionObservations(data, stats, span, theta, omega_up)

    def identify(self, plan: Plan, obs: SessionObservations, *, sigma: float | None,
                 noise_model: str | None) -> FerrarisResult:
        """Calibrate the accelerometer and gyro triads (closed form) with their covariance."""
        spec: FerrarisSpec = plan.procedure
        model = str(noise_model)
        data, stats = obs.data, obs.stats
        g = plan.site.gravity_m_s2
        fs = spec.sample_rate_hz
        turn_s = stats.n_turn / fs
        with_g = spec.g_sensitivity
        span, theta, omega_up = obs.span, obs.theta, obs.omega_up

        def solve(x: NDArray[np.float64]) -> tuple[NDArray, ...]:
            return _solve(x[:18].reshape(6, 3), x[18:36].reshape(6, 3), x[36:45].reshape(3, 3),
                          x[45:54].reshape(3, 3), turn_s, span, theta, with_g, omega_up)

        x0 = _pack(stats)
        A_a, b_a, A_g, b_g, G, E, _ = solve(x0)
        cal_a = np.linalg.inv(A_a)

        # Input covariance of the noise (face means, turn integrals) under the noise model.
        cov, components, notes = _noise_covariance(data, stats, spec, model)
        # Redundancy: the six off-axis pair sums of each sensor (face tilt disagreement, and under
        # position-offsets the offsets of the faces), linear in the face means.
        L_a, L_g = _pair_sums(0), _pair_sums(18)
        resid_raw = L_a @ x0
        var_d = np.einsum("ij,jk,ik->i", L_a, cov, L_a)  # their variance under the noise model
        half_sum = ((stats.acc_mean[0::2] + stats.acc_mean[1::2]) / 2 - b_a) @ cal_a.T
        d_off = np.array([half_sum[i, k] for i, k in _OFF])  # [m/s^2]
        if model == "position-offsets":
            # E[d^2] = sigma_o^2 + noise: an offset of each part (IMU re-set) in every channel;
            # horizontal face tilts act like offsets, so they are counted in it (tau = 0).
            tau2 = 0.0
            d_g = L_g @ x0
            var_dg = np.einsum("ij,jk,ik->i", L_g, cov, L_g)
            s2o = (max(0.0, float(np.mean(resid_raw**2 - var_d))),
                   max(0.0, float(np.mean(d_g**2 - var_dg))))
            for (means, turns), s2 in (((0, 45), s2o[0]), ((18, 36), s2o[1])):  # acc, gyro
                i_face = means + np.arange(18)
                i_turn = turns + np.arange(9)
                cov[i_face, i_face] += s2  # a mean offset per face and channel
                cov[i_turn, i_turn] += s2 * np.repeat(turn_s, 3) ** 2  # an offset x T per turn
            components["accelerometer"]["position offset"] = float(np.sqrt(s2o[0]))
            components["gyroscope"]["position offset"] = float(np.sqrt(s2o[1]))
        else:
            # Tilts only where the pair sums exceed the noise (chi-square of the six against their
            # covariance under the noise model, level TILT_ALPHA): a variance from six values,
            # clipped at zero, would otherwise add a spurious tilt to the misalignments' std.
            kk = np.array([A_a[k, k] for _, k in _OFF])
            C_d = L_a @ cov @ L_a.T
            chi2 = float(resid_raw @ np.linalg.lstsq(C_d, resid_raw, rcond=1e-12)[0])
            tau2 = 0.0
            if scipy.special.chdtrc(len(_OFF), chi2) < TILT_ALPHA:  # chi-square survival
                tau2 = max(0.0, float(2.0 * np.mean(d_off**2 - var_d / kk**2)) / g**2)
        # Second order of the face tilts: a face tilted by t reads g cos t on its vertical axis, so
        # a pair spans 2 g (1 - tau^2) on average and the scale factors come out low by tau^2.
        tilt2, var_tilt2 = (_tilt_second_order(d_off, var_d, A_a, g) if spec.tilt_correction
                            else (0.0, 0.0))
        span0 = span
        span = span0 * (1.0 - tilt2)  # read by solve() and outputs() below
        A_a, b_a, A_g, b_g, G, E, acc_int = solve(x0)
        cal_a = np.linalg.inv(A_a)
        fitted_offsets = int(model == "position-offsets") * sum(
            components[k].get("position offset", 0.0) > 0 for k in components)
        cov_noise = cov.copy()  # the noise model alone, for the model checks
        # Face tilts (on the acc means, first order on the horizontal axes).
        cov += _tilt_covariance(A_a, g, tau2)

        sa, sg = spec.acc_scale, spec.gyr_scale
        n_a = 12

        def outputs(x: NDArray[np.float64], spans: NDArray[np.float64] | None = None
                    ) -> NDArray[np.float64]:
            """Engineering values of both triads, then the turns' |a| - g [m/s^2] (batched).

            ``spans`` (..., 3): the face-pair spans of each input (default ``span``).
            """
            bx = x.shape[:-1]
            A_a_, b_a_, A_g_, b_g_, G_, _, acc_int = _solve(
                x[..., :18].reshape(*bx, 6, 3), x[..., 18:36].reshape(*bx, 6, 3),
                x[..., 36:45].reshape(*bx, 3, 3), x[..., 45:54].reshape(*bx, 3, 3),
                turn_s, span if spans is None else spans[..., None, :], theta, with_g, omega_up)
            return np.concatenate([
                _engineering(A_a_, b_a_, None, "accelerometer", sa),
                _engineering(A_g_, b_g_, G_ if with_g else None, "gyroscope", sg),
                np.linalg.norm(acc_int, axis=-1) / turn_s - g], axis=-1)

        # Values as the closed form gives them; their covariance (both triads, cross terms kept:
        # the gyro uses the acc) by a central-difference Jacobian over every input at once.
        p0 = np.concatenate(_parameters(A_a, b_a, A_g, b_g, G, with_g, spec))
        v_a = triad.engineering(p0[:n_a], "accelerometer", sa)
        v_g = triad.engineering(p0[n_a:], "gyroscope", sg)
        values = np.concatenate([v_a, v_g])
        f0, J = _jacobian(outputs, x0, np.sqrt(np.diag(cov)))
        cov_all = J @ cov @ J.T
        if var_tilt2 > 0:  # the uncertainty of the tilt correction (its six pair sums)
            h = 1e-3 * np.sqrt(var_tilt2)
            lo, hi = outputs(np.stack([x0, x0]),
                             np.stack([span0 * (1.0 - tilt2 - h), span0 * (1.0 - tilt2 + h)]))
            j_t = (lo - hi) / (2 * h)
            cov_all += var_tilt2 * np.outer(j_t, j_t)
        n_v = values.size
        cov_out = cov_all[:n_v, :n_v]
        std = np.sqrt(np.clip(np.diag(cov_out), 0.0, None))
        triads = (
            TriadEstimates.from_engineering(v_a, cov_out[:n_a, :n_a], sensor="accelerometer",
                                            scale=sa),
            TriadEstimates.from_engineering(v_g, cov_out[n_a:, n_a:], sensor="gyroscope", scale=sg),
        )
        turn_gravity = f0[n_v:]
        checks = _model_checks(
            pair_acc=resid_raw, pair_gyr=L_g @ x0, turn_gravity=turn_gravity,
            cov_pairs=(L_a @ cov_noise @ L_a.T, L_g @ cov_noise @ L_g.T),
            cov_turn=cov_all[n_v:, n_v:],
            A_a=A_a, A_g=A_g, g=g, latitude_rad=plan.site.latitude_rad, spec=spec, model=model,
            fitted_offsets=fitted_offsets)

        names = ACC_NAMES + GYR_NAMES + (G_NAMES if with_g else ())
        ua, ug = triad.units_of("accelerometer", sa), triad.units_of("gyroscope", sg, with_g)
        units = tuple(ua.values()) + tuple(ug.values())
        coefficients = {
            nm: Estimate(nm, float(v), float(s), u)
            for nm, v, s, u in zip(names, values, std, units, strict=True)
        }
        not_sep: tuple[str, ...] = (
            "accelerometer misalignments Ma_ij vs. face tilts: half the difference of the off-axis "
            "tilts of each up/down face pair enters like a misalignment (six faces cannot separate "
            "them); the misalignments refer to the faces as set, and the tilt scatter "
            f"({np.degrees(np.sqrt(tau2)):.2g} deg from the pair disagreement) is in their std",
        )
        if not with_g:
            not_sep += ("gyro g-sensitivity: not estimated (set g_sensitivity = true to "
                        "estimate it from the up/down faces)",)
        # The residuals of the design are the six off-axis pair sums (face tilt disagreement).
        resid_rms = float(np.sqrt(np.mean(resid_raw**2)))
        ident = Identification(
            coefficients=coefficients, combinations=(), not_separable=not_sep,
            covariance=cov_out, names=names, noise_sigma=resid_rms, noise_unit=spec.acc_unit,
            sigma_from_residuals=True, dof=6, rank=len(names), residuals=resid_raw,
            noise_model=model, noise_components=dict(components["accelerometer"]),
            checks=checks,
        )
        if not checks.fits:
            warnings.warn(str(checks.message), InertestWarning, stacklevel=3)

        cal_g = np.linalg.inv(A_g)
        calibration = ImuCalibration(
            accelerometer=TriadCalibration(cal_a, b_a, unit="m/s^2", raw_unit=spec.acc_unit),
            gyroscope=TriadCalibration(cal_g, b_g, unit="rad/s",
                                       raw_unit=spec.gyr_unit, g_sensitivity=G if with_g else None),
        )  # in the recorded raw units: the same as triad.calibration_from_parameters
        face_acc = (stats.acc_mean - b_a) @ cal_a.T
        face_err = np.linalg.norm(face_acc, axis=1) - g
        W = stats.turn_gyr_integral - turn_s[:, None] * b_g - acc_int @ G.T  # acc_int: solve()
        turn_angle = (W @ cal_g.T - E) / DEG_TO_RAD  # the turn without Earth rate
        messages = list(notes)
        for m, sensor, col in ((p0[:n_a], "accelerometer", "acc_{}"),
                               (p0[n_a:], "gyroscope", "gyr_{}")):
            msg = triad.reversed_axes_message(m, sensor, col)
            if msg is not None:
                messages.append(msg + (" (for an accelerometer, swapped _p/_a face labels look the "
                                       "same)" if sensor == "accelerometer" else ""))
        bad = np.flatnonzero(np.abs(face_err) > FACE_GRAVITY_TOLERANCE_M_S2)
        for f in bad:
            messages.append(
                f"face {session.FACE_LABELS[f]}: calibrated |a| misses g by "
                f"{face_err[f] / MILLI_G_TO_M_PER_S2:.3g} mg (more than "
                f"{FACE_GRAVITY_TOLERANCE_M_S2 / MILLI_G_TO_M_PER_S2:g} mg): did the IMU move on "
                "it?"
            )
        return FerrarisResult(
            site_latitude_deg=plan.site.latitude_deg,
            site_gravity_m_s2=g,
            identification=ident,
            calibration=calibration,
            triads=triads,
            stats=stats,
            face_gravity_error_m_s2=face_err,
            turn_angle_deg=turn_angle,
            tilt_scatter_deg=float(np.sqrt(tau2) / DEG_TO_RAD),
            noise_components=components,
            stats_units=(spec.acc_unit, spec.gyr_unit),
            rotation_deg=spec.rotation_deg,
            residual_output=resid_raw,
            output_unit=spec.acc_unit,
            messages=tuple(messages),
        )

    def synthesize(self, plan: Plan, motion: session.FerrarisSession,
                   truth: Mapping[str, float], *, noise: float,
                   rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """A virtual Ferraris session: six faces (random tilts if asked), three turns.

        ``truth``: ``Ka_*`` [count/(m/s^2) or 1], ``Ma_ij`` [urad], ``Ba_*`` [mg], ``Kg_*``
        [count/(deg/s) or 1], ``Mg_ij`` [urad], ``Bg_*`` [deg/h], ``Gg_ij`` [deg/h/g] (the units
        of the fit's result), and ``face_tilt_deg`` (std of each face's random tilt about each
        horizontal axis, default 0), ``acc_noise``, ``gyr_noise`` (white noise per sample in the
        raw units; default ``noise``, which must then not be given). Scale factors may be left
        out when the raw unit is not ``count`` (nominal scale 1). With ``earth_rate`` (plan),
        the Earth rate at the site is included (faces at heading 0).

        Returns columns ``part``, ``t_s``, ``acc_x..acc_z``, ``gyr_x..gyr_z``.
        """
        spec: FerrarisSpec = plan.procedure
        gen = np.random.default_rng(rng)
        A_a, b_a, A_g, b_g, G = _model_from_truth(truth, spec)
        fs = spec.sample_rate_hz
        tilt = float(truth.get("face_tilt_deg", 0.0)) * DEG_TO_RAD
        if noise and ("acc_noise" in truth or "gyr_noise" in truth):
            raise PlanError(
                "the truth gives acc_noise/gyr_noise and a noise level was given as well; "
                "give it in one place only"
            )
        s_a = float(truth.get("acc_noise", noise))
        s_g = float(truth.get("gyr_noise", noise))
        if min(s_a, s_g, tilt) < 0:
            raise PlanError("noise levels and face_tilt_deg must be >= 0")
        n_face = int(round(spec.face_duration_s * fs))
        n_turn, n_rest = _turn_samples(spec)
        faces, turns = motion.faces, motion.turns
        w_ie = earth_rate_enu(plan.site.latitude_rad)
        parts, f_all, w_all = [], [], []
        for label, axis, _ in session.FACES:
            inp = faces.inputs(label, np.zeros(n_face))
            f = inp.f_i
            if tilt > 0:  # a hand-set face: tilted by a small random angle about horizontal axes
                t = gen.normal(0.0, tilt, 3)
                t[axis] = 0.0
                f = Rotation.from_rotvec(t).apply(f)
            parts += [label] * n_face
            f_all.append(f)
            w_all.append(inp.omega_i if spec.earth_rate else _without_earth(inp, w_ie))
        t_turn = np.arange(n_turn + 2 * n_rest) / fs
        for label in session.TURN_LABELS:
            # The continuous motion sampled at the sample times: the raised-cosine rate about the
            # vertical axis, the Earth rate turning the other way in the body (exact attitude).
            inp = turns.inputs(label, t_turn)
            parts += [label] * t_turn.size
            f_all.append(inp.f_i)
            w_all.append(inp.omega_i if spec.earth_rate else _without_earth(inp, w_ie))
        f_b = np.vstack(f_all)
        w_b = np.vstack(w_all)
        n = len(parts)
        acc = f_b @ A_a.T + b_a
        gyr = w_b @ A_g.T + b_g + f_b @ G.T
        if s_a > 0:
            acc = acc + gen.normal(0.0, s_a, acc.shape)
        if s_g > 0:
            gyr = gyr + gen.normal(0.0, s_g, gyr.shape)
        out: dict[str, NDArray] = {"part": np.array(parts), "t_s": np.arange(n) / fs}
        for k in range(3):
            out[ACC_COLUMNS[k]] = acc[:, k]
        for k in range(3):
            out[GYR_COLUMNS[k]] = gyr[:, k]
        return out


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = Ferraris()


def _tilt_second_order(d_off: NDArray[np.float64], var_d: NDArray[np.float64],
                       A_a: NDArray[np.float64], g: float) -> tuple[float, float]:
    """``E[1 - cos t]`` of the face tilts from the six off-axis pair sums, and its variance.

    A face tilted by ``t`` (two horizontal components of variance ``tau^2`` each) reads
    ``g cos t ~ g (1 - t^2 / 2)`` on its vertical axis, ``E[1 - cos t] = tau^2``: the span of a
    face pair is ``2 g (1 - tau^2)`` on average, so dividing by ``2 g`` puts the scale factors
    low by ``tau^2`` (7.6e-5 at 0.5 deg), a bias the first-order propagation does not see. Each
    pair sum ``d`` [m/s^2] holds one tilt component of each of its two faces,
    ``E[d^2] = g^2 tau^2 / 2 + noise`` (``var_d`` [raw unit^2] through the diagonal of ``A_a``),
    so ``tau^2 = 2 mean(d^2 - noise) / g^2`` (clipped at 0) and, the six independent,
    ``Var = (4 / g^4) (2 / 6) (E[d^2])^2``. Corrected rather than added to the std: the bias is
    one-sided and known to first order in the tilt variance. Under ``position-offsets`` the
    pair sums also hold the face offsets, so this is an upper bound (it over-corrects by
    ``(offset / g)^2``, 1e-5 for a 3 mg offset).
    """
    kk = np.array([A_a[k, k] for _, k in _OFF])
    noise = var_d / kk**2
    tau2 = max(0.0, float(2.0 * np.mean(d_off**2 - noise)) / g**2)
    e_d2 = g**2 * tau2 / 2 + float(np.mean(noise))
    return tau2, 4.0 / g**4 * (2.0 / len(_OFF)) * e_d2**2


@functools.lru_cache(maxsize=2)
def _pair_sums(first: int) -> NDArray[np.float64]:
    """The six off-axis pair sums as rows over the packed inputs, shape (6, 54).

    Row (i, k): ``(u_k(i_p) + u_k(i_a))/2 - (u_k(k_p) + u_k(k_a))/2`` of the face means
    starting at ``first`` (0: acc, 18: gyro).
    """
    L = np.zeros((len(_OFF), 54))
    for r, (i, k) in enumerate(_OFF):
        for f, w in ((2 * i, 0.5), (2 * i + 1, 0.5), (2 * k, -0.5), (2 * k + 1, -0.5)):
            L[r, first + 3 * f + k] += w
    L.flags.writeable = False
    return L


def _tilt_covariance(A_a: NDArray[np.float64], g: float, tau2: float) -> NDArray[np.float64]:
    """Covariance (54, 54) that face tilts of variance ``tau2`` [rad^2] per horizontal axis add.

    Each face's specific force gets ``g t`` on its two horizontal axes (first order), read
    through ``A_a`` by the accelerometer means; faces independent.
    """
    out = np.zeros((54, 54))
    for f, (_, axis, _) in enumerate(session.FACES):
        P = np.eye(3)
        P[axis, axis] = 0.0
        sl = slice(3 * f, 3 * f + 3)
        out[sl, sl] = g**2 * tau2 * A_a @ P @ A_a.T
    return out


def _model_checks(
    *, pair_acc: NDArray[np.float64], pair_gyr: NDArray[np.float64],
    turn_gravity: NDArray[np.float64], cov_pairs: tuple[NDArray[np.float64], NDArray[np.float64]],
    cov_turn: NDArray[np.float64], A_a: NDArray[np.float64], A_g: NDArray[np.float64], g: float,
    latitude_rad: float, spec: FerrarisSpec, model: str, fitted_offsets: int,
) -> ModelChecks:
    """The session's redundancy against the noise model (module docstring, "Model checks").

    Fifteen checks, each with its variance under the noise model: the six off-axis pair sums
    of the accelerometers [acc_unit] (noise plus face tilts of the plan's ``face_tilt_deg``),
    the six of the gyros [gyr_unit] (noise plus the horizontal Earth rate of an unknown
    heading, variance ``(W_ie cos L)^2 / 2`` per axis), and each turn's ``|integral a_cal| / T
    - g`` [m/s^2] (noise propagated through the calibration, plus the hand-turn allowance
    :data:`TURN_GRAVITY_ALLOWANCE_M_S2`). Chi-square over the three blocks (each whitened by its
    covariance) with ``15 - fitted`` dof, outliers by their marginal ``z`` above a Bonferroni
    bound, verdict at :data:`~inertest.estimation.identify.CHECK_ALPHA`.
    """
    kk_g = np.array([A_g[k, k] for _, k in _OFF])
    V_a = cov_pairs[0]
    if model != "position-offsets":  # there the tilts are in the fitted offsets
        V_a = V_a + _pair_sums(0) @ _tilt_covariance(
            A_a, g, (spec.face_tilt_deg * DEG_TO_RAD) ** 2) @ _pair_sums(0).T
    w_h = OMEGA_IE * np.cos(latitude_rad)
    V_g = cov_pairs[1] + np.diag((kk_g * w_h) ** 2 / 2)
    V_t = cov_turn + TURN_GRAVITY_ALLOWANCE_M_S2**2 * np.eye(3)
    chi2 = 0.0
    z = []
    for c, V in ((pair_acc, V_a), (pair_gyr, V_g), (turn_gravity, V_t)):
        chi2 += float(c @ np.linalg.solve(V, c))
        z.append(c / np.sqrt(np.diag(V)))
    zz = np.concatenate(z)
    labels = ([f"{AXES[i]} faces, acc_{AXES[k]}" for i, k in _OFF]
              + [f"{AXES[i]} faces, gyr_{AXES[k]}" for i, k in _OFF]
              + [f"{lab} |a| - g" for lab in session.TURN_LABELS])
    n = zz.size
    dof = n - fitted_offsets
    p = float(scipy.special.chdtrc(dof, chi2))  # chi-square survival function
    thr = outlier_threshold(n)  # Bonferroni
    outliers = tuple(Outlier(labels[i], float(zz[i])) for i in np.flatnonzero(np.abs(zz) > thr))
    statistic = ("chi-square of the 6 + 6 off-axis face-pair sums (accelerometer, gyro) and the "
                 "3 turns' |a| - g against the noise model, face tilts and Earth rate")
    if fitted_offsets:
        statistic += " (the pair sums also gave the position offsets: a weak test)"
    checks = ModelChecks(
        noise_model=model, unit="face pair / turn", n_units=n, statistic=statistic,
        chi_square=chi2, dof=dof, p_value=p, serial_chi_square=None, serial_dof=0,
        serial_p_value=None, outliers=outliers, outlier_threshold=thr, alpha=CHECK_ALPHA,
        verdict="model does not fit" if p < CHECK_ALPHA or outliers else "consistent",
        name="face pairs and turns against the noise model")
    return checks if checks.fits else replace(checks, message=misfit_message(
        checks, what="the session", prefix=f"{KIND}: ",
        check="the face and turn labels (a face with the IMU moving or not lying flat, a turn "
              "label running into the next face), the face_tilt_deg of the plan and the noise "
              "model"))


def _noise_covariance(
    data: Mapping[str, object], stats: FaceStats, spec: FerrarisSpec, model: str,
) -> tuple[NDArray[np.float64], dict[str, dict[str, float]], list[str]]:
    """Covariance of the packed inputs (face means, turn integrals) under the noise model.

    ``white`` (and the white part of ``position-offsets``): face means with their own sample
    variance / n, turn integrals with the pooled static noise x n_turn / fs^2 (channels and
    parts independent). ``random-walk``, ``flicker``: each channel's white level and drift
    level are estimated by :func:`inertest.estimation.identify.solve` from the face samples
    (blocks of each face as units, the face means as the model, so only the within-face
    wander is used), and propagated to every face mean and turn integral, correlated across
    the parts through the drift's row kernel over the session
    (:meth:`inertest.estimation.noise_models.NoiseModel.row_apply`, rows in time order at
    ``sample_rate_hz``; the same noise model as the fit of the faces). Returns the covariance
    (54, 54), the components per sensor (RMS over its channels, raw unit per sample) and notes
    on channels whose noise model does not fit.
    """
    fs = spec.sample_rate_hz
    n = 54
    cov = np.zeros((n, n))
    comps: dict[str, dict[str, float]] = {}
    notes: list[str] = []
    n_face, n_turn = stats.n_face, stats.n_turn
    if model in ("white", "position-offsets"):
        var_a = (stats.acc_std**2 / n_face[:, None]).ravel()
        var_g = (stats.gyr_std**2 / n_face[:, None]).ravel()
        cov[np.arange(18), np.arange(18)] = var_a
        cov[np.arange(18, 36), np.arange(18, 36)] = var_g
        pooled_g = np.sqrt(np.mean(stats.gyr_std**2, axis=0))
        pooled_a = np.sqrt(np.mean(stats.acc_std**2, axis=0))
        for j in range(3):
            idx = 36 + 3 * j + np.arange(3)
            cov[idx, idx] = n_turn[j] * pooled_g**2 / fs**2
            idx = 45 + 3 * j + np.arange(3)
            cov[idx, idx] = n_turn[j] * pooled_a**2 / fs**2
        comps["accelerometer"] = {"white": float(np.sqrt(np.mean(pooled_a**2)))}
        comps["gyroscope"] = {"white": float(np.sqrt(np.mean(pooled_g**2)))}
        return cov, comps, notes
    cols = {c: np.asarray(data[c], dtype=float) for c in ACC_COLUMNS + GYR_COLUMNS}
    face_rows = np.concatenate(stats.rows[:6])
    face_of = np.repeat(np.arange(6), [r.size for r in stats.rows[:6]])
    block = np.concatenate([np.arange(r.size) * _BLOCKS_PER_FACE // r.size
                            for r in stats.rows[:6]])
    order = np.argsort(face_rows, kind="stable")
    face_rows, face_of, block = face_rows[order], face_of[order], block[order]
    groups = np.char.add(np.char.add(face_of.astype(str), "#"), block.astype(str))
    A = (face_of[:, None] == np.arange(6)[None, :]).astype(float)
    n_rows = max(int(r.max()) for r in stats.rows) + 1
    drift = MODELS[model]
    label = str(drift.component)
    Mt = np.zeros((n_rows, 9))
    for u, r in enumerate(stats.rows):
        Mt[r, u] = 1.0 / r.size if u < 6 else 1.0 / fs
    # (9, 9): the drift's covariance of the face means and turn integrals over the session, at
    # the level fitted on the face samples (unit variance per sample of that record).
    unit_k = Mt.T @ drift.row_apply(Mt, level_rows=face_rows.size)
    unit_w = np.r_[1.0 / n_face, n_turn / fs**2]
    for sensor, names, means, turns in (("accelerometer", ACC_COLUMNS, 0, 45),
                                        ("gyroscope", GYR_COLUMNS, 18, 36)):
        levels: dict[str, list[float]] = {"white": [], label: []}
        for c, name in enumerate(names):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", InertestWarning)
                _, nf = identify_solve(A, cols[name][face_rows], groups=groups,
                                       noise_model=model)
            if not nf.checks.fits:
                notes.append(f"{name}: the {model} noise model does not fit the face samples "
                             f"({nf.checks.verdict}); its uncertainties are not reliable")
            w, d = nf.components["white"], nf.components.get(label, 0.0)
            idx = np.r_[means + c + 3 * np.arange(6), turns + c + 3 * np.arange(3)]
            cov[np.ix_(idx, idx)] = w**2 * np.diag(unit_w) + d**2 * unit_k
            levels["white"].append(w)
            levels[label].append(d)
        comps[sensor] = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in levels.items()}
    return cov, comps, notes


def _jacobian(func, x0: NDArray[np.float64], scale: NDArray[np.float64]
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``func(x0)`` and its central-difference Jacobian, steps 1e-3 of each input's std.

    The map is smooth (ratios and a 3x3 inverse); steps far below the input spread keep the
    truncation error negligible against the propagated uncertainty. ``func`` is evaluated once,
    on ``x0`` and all ``2 x0.size`` perturbed inputs stacked along a leading axis.
    """
    h = np.where(scale > 0, 1e-3 * scale, 1e-6 * np.maximum(1.0, np.abs(x0)))
    steps = np.diag(h)
    f = func(np.concatenate([x0 + steps, x0 - steps, x0[None, :]]))
    n = x0.size
    J: NDArray[np.float64] = ((f[:n] - f[n:2 * n]) / (2 * h[:, None])).T
    return f[2 * n], J


# ---------------------------------------------------------------------------------------------
# simulation


def _model_from_truth(
    truth: Mapping[str, float], spec: FerrarisSpec
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
    """``A_a`` [raw per m/s^2], ``b_a``, ``A_g`` [raw per rad/s], ``b_g``, ``G`` [raw per m/s^2]."""
    known = set(ACC_NAMES + GYR_NAMES + G_NAMES) | {"face_tilt_deg", "acc_noise", "gyr_noise"}
    unknown = sorted(set(truth) - known)
    if unknown:
        raise PlanError(
            f"truth has unknown name(s) {', '.join(unknown)}; ferraris knows "
            "Ka_x.., Ma_xy.. [urad], Ba_x.. [mg], Kg_x.., Mg_xy.., Bg_x.. [deg/h], "
            "Gg_xx.. [deg/h/g], face_tilt_deg, acc_noise, gyr_noise"
        )

    out = []
    for letter, sensor, scale in (("a", "accelerometer", spec.acc_scale),
                                  ("g", "gyroscope", spec.gyr_scale)):
        p = triad.parameters_from_engineering(truth, sensor, scale, prefix=letter,
                                              what=f"truth of the {sensor}")
        r = scale.raw_si_per_raw  # raw unit per input SI unit: divide the raw-SI parameters
        out += [p[:9].reshape(3, 3) / r, p[9:12] / r]
        if sensor == "gyroscope":
            out.append(p[12:21].reshape(3, 3) / r if p.size == 21 else np.zeros((3, 3)))
    return out[0], out[1], out[2], out[3], out[4]


def _turn_samples(spec: FerrarisSpec) -> tuple[int, int]:
    """Samples of a turn and of each rest; the turn must be a whole number of samples.

    Then the samples of the raised-cosine rate sum to exactly ``angle * rate``: the sampled
    turn integrates to the turn angle (the fit's rectangle rule is exact for it).
    """
    fs = spec.sample_rate_hz
    n_turn = int(round(spec.turn_duration_s * fs))
    if n_turn < 2 or abs(n_turn - spec.turn_duration_s * fs) > 1e-9 * n_turn:
        raise PlanError(
            f"turn_duration_s = {spec.turn_duration_s:g} s times sample_rate_hz = {fs:g} Hz "
            "must be a whole number of samples (>= 2)")
    return n_turn, int(round(spec.rest_s * fs))


def _without_earth(inp: Inputs, w_ie: NDArray[np.float64]) -> NDArray[np.float64]:
    """``omega_i`` of a motion less the Earth rate ``C_ni^T W_ie_n`` (``earth_rate = false``)."""
    return inp.omega_i - np.einsum("kji,j->ki", inp.C_ni, w_ie)
