"""Result types of every triad procedure: the engineering estimates of the triad model.

Triad-multiposition, Ferraris, orientation-free and gyro-triad procedures report the model of
:mod:`inertest.models.triad` (scale factors, misalignments, biases, g-sensitivity) with their
standard uncertainties and the calibration to apply to recordings (:mod:`inertest.models.imu`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.models import triad
from inertest.models.imu import ImuCalibration
from inertest.results import Estimate, Identification, LinearTestResult


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
        Covariance of all values in :func:`~inertest.models.triad.parameter_names` order,
        engineering units.
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
        cls, p: ArrayLike, covariance: ArrayLike, *, sensor: str, scale: triad.ScaleUnit
    ) -> TriadEstimates:
        """Build from the SI parameter vector ``[S.ravel(), b, (G.ravel())]`` and its covariance."""
        value, cov = triad.propagate(p, covariance, sensor, scale)
        return cls.from_engineering(value, cov, sensor=sensor, scale=scale)

    @classmethod
    def from_engineering(
        cls, value: ArrayLike, covariance: ArrayLike, *, sensor: str, scale: triad.ScaleUnit
    ) -> TriadEstimates:
        """Build from :func:`~inertest.models.triad.engineering` values and their covariance."""
        value, cov = np.asarray(value, dtype=float), np.asarray(covariance, dtype=float)
        names = triad.parameter_names(value.size == 21)
        units = triad.units_of(sensor, scale, value.size == 21)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        est = {n: Estimate(n, float(v), float(s), units[n])
               for n, v, s in zip(names, value, std, strict=True)}
        ppm = {}
        if scale.nominal is not None:
            ppm = {
                n: Estimate(n, (est[n].value / scale.nominal - 1.0) * 1e6,
                            est[n].std / abs(scale.nominal) * 1e6, triad.SCALE_DEVIATION_UNIT)
                for n in triad.SCALE_NAMES
            }
        return cls(
            sensor=sensor,
            scale={n: est[n] for n in triad.SCALE_NAMES},
            misalignment={n: est[n] for n in triad.MISALIGNMENT_NAMES},
            bias={n: est[n] for n in triad.BIAS_NAMES},
            scale_ppm=ppm,
            g_sensitivity={n: est[n] for n in triad.G_SENSITIVITY_NAMES if n in est},
            covariance=cov,
        )

    def all_estimates(self) -> dict[str, Estimate]:
        """Every estimate by name (scale, misalignment, bias, g-sensitivity)."""
        return {**self.scale, **self.misalignment, **self.bias, **self.g_sensitivity}

    def to_dict(self) -> dict[str, object]:
        """JSON of the estimates with their units and covariance.

        Keys: ``scale_factor`` (+ ``scale_factor_ppm``), ``misalignment`` [urad], ``bias``,
        [``g_sensitivity``], ``covariance`` (names, matrix, same units).
        """
        def block(d: dict[str, Estimate]) -> dict[str, object]:
            return {k: e.to_dict() for k, e in d.items()}

        out: dict[str, object] = {
            "scale_factor": block(self.scale),
            "misalignment": block(self.misalignment),
            "bias": block(self.bias),
        }
        if self.scale_ppm:
            out["scale_factor_ppm"] = block(self.scale_ppm)
        if self.g_sensitivity:
            out["g_sensitivity"] = block(self.g_sensitivity)
        if self.covariance.size:
            out["covariance"] = {"names": list(self.all_estimates()),
                                 "matrix": self.covariance.tolist()}
        return out


def triad_identification(
    p: ArrayLike,
    covariance: ArrayLike,
    *,
    sensor: str,
    scale: triad.ScaleUnit,
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
    calibration: ImuCalibration
    triads: tuple[TriadEstimates, ...]

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d: dict[str, object] = {}
        d["calibration"] = self.calibration.to_dict()
        d["triads"] = {t.sensor: t.to_dict() for t in self.triads}
        return d
