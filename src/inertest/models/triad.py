"""The one IMU-triad error model: scale factor, misalignment, bias, g-sensitivity.

A triad is three accelerometers or three gyros on (nearly) orthogonal axes.

Every procedure and analysis that touches a triad uses this module: triad-multiposition,
gyro-triad-rotation, ferraris, the navigation-mode iteration, rotation modulation, the CLI.

Output model (seed ``003_f374f866dfe7c99f.txt``, FOG triad output model, eq. (1))::

    raw = K (I + M) u + b  [+ G a]          S = K (I + M)  (the "forward" matrix)

``u`` the true input on the triad's orthogonal reference axes (SI: m/s^2 or rad/s), ``K``
diagonal scale factors [raw-SI unit per SI unit], ``M`` small misalignment / non-orthogonality
(dimensionless, zero diagonal), ``b`` bias [raw-SI unit] and, for gyros, ``G`` the g-sensitivity
[raw-SI unit per m/s^2 of specific force ``a``]. Parameter vector of the fits::

    p = [S.ravel() (9, row-wise), b (3), G.ravel() (9, gyros with g-sensitivity)]

The inverse, used to correct recordings, is the calibration::

    calibrated = matrix @ (raw - offset)                            (accelerometer)
    calibrated = matrix @ (raw - g_sensitivity @ a_cal - offset)     (gyroscope)

so ``matrix = (K (I + M))^-1`` and ``offset = b``; in JSON (every triad procedure's result)::

    "calibration": {"accelerometer": {"matrix": 3x3, "offset": [3], "unit": ..., "raw_unit": ...},
                    "gyroscope": {"matrix": 3x3, "offset": [3], "g_sensitivity": 3x3, ...}}

``g_sensitivity`` is in raw units per (m/s^2) of *calibrated* acceleration.

Conventions (written here once; every procedure follows them)
--------------------------------------------------------------
* **Misalignment index order.** ``M_ij`` (``i != j``) is the sensitivity of **sensor i** (first
  index, the output) to the input **along / about reference axis j** (second index), relative
  to sensor i's scale factor: ``M_ij = S_ij / S_ii``. Example: ``M_xy`` is how much of the rate
  about y (or specific force along y) the x gyro (accelerometer) reads. The reference axes are
  those of the test fixture (turntable, cube faces), so all six ``M_ij`` are free:
  ``M_ij + M_ji`` is the mounting rotation, ``M_ij - M_ji`` the non-orthogonality.
  Names and order: ``M_xy, M_xz, M_yx, M_yz, M_zx, M_zy`` (:data:`MISALIGNMENT_NAMES`).
  Reported in **urad** everywhere (IEEE Std 952-1997 specification format).
* **Scale factor** ``K_i = S_ii``: raw output per unit input. Accelerometers: raw unit per
  (m/s^2) (``count/(m/s^2)``). Gyros: **raw rate reading per (deg/s)**, one rule for every
  output kind: a digital rate reading (one count per sample, e.g. a MEMS LSB) gives
  ``count/(deg/s)``; a pulse output is read as the pulse rate count/s, so its scale factor is
  (count/s)/(deg/s), written ``count/deg`` -- the same number as counts per degree turned;
  an electrical output gives ``V/(deg/s)``, ``mA/(deg/s)``. An output already in a physical unit
  of the input (m/s^2, g, deg/s, rad/s, ...) is converted to SI first and its scale factor is
  dimensionless ``1``. Scale-factor deviation from nominal in **ppm** (nominal 1 for physical
  outputs, the plan's nominal for counts).
* **Sign of the bias.** The bias adds to the output: a positive ``b_i`` raises sensor i's
  reading. It is reported input-referred, ``B = S^-1 b`` (the input that produces the output
  ``b``; so a positive ``B_i`` means sensor i reads high), in **mg** (accelerometers) and
  **deg/h** (gyros). Gyro g-sensitivity input-referred, ``S^-1 G``, in **deg/h/g**.
* **Negative scale factors** (an axis mounted reversed, a negated channel) are legal in the
  model: ``K_i < 0`` with the same misalignment definition. Procedures report them with a
  message instead of refusing them (:func:`reversed_axes_message`).

Uncertainties are propagated through one Jacobian (:func:`engineering_jacobian`, complex step,
Squire & Trapp, SIAM Review 40(1), 1998, doi:10.1137/S003614459631241X): engineering quantities
from the parameter vector ``p``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import IdentifiabilityError, InputError, PlanError
from inertest.units import (
    ACCEL_UNITS,
    DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2,
    DEG_PER_H_TO_RAD_PER_S,
    DEG_PER_S_TO_RAD_PER_S,
    MICRORAD_TO_RAD,
    MILLI_G_TO_M_PER_S2,
    PPM_TO_RATIO,
    RATE_UNITS,
)

AXES = ("x", "y", "z")
SENSORS = ("accelerometer", "gyroscope")
#: (sensor i, reference axis j) of each misalignment, in the order of :data:`MISALIGNMENT_NAMES`.
OFF_DIAGONAL: tuple[tuple[int, int], ...] = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
#: Names of the scale factors, misalignments, biases and g-sensitivities (result order).
SCALE_NAMES = tuple(f"K_{a}" for a in AXES)
MISALIGNMENT_NAMES = tuple(f"M_{AXES[i]}{AXES[j]}" for i, j in OFF_DIAGONAL)
BIAS_NAMES = tuple(f"B_{a}" for a in AXES)
G_SENSITIVITY_NAMES = tuple(f"G_{a}{c}" for a in AXES for c in AXES)
#: Engineering units of the quantities that have one unit whatever the raw output.
MISALIGNMENT_UNIT = "urad"
SCALE_DEVIATION_UNIT = "ppm"
G_SENSITIVITY_UNIT = "deg/h/g"
#: Input-referred bias: engineering unit and its SI value, per sensor.
BIAS_UNITS: dict[str, tuple[str, float]] = {
    "accelerometer": ("mg", MILLI_G_TO_M_PER_S2),
    "gyroscope": ("deg/h", DEG_PER_H_TO_RAD_PER_S),
}
#: SI unit of each sensor's input.
INPUT_SI_UNITS = {"accelerometer": "m/s^2", "gyroscope": "rad/s"}


def _check_sensor(sensor: str) -> None:
    if sensor not in SENSORS:
        raise InputError(f'sensor must be one of {", ".join(SENSORS)}, got "{sensor}"')


@dataclass(frozen=True)
class ScaleUnit:
    """How a triad's scale factor is reported (module docstring: the rule).

    Attributes
    ----------
    unit : str
        Unit of ``K`` (``"count/(m/s^2)"``, ``"count/(deg/s)"``, ``"count/deg"``, ``"1"``...).
    si_per_unit : float
        SI value (raw-SI per input SI) of one ``unit``.
    raw_si_per_raw : float
        Factor from the recorded raw output to the raw-SI used in the fit (1 for counts and
        electrical outputs; the unit factor when the raw output is a physical unit such as
        ``g`` or ``deg/s``).
    nominal : float or None
        Nominal scale factor [unit] (1 for physical outputs); None for counts.
    """

    unit: str
    si_per_unit: float
    raw_si_per_raw: float
    nominal: float | None

    def with_nominal(self, nominal: float | None) -> ScaleUnit:
        """The same unit with a nominal scale factor (for the ppm deviation of count outputs)."""
        if nominal is None or self.nominal is not None:
            return self
        return ScaleUnit(self.unit, self.si_per_unit, self.raw_si_per_raw, float(nominal))


def scale_unit(raw_unit: str, sensor: str) -> ScaleUnit:
    """The reporting unit of ``K`` for a triad whose raw output (rate reading) is ``raw_unit``.

    Parameters
    ----------
    raw_unit : str
        Unit of one raw reading. Gyros: a rate reading, i.e. ``"count"`` for a digital reading
        per sample, ``"count/s"`` for a pulse output, ``"V"``, ``"mA"``... or a rate unit.
    sensor : {"accelerometer", "gyroscope"}

    Returns
    -------
    ScaleUnit
        Accelerometers: ``<raw>/(m/s^2)``; gyros: ``<raw>/(deg/s)`` (``count/deg`` for
        ``count/s``); ``1`` with nominal 1 when ``raw_unit`` is a unit of the input itself.
    """
    _check_sensor(sensor)
    table = ACCEL_UNITS if sensor == "accelerometer" else RATE_UNITS
    if raw_unit in table:
        return ScaleUnit("1", 1.0, table[raw_unit], 1.0)
    if sensor == "accelerometer":
        return ScaleUnit(f"{raw_unit}/(m/s^2)", 1.0, 1.0, None)
    unit = "count/deg" if raw_unit == "count/s" else f"{raw_unit}/(deg/s)"
    return ScaleUnit(unit, 1.0 / DEG_PER_S_TO_RAD_PER_S, 1.0, None)


def bias_unit(sensor: str) -> tuple[str, float]:
    """Engineering unit of an input-referred bias and its SI value: mg or deg/h."""
    _check_sensor(sensor)
    return BIAS_UNITS[sensor]


def parameter_names(with_g_sensitivity: bool = False) -> tuple[str, ...]:
    """Names of the engineering quantities returned by :func:`engineering`, in order."""
    names = SCALE_NAMES + MISALIGNMENT_NAMES + BIAS_NAMES
    return names + G_SENSITIVITY_NAMES if with_g_sensitivity else names


def units_of(sensor: str, scale: ScaleUnit, with_g_sensitivity: bool = False) -> dict[str, str]:
    """Engineering unit of each name of :func:`parameter_names`."""
    b_unit, _ = bias_unit(sensor)
    out = dict.fromkeys(SCALE_NAMES, scale.unit)
    out.update(dict.fromkeys(MISALIGNMENT_NAMES, MISALIGNMENT_UNIT))
    out.update(dict.fromkeys(BIAS_NAMES, b_unit))
    if with_g_sensitivity:
        out.update(dict.fromkeys(G_SENSITIVITY_NAMES, G_SENSITIVITY_UNIT))
    return out


def stack_parameters(S: ArrayLike, b: ArrayLike, G: ArrayLike | None = None) -> NDArray:
    """``p = [S.ravel(), b, (G.ravel())]``, the parameter vector of the fits."""
    parts: list[ArrayLike] = [np.ravel(S), np.ravel(b)]
    if G is not None:
        parts.append(np.ravel(G))
    return np.concatenate([np.asarray(x, dtype=float) for x in parts])


def misalignment_matrix(values: ArrayLike) -> NDArray:
    """``M`` (3x3, zero diagonal) from six values in :data:`MISALIGNMENT_NAMES` order.

    Any unit; the matrix is in the same unit.
    """
    v = np.asarray(values)
    if v.shape != (6,):
        raise InputError(f"misalignment needs six values (xy, xz, yx, yz, zx, zy), got {v.shape}")
    M = np.zeros((3, 3), dtype=v.dtype)
    for k, (i, j) in enumerate(OFF_DIAGONAL):
        M[i, j] = v[k]
    return M


def misalignment_values(M: ArrayLike) -> NDArray:
    """The six off-diagonal entries of ``M`` in :data:`MISALIGNMENT_NAMES` order."""
    m = np.asarray(M)
    return np.array([m[i, j] for i, j in OFF_DIAGONAL])


def forward_matrix(scale: ArrayLike, misalignment: ArrayLike) -> NDArray:
    """``S = K (I + M)`` from the scale factors ``K`` (3,) and ``M`` (3x3 or its six values)."""
    M = np.asarray(misalignment)
    if M.shape == (6,):
        M = misalignment_matrix(M)
    return np.diag(np.asarray(scale)) @ (np.eye(3) + M)


def decompose(S: ArrayLike, b: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """``K = diag(S)``, the six ``M_ij = S_ij / S_ii`` [-] and ``B = S^-1 b`` of the forward model.

    Works on complex arrays (for the complex-step Jacobian). A negative ``S_ii`` (reversed axis)
    gives a negative ``K_i`` and the misalignments of the same definition.
    """
    S = np.asarray(S)
    d = np.diag(S)
    return d, misalignment_values(S / d[:, None]), np.linalg.solve(S, np.asarray(b))


def output(u: ArrayLike, S: ArrayLike, b: ArrayLike, G: ArrayLike | None = None,
           a: ArrayLike | None = None) -> NDArray:
    """The forward model ``raw = S u + b [+ G a]`` for inputs ``u`` (n, 3) [raw-SI]."""
    raw = np.atleast_2d(np.asarray(u, dtype=float)) @ np.asarray(S, dtype=float).T + np.asarray(
        b, dtype=float)
    if G is not None and a is not None:
        raw = raw + np.atleast_2d(np.asarray(a, dtype=float)) @ np.asarray(G, dtype=float).T
    return raw


def engineering(p: ArrayLike, sensor: str, scale: ScaleUnit) -> NDArray:
    """Engineering quantities from the SI parameter vector ``p`` (works on complex input).

    Parameters
    ----------
    p : array_like, shape (12,) or (21,)
        ``[S.ravel(), b, G.ravel()]``: ``S`` [raw SI per input SI], ``b`` [raw SI],
        ``G`` [raw SI per m/s^2] (gyros only).
    sensor : {"accelerometer", "gyroscope"}
    scale : ScaleUnit

    Returns
    -------
    ndarray
        ``K_x..K_z`` [scale.unit], ``M_xy, M_xz, M_yx, M_yz, M_zx, M_zy`` [urad], ``B_x..B_z``
        [mg or deg/h] and, with ``G``, ``G_xx..G_zz`` [deg/h/g], input-referred ``S^-1 G``.
    """
    q = np.asarray(p)
    S = q[:9].reshape(3, 3)
    K, mis, B = decompose(S, q[9:12])
    _, b_si = bias_unit(sensor)
    out = [K / scale.si_per_unit, mis / MICRORAD_TO_RAD, B / b_si]
    if q.size == 21:
        G = np.linalg.solve(S, q[12:21].reshape(3, 3))
        out.append(G.ravel() / DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2)
    return np.concatenate(out)


def engineering_jacobian(
    p: ArrayLike, sensor: str, scale: ScaleUnit
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`engineering` at ``p`` and its Jacobian ``d engineering / d p`` (complex step).

    The one Jacobian of the triad model, used for every covariance propagation; exact to
    rounding for any tiny step (Squire & Trapp 1998, doi:10.1137/S003614459631241X).
    """
    x = np.asarray(p, dtype=float)
    if x.size not in (12, 21):
        raise InputError(f"triad parameters must be 12 or 21, got {x.size}")
    return complex_step_jacobian(lambda q: engineering(q, sensor, scale), x)


