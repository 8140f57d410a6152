"""Shared result of the triad procedures: calibration block plus engineering-unit estimates.

Every triad procedure (accelerometer or gyro triad) estimates, in SI, the parameters of the output
model of seed ``003_f374f866dfe7c99f.txt`` (FOG triad output model, eq. 1)::

    raw = S u + b [+ G a],     S = K (I + M)

with ``u`` the true input on the triad's reference axes, ``K = diag(S)`` the scale factors,
``M`` the small misalignment / non-orthogonality (zero diagonal) and ``b`` the bias in raw units.
This module turns the parameter vector ``p = [S.ravel() (9), b (3), G.ravel() (9, optional)]`` and
its covariance into what a test engineer reads, with first-order propagated uncertainty:

* scale factors ``K_i = S_ii`` [raw unit per SI unit; dimensionless "1" when the raw output is
  already a physical unit of the input], and their deviation from nominal [ppm] where a nominal
  exists;
* misalignment ``M_ij = S_ij / S_ii`` (sensor i's sensitivity to input along reference axis j)
  [urad and arcsec];
* input-referred bias ``B = S^-1 b`` [mg for accelerometers, deg/h for gyros];
* optional g-sensitivity ``G`` input-referred, ``S^-1 G`` [deg/h/g].

Misalignment convention: all six off-diagonal ``M_ij`` are free and refer to the *reference frame
fixed by the test fixture* (turntable or cube axes), so the 9 elements of ``S`` are exactly 3 scale
factors + 6 misalignment angles. With a perfectly orthogonal triad, ``M_ij + M_ji`` measures the
mounting rotation of the triad in the fixture and ``M_ij - M_ji`` its non-orthogonality.

Uncertainties are propagated through the (exact, complex-step) Jacobian of this map.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import IdentifiabilityError, InputError
from inertest.models.triad import AXES, ImuCalibration, TriadCalibration
from inertest.results import Estimate, Identification, LinearTestResult
from inertest.units import (
    ACCEL_UNITS,
    ARCSEC_TO_RAD,
    DEG_PER_H_TO_RAD_PER_S,
    G0,
    MILLI_G_TO_M_PER_S2,
    RATE_UNITS,
)

SENSORS = ("accelerometer", "gyroscope")
#: Names of the scale factors, misalignments and biases, in the order of :func:`engineering`.
SCALE_NAMES = tuple(f"K_{a}" for a in AXES)
MISALIGNMENT_NAMES = tuple(f"M_{a}{c}" for a in AXES for c in AXES if a != c)
BIAS_NAMES = tuple(f"B_{a}" for a in AXES)
G_SENSITIVITY_NAMES = tuple(f"G_{a}{c}" for a in AXES for c in AXES)
URAD_TO_RAD = 1e-6


@dataclass(frozen=True)
class ScaleUnit:
    """How a triad's scale factor is reported.

    Attributes
    ----------
    unit : str
        Unit of ``K`` (``"count/(m/s^2)"``, ``"count/(rad/s)"`` or ``"1"``).
    si_per_unit : float
        SI value (raw-SI per input SI) of one ``unit``.
    raw_si_per_raw : float
        Factor from the recorded raw output to the raw-SI used in the fit (1 for counts; the unit
        factor when the raw output is a physical unit such as ``g`` or ``deg/s``).
    nominal : float or None
        Nominal scale factor [unit] (1 for physical outputs); None for counts.
    """

    unit: str
    si_per_unit: float
    raw_si_per_raw: float
    nominal: float | None


def scale_unit(output_unit: str, sensor: str) -> ScaleUnit:
    """The reporting unit of ``K`` for a raw ``output_unit`` of an accelerometer/gyro triad."""
    if sensor not in SENSORS:
        raise InputError(f'sensor must be one of {", ".join(SENSORS)}, got "{sensor}"')
    table = ACCEL_UNITS if sensor == "accelerometer" else RATE_UNITS
    si = "m/s^2" if sensor == "accelerometer" else "rad/s"
    if output_unit in table:
        return ScaleUnit("1", 1.0, table[output_unit], 1.0)
    return ScaleUnit(f"{output_unit}/({si})", 1.0, 1.0, None)


def bias_unit(sensor: str) -> tuple[str, float]:
    """Engineering unit of an input-referred bias and its SI value: mg or deg/h."""
    return ("mg", MILLI_G_TO_M_PER_S2) if sensor == "accelerometer" else (
        "deg/h", DEG_PER_H_TO_RAD_PER_S)


def parameter_names(with_g_sensitivity: bool = False) -> tuple[str, ...]:
    """Names of the engineering quantities returned by :func:`engineering`."""
    names = SCALE_NAMES + MISALIGNMENT_NAMES + BIAS_NAMES
    return names + G_SENSITIVITY_NAMES if with_g_sensitivity else names


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
    b = q[9:12]
    d = np.diag(S)
    M = S / d[:, None]
    mis = np.array([M[i, j] for i in range(3) for j in range(3) if i != j])
    _, b_si = bias_unit(sensor)
    out = [d / scale.si_per_unit, mis / URAD_TO_RAD, np.linalg.solve(S, b) / b_si]
    if q.size == 21:
        G = np.linalg.solve(S, q[12:21].reshape(3, 3))
        out.append(G.ravel() / (DEG_PER_H_TO_RAD_PER_S / G0))
    return np.concatenate(out)


def propagate(
    p: ArrayLike, covariance: ArrayLike, sensor: str, scale: ScaleUnit
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Engineering values and their covariance, ``J C J^T`` with the complex-step Jacobian."""
    x = np.asarray(p, dtype=float)
    C = np.asarray(covariance, dtype=float)
    if x.size not in (12, 21) or C.shape != (x.size, x.size):
        raise InputError(f"triad parameters must be 12 or 21 with a matching covariance, got "
                         f"{x.size} and {C.shape}")
    value = engineering(x, sensor, scale)
    # Complex step (Squire & Trapp 1998): exact to rounding for any tiny step.
    ref = float(np.max(np.abs(x))) or 1.0
    h = 1e-20 * np.where(x != 0, np.abs(x), ref)
    J = np.empty((value.size, x.size))
    for k in range(x.size):
        xc = x.astype(complex)
        xc[k] += 1j * h[k]
        J[:, k] = engineering(xc, sensor, scale).imag / h[k]
    return value.real.astype(float), J @ C @ J.T


