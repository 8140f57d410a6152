"""Temperature sensitivity of the bias: static records at soaked chamber temperatures.

IEEE Std 952-1997 (single-axis FOG) and IEEE Std 1293-2018 (linear accelerometer) specify the
bias *temperature sensitivity*: the change of the bias per degree of the instrument's (soaked)
temperature, from static tests at several chamber temperatures. The model

    b(T) = B_ref + S (T - T_ref)   [+ S2 (T - T_ref)^2 with degree = 2]

is fitted to the readings by least squares under the plan's noise model with the readings of one
temperature step as one unit (:func:`inertest.estimation.identify.solve`: ``auto`` chooses
between white noise and a step offset, a random walk or flicker, with its model checks), so that
a bias that re-settles differently at each step (an offset per step) gives the slope its honest
uncertainty rather than that of white noise. Quantities: ``B_ref`` (bias at ``T_ref``) [bias
unit], ``temperature_sensitivity`` ``S`` [bias unit / degC] (``temperature_curvature`` ``S2``
[bias unit / degC^2] with degree 2). The bias is the output less the input at rest (the Earth
rate along the gyro's input axis, gravity along the accelerometer's). A thermal *hysteresis*
test (heating against cooling) and compensation models are ``inertest thermal``.

Data columns: ``temperature_c`` [degC, the soaked temperature of each reading or step],
``output`` [output unit], optional ``step`` (the chamber step of each reading; by default the
steps are the runs of equal ``temperature_c``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.errors import IdentifiabilityError, PlanError
from inertest.estimation.identify import identify
from inertest.estimation.noise_models import NOISE_MODELS
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure
from inertest.procedures.spec import known_sigma, noise_samples, require_columns
from inertest.procedures.static_record import Sensor, input_at_rest, read_axis, sensor_of
from inertest.results import LinearTestResult

KIND = "temperature-sensitivity"
#: Names a truth file may give (bias unit, per degC, per degC^2; step offset std).
TRUTH_NAMES = ("B_ref", "temperature_sensitivity", "temperature_curvature", "step_sigma")


@dataclass(frozen=True)
class TemperatureSensitivitySpec:
    """Parameters of a temperature-sensitivity plan (``[procedure]`` table).

    Attributes
    ----------
    t_ref_c : float
        Reference temperature of ``B_ref`` [degC].
    degree : int
        1 (slope) or 2 (slope and curvature).
    input_axis : str or tuple of float
        Input axis in ENU, for the input at rest.
    noise_model : str
        Noise model of the fit (``auto`` by default).
    temperatures_c : tuple of float
        Chamber steps (simulation) [degC].
    readings_per_step : int
        Readings at each step (simulation).
    """

    kind: ClassVar[str] = KIND
    t_ref_c: float = 25.0
    degree: int = 1
    input_axis: str | tuple[float, ...] = "U"
    noise_model: str = "auto"
    temperatures_c: tuple[float, ...] = (-40.0, -20.0, 0.0, 20.0, 40.0, 60.0)
    readings_per_step: int = 60

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> TemperatureSensitivitySpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "input_axis"))
        return cls(input_axis=read_axis(params), **v)


FIELDS = (
    Field("t_ref_c", default=25.0, unit="degC", minimum=-100.0, maximum=300.0,
          doc="reference temperature of B_ref"),
    Field("degree", "integer", default=1, minimum=1, maximum=2, doc="1 slope, 2 curvature"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
    Field("temperatures_c", "numbers", default=TemperatureSensitivitySpec.temperatures_c,
          unit="degC", doc="chamber steps (simulation)"),
    Field("readings_per_step", "integer", default=60, positive=True,
          doc="readings at each step (simulation)"),
)


@dataclass(frozen=True, kw_only=True)
class TemperatureResult(LinearTestResult):
    """Outcome of a temperature-sensitivity test: ``B_ref``, ``temperature_sensitivity``."""

    steps: tuple[dict[str, object], ...]
    t_ref_c: float
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` in the envelope)."""
        return {"t_ref_c": self.t_ref_c, "steps": list(self.steps)}


@dataclass(frozen=True)
class ThermalSteps:
    """Readings in SI (input at rest removed), their temperature and step."""

    y: NDArray[np.float64]
    temperature_c: NDArray[np.float64]
    step: NDArray[np.str_]
    sensor: Sensor