def complex_step_jacobian(
    fun: Callable[[NDArray[Any]], NDArray[Any]], x: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``fun(x)`` and its Jacobian by the complex step, for any analytic vector function.

    Step ``1e-20 |x_k|`` (``1e-20 max |x|`` where ``x_k = 0``): exact to rounding (Squire &
    Trapp, SIAM Review 40(1), 1998, doi:10.1137/S003614459631241X). The triad model's
    :func:`engineering_jacobian` and the single-axis rate-table fit use it.
    """
    x = np.asarray(x, dtype=float)
    value = np.asarray(fun(x))
    ref = float(np.max(np.abs(x))) or 1.0
    h = 1e-20 * np.where(x != 0, np.abs(x), ref)
    J = np.empty((value.size, x.size))
    for k in range(x.size):
        xc = x.astype(complex)
        xc[k] += 1j * h[k]
        J[:, k] = np.asarray(fun(xc)).imag / h[k]
    return value.real.astype(float), J


def propagate(
    p: ArrayLike, covariance: ArrayLike, sensor: str, scale: ScaleUnit
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Engineering values and their covariance ``J C J^T`` (:func:`engineering_jacobian`)."""
    x = np.asarray(p, dtype=float)
    C = np.asarray(covariance, dtype=float)
    if C.shape != (x.size, x.size):
        raise InputError(f"triad covariance must be {x.size}x{x.size}, got {C.shape}")
    value, J = engineering_jacobian(x, sensor, scale)
    return value, J @ C @ J.T


def parameters_from_engineering(
    values: Mapping[str, float], sensor: str, scale: ScaleUnit, *, prefix: str = "",
    what: str = "truth",
) -> NDArray[np.float64]:
    """The parameter vector ``p`` [raw SI] from engineering values by name.

    The inverse of :func:`engineering`:

    ``K_x..K_z`` [scale.unit; default the nominal, required for count outputs], ``M_ij`` [urad],
    ``B_i`` [mg or deg/h, input-referred, so ``b = S B``], optional ``G_ij`` [deg/h/g,
    input-referred, so ``G_raw = S G``]; absent misalignments, biases, g-sensitivities are 0.
    ``prefix`` is inserted after the letter (``Ka_x``, ``Mg_xy`` for an IMU result).
    Unknown names are the caller's to check.
    """
    def key(name: str) -> str:
        return f"{name[0]}{prefix}{name[1:]}"

    missing = [key(k) for k in SCALE_NAMES if key(k) not in values]
    if missing and scale.nominal is None:
        raise PlanError(f"{what} needs the scale factors {', '.join(missing)} in {scale.unit}")
    K = np.array([float(values.get(key(k), scale.nominal or 1.0)) for k in SCALE_NAMES])
    mis = np.array([float(values.get(key(k), 0.0)) for k in MISALIGNMENT_NAMES])
    S = forward_matrix(K * scale.si_per_unit, mis * MICRORAD_TO_RAD)
    _, b_si = bias_unit(sensor)
    B = np.array([float(values.get(key(k), 0.0)) for k in BIAS_NAMES]) * b_si
    if not any(key(k) in values for k in G_SENSITIVITY_NAMES):
        return stack_parameters(S, S @ B)
    G = np.array([float(values.get(key(k), 0.0)) for k in G_SENSITIVITY_NAMES]).reshape(3, 3)
    return stack_parameters(S, S @ B, S @ (G * DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2))


def model_from_truth(truth: Mapping[str, float], sensor: str, scale: ScaleUnit
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``S = K (I + M)`` [raw SI per SI] and ``b`` [raw SI] of a virtual triad's truth.

    ``truth`` names ``K_x..K_z`` [scale unit; default the nominal], ``M_ij`` [urad], ``B_i``
    [mg or deg/h, input-referred: ``b = S B``] (:func:`parameters_from_engineering`); any other
    name is an error naming the known ones.
    """
    names = parameter_names(False)
    unknown = sorted(set(truth) - set(names))
    if unknown:
        raise PlanError(f"truth for {'an' if sensor[0] in 'aeiou' else 'a'} {sensor} triad has "
                        f"unknown name(s) {', '.join(unknown)}; known: {', '.join(names)}")
    p = parameters_from_engineering(truth, sensor, scale)
    return p[:9].reshape(3, 3), p[9:12]


def reversed_axes(p: ArrayLike) -> tuple[int, ...]:
    """Indices of the sensors with a negative scale factor (``S_ii < 0``)."""
    d = np.diag(np.asarray(p, dtype=float)[:9].reshape(3, 3))
    return tuple(int(i) for i in np.flatnonzero(d < 0))


def reversed_axes_message(p: ArrayLike, sensor: str, column: str) -> str | None:
    """A message naming the reversed axes (negative scale factor), or None.

    ``column`` is the data-column pattern with ``{}`` for the axis letter (``"gyr_{}"``).
    """
    rev = reversed_axes(p)
    if not rev:
        return None
    names = ", ".join(column.format(AXES[i]) for i in rev)
    ks = ", ".join(f"K_{AXES[i]}" for i in rev)
    return (f"{sensor} {names}: negative scale factor ({ks} < 0): the sensor points opposite to "
            "the reference axis (mounted reversed or the channel negated); the calibration "
            "corrects it, but check the mounting if this is not intended")


@dataclass(frozen=True)
class TriadErrors:
    """Small errors of a triad relative to its nominal model, SI (for error analyses).

    The first-order error of the calibrated output ``u_cal = u + E u + bias`` of a triad whose
    ``S = K0 (I + dK) (I + M)`` was calibrated with the nominal ``K0``: ``E = diag(dK) + M``
    (module conventions: ``M_ij`` sensor i, reference axis j; bias adds to the output).

    Attributes
    ----------
    scale_deviation : ndarray, shape (3,)
        ``dK_i`` [-] (ppm x 1e-6).
    misalignment : ndarray, shape (3, 3)
        ``M`` [rad], zero diagonal.
    bias : ndarray, shape (3,)
        Input-referred bias [m/s^2 or rad/s].
    """

    scale_deviation: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    misalignment: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))
    bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        for name, shape in (("scale_deviation", (3,)), ("misalignment", (3, 3)), ("bias", (3,))):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise InputError(f"triad error {name} must be finite with shape {shape}, got "
                                 f"{np.shape(getattr(self, name))}")
            object.__setattr__(self, name, a.copy())
        check_misalignment(self.misalignment)

    @classmethod
    def from_engineering(
        cls, sensor: str, *, scale_ppm: ArrayLike = (0.0, 0.0, 0.0),
        misalignment_urad: Mapping[str, float] | ArrayLike = (0.0,) * 6,
        bias: ArrayLike = (0.0, 0.0, 0.0),
    ) -> TriadErrors:
        """From engineering units.

        ``scale_ppm`` [ppm]; ``misalignment_urad`` [urad] by name (``{"M_xy": 5.0}``, absent
        ones 0) or the six values in :data:`MISALIGNMENT_NAMES` order; the input-referred bias
        [mg or deg/h, :func:`bias_unit`].
        """
        _, b_si = bias_unit(sensor)
        if isinstance(misalignment_urad, Mapping):
            unknown = sorted(set(misalignment_urad) - set(MISALIGNMENT_NAMES))
            if unknown:
                raise InputError(f"unknown misalignment name(s) {', '.join(unknown)}; use "
                                 f"{', '.join(MISALIGNMENT_NAMES)}")
            mis = np.array([float(misalignment_urad.get(k, 0.0)) for k in MISALIGNMENT_NAMES])
        else:
            mis = np.asarray(misalignment_urad, dtype=float)
        return cls(scale_deviation=np.asarray(scale_ppm, dtype=float) * PPM_TO_RATIO,
                   misalignment=misalignment_matrix(np.asarray(mis) * MICRORAD_TO_RAD),
                   bias=np.asarray(bias, dtype=float) * b_si)

    @property
    def matrix(self) -> NDArray[np.float64]:
        """``E = diag(dK) + M`` [-]."""
        return error_matrix(self.scale_deviation, self.misalignment)


def check_misalignment(M: ArrayLike, name: str = "misalignment") -> None:
    """Raise :class:`InputError` unless ``M`` has a zero diagonal (scale factors go in K)."""
    if np.any(np.diag(np.asarray(M)) != 0):
        raise InputError(f"{name} must have a zero diagonal: put scale-factor errors in the "
                         "scale factors")


def error_matrix(scale_deviation: ArrayLike, misalignment: ArrayLike) -> NDArray[np.float64]:
    """``diag(dK) + M`` [-]: first-order relative error of ``K (I + M)`` about the nominal."""
    return np.diag(np.asarray(scale_deviation, dtype=float)) + np.asarray(misalignment, float)


@dataclass(frozen=True)
class TriadCalibration:
    """Correction of one triad: ``calibrated = matrix @ (raw - [g_sensitivity @ a] - offset)``.

    Attributes
    ----------
    matrix : ndarray, shape (3, 3)
        ``(K (I + M))^-1`` [SI unit per raw unit].
    offset : ndarray, shape (3,)
        Bias [raw unit].
    unit : str
        Unit of the calibrated output (``"m/s^2"`` or ``"rad/s"``).
    raw_unit : str
        Unit of the raw output (e.g. ``"count"``).
    g_sensitivity : ndarray, shape (3, 3) or None
        Gyro bias per calibrated specific force [raw unit per m/s^2]; None for accelerometers.
    """

    matrix: NDArray[np.float64]
    offset: NDArray[np.float64]
    unit: str
    raw_unit: str = "count"
    g_sensitivity: NDArray[np.float64] | None = field(default=None)

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix, dtype=float)
        o = np.asarray(self.offset, dtype=float)
        if m.shape != (3, 3) or o.shape != (3,):
            raise InputError(
                f"calibration matrix must be 3x3 and offset 3, got {m.shape}, {o.shape}"
            )
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(o))):
            raise InputError("calibration matrix and offset must be finite")
        if abs(np.linalg.det(m)) < 1e-300:
            raise InputError("calibration matrix is singular")
        object.__setattr__(self, "matrix", m)
        object.__setattr__(self, "offset", o)
        if self.g_sensitivity is not None:
            g = np.asarray(self.g_sensitivity, dtype=float)
            if g.shape != (3, 3) or not np.all(np.isfinite(g)):
                raise InputError(f"g_sensitivity must be a finite 3x3 matrix, got {g.shape}")
            object.__setattr__(self, "g_sensitivity", g)

    @classmethod
    def from_model(
        cls,
        scale: ArrayLike,
        misalignment: ArrayLike,
        bias: ArrayLike,
        *,
        unit: str,
        raw_unit: str = "count",
        g_sensitivity: ArrayLike | None = None,
    ) -> TriadCalibration:
        """From the output model: ``K = diag(scale)``, ``M`` (3x3, zero diagonal), ``b``."""
        K = np.diag(np.asarray(scale, dtype=float))
        M = np.asarray(misalignment, dtype=float)
        if M.shape != (3, 3):
            raise InputError(f"misalignment must be 3x3, got {M.shape}")
        return cls(
            matrix=np.linalg.inv(K @ (np.eye(3) + M)),
            offset=np.asarray(bias, dtype=float),
            unit=unit,
            raw_unit=raw_unit,
            g_sensitivity=None if g_sensitivity is None else np.asarray(g_sensitivity, float),
        )

    @property
    def forward(self) -> NDArray[np.float64]:
        """``K (I + M)`` [raw unit per SI unit], the inverse of :attr:`matrix`."""
        return np.asarray(np.linalg.inv(self.matrix), dtype=float)

    def apply(
        self, raw: ArrayLike, acc_calibrated: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Calibrated output, shape (n, 3), from raw output, shape (n, 3).

        Gyroscopes with a ``g_sensitivity`` need ``acc_calibrated`` [m/s^2], shape (n, 3).
        """
        r = np.atleast_2d(np.asarray(raw, dtype=float))
        if r.shape[-1] != 3:
            raise InputError(f"raw triad data must have 3 columns, got shape {r.shape}")
        r = r - self.offset
        if self.g_sensitivity is not None:
            if acc_calibrated is None:
                raise InputError("this gyroscope calibration needs the calibrated acceleration")
            r = r - np.atleast_2d(np.asarray(acc_calibrated, dtype=float)) @ self.g_sensitivity.T
        return r @ self.matrix.T

    def simulate(
        self, true_input: ArrayLike, acc_true: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Raw output for true inputs (the inverse of :meth:`apply`), shape (n, 3)."""
        u = np.atleast_2d(np.asarray(true_input, dtype=float))
        raw = u @ self.forward.T + self.offset
        if self.g_sensitivity is not None and acc_true is not None:
            raw = raw + np.atleast_2d(np.asarray(acc_true, dtype=float)) @ self.g_sensitivity.T
        return raw

    def to_dict(self) -> dict[str, object]:
        """JSON layout of the issue: matrix, offset, [g_sensitivity], unit, raw_unit."""
        d: dict[str, object] = {
            "matrix": self.matrix.tolist(),
            "offset": self.offset.tolist(),
            "unit": self.unit,
            "raw_unit": self.raw_unit,
        }
        if self.g_sensitivity is not None:
            d["g_sensitivity"] = self.g_sensitivity.tolist()
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> TriadCalibration:
        """Inverse of :meth:`to_dict`; errors name the missing or malformed key."""
        for key in ("matrix", "offset", "unit"):
            if key not in d:
                raise InputError(f'calibration lacks "{key}"')
        try:
            return cls(
                matrix=np.asarray(d["matrix"], dtype=float),
                offset=np.asarray(d["offset"], dtype=float),
                unit=str(d["unit"]),
                raw_unit=str(d.get("raw_unit", "count")),
                g_sensitivity=(
                    None if d.get("g_sensitivity") is None
                    else np.asarray(d["g_sensitivity"], dtype=float)
                ),
            )
        except (TypeError, ValueError) as exc:
            raise InputError(f"malformed calibration: {exc}") from None


def calibration_from_parameters(
    p: ArrayLike, *, sensor: str, scale: ScaleUnit, raw_unit: str
) -> TriadCalibration:
    """The correction ``calibrated = matrix @ (raw - offset)`` in the raw unit of the file.

    ``matrix = S^-1`` rescaled to the recorded raw unit; ``offset = b`` in the recorded unit;
    ``g_sensitivity`` (gyros) in recorded raw unit per m/s^2 of calibrated acceleration.
    """
    q = np.asarray(p, dtype=float)
    S = q[:9].reshape(3, 3)
    r = scale.raw_si_per_raw
    if abs(np.linalg.det(S)) == 0:
        raise IdentifiabilityError("the estimated triad matrix K (I + M) is singular")
    return TriadCalibration(
        matrix=np.linalg.inv(S) * r,
        offset=q[9:12] / r,
        unit=INPUT_SI_UNITS[sensor],
        raw_unit=raw_unit,
        g_sensitivity=None if q.size != 21 else q[12:21].reshape(3, 3) / r,
    )