def units_of(sensor: str, scale: ScaleUnit, with_g_sensitivity: bool = False) -> dict[str, str]:
    """Engineering unit of each name of :func:`parameter_names`."""
    b_unit, _ = bias_unit(sensor)
    out = {n: scale.unit for n in SCALE_NAMES}
    out.update({n: "urad" for n in MISALIGNMENT_NAMES})
    out.update({n: b_unit for n in BIAS_NAMES})
    if with_g_sensitivity:
        out.update({n: "deg/h/g" for n in G_SENSITIVITY_NAMES})
    return out


@dataclass(frozen=True)
class TriadEstimates:
    """One triad's scale factors, misalignments and biases with standard uncertainties.

    Attributes
    ----------
    sensor : {"accelerometer", "gyroscope"}
    scale, misalignment, bias : dict of Estimate
        ``K_i`` [scale unit], ``M_ij`` [urad], ``B_i`` [mg or deg/h].
    scale_ppm : dict of Estimate
        Deviation of ``K_i`` from the nominal [ppm]; empty when there is no nominal.
    g_sensitivity : dict of Estimate
        ``G_ij`` [deg/h/g] (gyros with a g-sensitivity model; otherwise empty).
    covariance : ndarray
        Covariance of all values in :func:`parameter_names` order, engineering units.
    """

    sensor: str
    scale: dict[str, Estimate]
    misalignment: dict[str, Estimate]
    bias: dict[str, Estimate]
    scale_ppm: dict[str, Estimate] = field(default_factory=dict)
    g_sensitivity: dict[str, Estimate] = field(default_factory=dict)
    covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)), repr=False)

    @classmethod
    def from_parameters(
        cls, p: ArrayLike, covariance: ArrayLike, *, sensor: str, scale: ScaleUnit
    ) -> TriadEstimates:
        """Build from the SI parameter vector ``[S.ravel(), b, (G.ravel())]`` and its covariance."""
        value, cov = propagate(p, covariance, sensor, scale)
        names = parameter_names(value.size == 21)
        units = units_of(sensor, scale, value.size == 21)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        est = {n: Estimate(n, float(v), float(s), units[n])
               for n, v, s in zip(names, value, std, strict=True)}
        ppm = {}
        if scale.nominal is not None:
            ppm = {
                n: Estimate(n, (est[n].value / scale.nominal - 1.0) * 1e6,
                            est[n].std / abs(scale.nominal) * 1e6, "ppm")
                for n in SCALE_NAMES
            }
        return cls(
            sensor=sensor,
            scale={n: est[n] for n in SCALE_NAMES},
            misalignment={n: est[n] for n in MISALIGNMENT_NAMES},
            bias={n: est[n] for n in BIAS_NAMES},
            scale_ppm=ppm,
            g_sensitivity={n: est[n] for n in G_SENSITIVITY_NAMES if n in est},
            covariance=cov,
        )

    def all_estimates(self) -> dict[str, Estimate]:
        """Every estimate by name (scale, misalignment, bias, g-sensitivity)."""
        return {**self.scale, **self.misalignment, **self.bias, **self.g_sensitivity}

    def to_dict(self) -> dict[str, object]:
        """JSON of the estimates with their units and covariance.

        Keys: ``scale_factor`` (+ ``scale_factor_ppm``), ``misalignment`` [urad] and
        ``misalignment_arcsec``, ``bias``, [``g_sensitivity``], ``covariance`` (names, matrix).
        """
        def block(d: dict[str, Estimate]) -> dict[str, object]:
            return {k: e.to_dict() for k, e in d.items()}

        arcsec = {
            k: {"value": e.value * URAD_TO_RAD / ARCSEC_TO_RAD,
                "std": e.std * URAD_TO_RAD / ARCSEC_TO_RAD, "unit": "arcsec"}
            for k, e in self.misalignment.items()
        }
        out: dict[str, object] = {
            "scale_factor": block(self.scale),
            "misalignment": block(self.misalignment),
            "misalignment_arcsec": arcsec,
            "bias": block(self.bias),
        }
        if self.scale_ppm:
            out["scale_factor_ppm"] = block(self.scale_ppm)
        if self.g_sensitivity:
            out["g_sensitivity"] = block(self.g_sensitivity)
        if self.covariance.size:
            # full covariance in the engineering units above (urad for misalignment)
            out["covariance"] = {"names": list(self.all_estimates()),
                                 "matrix": self.covariance.tolist()}
        return out


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
        unit="m/s^2" if sensor == "accelerometer" else "rad/s",
        raw_unit=raw_unit,
        g_sensitivity=None if q.size != 21 else q[12:21].reshape(3, 3) / r,
    )