class TemperatureSensitivity(Procedure[TemperatureSensitivitySpec, ThermalSteps,
                                       TemperatureResult]):
    """Bias against soaked temperature (IEEE Std 952 / 1293 temperature sensitivity).

    Data columns ``temperature_c``, ``output``, optional ``step``.
    """

    kind = KIND
    title = "Bias temperature sensitivity"
    spec = TemperatureSensitivitySpec
    model = "inertest.procedures.temperature_sensitivity"
    method = "weighted least squares under a noise model (steps as units)"
    noise_models = NOISE_MODELS

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Any) -> ThermalSteps:
        """Readings in SI, the input at rest removed; steps from ``step`` or the temperature."""
        spec: TemperatureSensitivitySpec = plan.procedure
        sensor = sensor_of(plan.instrument, KIND)
        text = ("step",) if "step" in data else ()
        cols = require_columns(data, ("temperature_c", "output"), text, procedure=KIND)
        step = cols["step"] if text else np.char.mod("%.6g degC", cols["temperature_c"])
        distinct = np.unique(cols["temperature_c"])
        if distinct.size < spec.degree + 1 or np.ptp(distinct) <= 0:
            raise IdentifiabilityError(
                f"{KIND} with degree {spec.degree} needs at least {spec.degree + 1} distinct "
                f"temperatures, got {distinct.size}; add chamber steps")
        y = cols["output"] * sensor.si_per_output - input_at_rest(plan, sensor, spec.input_axis)
        return ThermalSteps(y, cols["temperature_c"], np.asarray(step), sensor)

    def identify(self, plan: Plan, obs: ThermalSteps, *, sigma: float | None,
                 noise_model: str | None) -> TemperatureResult:
        """``B_ref``, the sensitivity (and curvature) by least squares under the noise model."""
        spec: TemperatureSensitivitySpec = plan.procedure
        sensor = obs.sensor
        dt = obs.temperature_c - spec.t_ref_c
        names = ["B_ref", "temperature_sensitivity", "temperature_curvature"][: spec.degree + 1]
        A = np.column_stack([dt**k for k in range(spec.degree + 1)])
        u = sensor.si_per_bias_unit
        units = {"B_ref": sensor.bias_unit, "temperature_sensitivity": f"{sensor.bias_unit}/degC",
                 "temperature_curvature": f"{sensor.bias_unit}/degC^2"}
        sig = None if sigma is None else known_sigma(sigma, sensor.si_per_output)
        _, ident = identify(A, obs.y, names=names, units=units,
                            si_per_unit={n: u for n in names}, noise_unit=sensor.output_unit,
                            si_per_noise_unit=sensor.si_per_output, sigma_si=sig,
                            groups=obs.step, noise_model=str(noise_model or "auto"))
        labels, first = np.unique(obs.step, return_index=True)
        steps = []
        for k in np.argsort(first):
            rows = obs.step == labels[k]
            steps.append({"step": str(labels[k]),
                          "temperature_c": float(np.mean(obs.temperature_c[rows])),
                          "bias": {"value": float(np.mean(obs.y[rows]) / u),
                                   "unit": sensor.bias_unit},
                          "readings": int(rows.sum())})
        return TemperatureResult(
            site_latitude_deg=plan.site.latitude_deg, site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident, residual_output=ident.residuals, output_unit=sensor.output_unit,
            steps=tuple(steps), t_ref_c=spec.t_ref_c)

    def synthesize(self, plan: Plan, motion: Any, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """Columns ``step``, ``temperature_c``, ``output`` at the plan's chamber steps.

        Each step adds an offset ``N(0, step_sigma^2)`` [bias unit] (re-settling); white noise
        ``noise`` per reading [output unit].
        """
        spec: TemperatureSensitivitySpec = plan.procedure
        sensor = sensor_of(plan.instrument, KIND)
        unknown = sorted(set(truth) - set(TRUTH_NAMES))
        if unknown:
            raise PlanError(f"truth for {KIND} has unknown name(s) {', '.join(unknown)}; "
                            f"known: {', '.join(TRUTH_NAMES)}")
        gen = np.random.default_rng(rng)
        T = np.repeat(np.asarray(spec.temperatures_c, dtype=float), spec.readings_per_step)
        step = np.repeat([f"step {k + 1}" for k in range(len(spec.temperatures_c))],
                         spec.readings_per_step)
        dt = T - spec.t_ref_c
        u = sensor.si_per_bias_unit
        offsets = gen.normal(0.0, float(truth.get("step_sigma", 0.0)), len(spec.temperatures_c))
        b = (float(truth.get("B_ref", 0.0)) + float(truth.get("temperature_sensitivity", 0.0))
             * dt + float(truth.get("temperature_curvature", 0.0)) * dt**2
             + np.repeat(offsets, spec.readings_per_step)) * u
        y = (b + input_at_rest(plan, sensor, spec.input_axis)) / sensor.si_per_output
        return {"step": step, "temperature_c": T, "output": y + noise_samples(T.size, noise, gen)}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = TemperatureSensitivity()