def triad_identification(
    p: ArrayLike,
    covariance: ArrayLike,
    *,
    sensor: str,
    scale: ScaleUnit,
    noise_sigma: float,
    noise_unit: str,
    sigma_from_residuals: bool,
    dof: int,
    rank: int,
    residuals: ArrayLike,
) -> tuple[TriadEstimates, Identification]:
    """The engineering estimates and an :class:`Identification` (``K``, ``M``, ``B`` names).

    Use only when every parameter is identifiable (triad procedures raise
    :class:`~inertest.errors.IdentifiabilityError` before, naming what is missing).
    """
    est = TriadEstimates.from_parameters(p, covariance, sensor=sensor, scale=scale)
    coefficients = est.all_estimates()
    ident = Identification(
        coefficients=coefficients,
        combinations=(),
        not_separable=(),
        covariance=est.covariance,
        names=tuple(coefficients),
        noise_sigma=noise_sigma,
        noise_unit=noise_unit,
        sigma_from_residuals=sigma_from_residuals,
        dof=dof,
        rank=rank,
        residuals=np.asarray(residuals, dtype=float),
    )
    return est, ident


@dataclass(frozen=True, kw_only=True)
class TriadResult(LinearTestResult):
    """Result of a triad procedure (keyword-only fields, so procedures can subclass freely).

    Attributes
    ----------
    procedure : str
    site_latitude_deg, site_gravity_m_s2 : float
    identification : Identification
        ``K_i``, ``M_ij``, ``B_i`` (and ``G_ij``) with covariance in engineering units.
    calibration : ImuCalibration
        The correction to apply to recordings (JSON ``"calibration"`` block).
    triads : tuple of TriadEstimates
        Per-triad engineering estimates (accelerometer and/or gyroscope).
    residual_output : ndarray
        Residuals [output_unit].
    output_unit : str
    messages : tuple of str
    """

    procedure: str
    site_latitude_deg: float
    site_gravity_m_s2: float
    identification: Identification
    calibration: ImuCalibration
    triads: tuple[TriadEstimates, ...]
    residual_output: NDArray[np.float64] = field(repr=False)
    output_unit: str
    messages: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, object]:
        """Common layout plus ``"calibration"`` and ``"triads"`` (engineering estimates)."""
        d = super().to_dict()
        d["calibration"] = self.calibration.to_dict()
        d["triads"] = {t.sensor: t.to_dict() for t in self.triads}
        return d


def stack_parameters(S: ArrayLike, b: ArrayLike, G: ArrayLike | None = None) -> NDArray:
    """``[S.ravel(), b, (G.ravel())]``, the parameter vector of this module."""
    parts: Sequence[ArrayLike] = [np.ravel(S), np.ravel(b)]
    if G is not None:
        parts = [*parts, np.ravel(G)]
    return np.concatenate([np.asarray(x, dtype=float) for x in parts])
