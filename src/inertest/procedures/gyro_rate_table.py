"""Rate-table test of one gyro axis: scale factor, asymmetry, nonlinearity and bias.

The gyro is a single-axis gyro or one axis of a triad.

The gyro's input axis is set along the table axis ``a`` (fixed in the local-level frame) and the
table turns at commanded rates ``w_t`` in both directions. The input rate is the table rate plus
the Earth rate along the axis, ``w_in = w_t + W_ie . a``. The output at each rate (mean over the
dwell) follows the least-squares straight line of the scale-factor test of IEEE Std 952-1997
(interferometric FOG test procedure)::

    E = K (w_in + B)                      (least squares over all rates: K and bias B)

Scale-factor asymmetry (terms as defined in IEEE Std 528, inertial sensor terminology, and
IEEE Std 952): the scale factors of the positive and negative rates,
from ``E = K+ w_t [w_t > 0] + K- w_t [w_t < 0] + c``, as ``(K+ - K-) / ((K+ + K-)/2)`` in ppm.
Nonlinearity (same sources): the largest deviation of the per-rate mean output from the
straight line, as ppm of the full-scale output ``|K| max |w_t|``. With ``fit_k2`` the
second-order coefficient of ``E = K (w_in + K2 w_t^2) + c`` (relative scale-factor change per
unit rate) is fitted as well. All terms are fitted together; the reported K is
``(K+ + K-)/2`` (the least-squares slope for a symmetric set of rates) when both directions'
scale factors are determined.

Data columns: ``rate_deg_s`` (commanded table rate [deg/s], signed, one row per reading) and
``output`` (the gyro's mean output over the dwell [output unit; count/s for pulse outputs]).

Closed forms (used by the tests as independent references): from a pair of opposite rates
``+-w``, ``K = (E+ - E-) / (2 w)`` and ``B = (E+ + E-) / (2 K) - W_ie . a``.

Identifiability: K and B need one non-zero rate and a second distinct rate; the asymmetry needs
both directions (an error otherwise) and, beside a single pair ``+-w``, a second rate of one sign
or a zero-rate reading (else K+, K- and the bias are not separable); the nonlinearity and K2 need
at least three distinct rates.

Output units: a rate output (``deg/h``, ``deg/s``, ``rad/s``) gives a dimensionless K (unit
``"1"``); any other output (``count`` read as count/s, ``V``, ``mA``) gives K in
``<unit>/(deg/s)`` (``count/deg`` for pulses). The bias is always reported in deg/h.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.equipment import rate_table as table
from inertest.errors import IdentifiabilityError, PlanError
from inertest.estimation.identify import solve
from inertest.estimation.least_squares import weighted_least_squares
from inertest.estimation.noise_models import NOISE_MODELS
from inertest.models import rate_gyro, triad
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import known_sigma, noise_samples, require_columns
from inertest.results import Estimate, Identification, LinearTestResult
from inertest.units import DEG_PER_H_TO_RAD_PER_S, DEG_TO_RAD, RATE_UNITS

KIND = "gyro-rate-table"
#: Names a truth file may give (engineering units: K unit, deg/h, ppm, ppm/(deg/s)).
TRUTH_NAMES = ("K", "B", "asymmetry", "K2")
PPM = 1e-6


@dataclass(frozen=True)
class GyroRateTableSpec:
    """Parameters of a rate-table plan (``[procedure]`` table).

    Attributes
    ----------
    rates_deg_s : tuple of float
        Commanded table rates [deg/s], signed (positive: right-handed about the table axis).
    samples_per_rate : int
        Readings (dwell means) recorded at each rate (for simulation).
    table_axis : str or tuple of float
        Direction of the table axis (= the gyro's input axis) in ENU: a letter (E, W, N, S, U,
        D) or a vector. Default ``"U"`` (vertical table).
    fit_k2 : bool
        Also fit the second-order scale-factor coefficient K2.
    noise_model : str
        Noise model behind the uncertainties: ``auto`` (default), ``white``,
        ``position-offsets`` (an offset per rate run: the table rate or the gyro bias settles
        differently at each run), ``random-walk`` or ``flicker``
        (:func:`inertest.estimation.identify.solve`).
    """

    kind: ClassVar[str] = KIND
    rates_deg_s: tuple[float, ...] = (-100.0, -30.0, -10.0, -1.0, 1.0, 10.0, 30.0, 100.0)
    samples_per_rate: int = 1
    table_axis: str | tuple[float, ...] = "U"
    fit_k2: bool = False
    noise_model: str = "auto"

    @property
    def axis_enu(self) -> NDArray[np.float64]:
        """Unit vector of the table axis in ENU."""
        return table.direction_vector(self.table_axis)

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> GyroRateTableSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`).

        ``table_axis`` is a letter or an ENU vector (two types): read here.
        """
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "table_axis"))
        given = params.get("table_axis", "U")
        axis: str | tuple[float, ...] = (given if isinstance(given, str)
                                         else tuple(given))  # type: ignore[arg-type]
        table.direction_vector(axis)  # validate now, not at fit time
        return cls(table_axis=axis, **v)


FIELDS = (
    Field("rates_deg_s", "numbers", default=GyroRateTableSpec.rates_deg_s, unit="deg/s",
          doc="commanded table rates, signed"),
    Field("samples_per_rate", "integer", default=1, positive=True,
          doc="readings at each rate (simulation)"),
    Field("fit_k2", "bool", default=False, doc="fit the second-order scale factor K2"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
)


@dataclass(frozen=True, kw_only=True)
class GyroRateTableResult(LinearTestResult):
    """Outcome of :func:`fit` for a rate-table test.

    Attributes
    ----------
    identification : Identification
        ``K`` [K unit], ``B`` [deg/h] (Earth rate removed), and when determined ``K_pos``,
        ``K_neg`` [K unit], ``asymmetry`` [ppm], ``K2`` [ppm/(deg/s)].
    nonlinearity_ppm : float or None
        Largest deviation of a per-rate mean from the straight line [ppm of full scale]; None
        when fewer than three distinct rates were run.
    nonlinearity_noise_ppm : float or None
        Noise of a per-rate mean residual at the worst rate [ppm of full scale]: deviations of
        this size are noise, not nonlinearity.
    pairs : tuple of dict
        Closed-form K and B from each pair of opposite rates (``rate_deg_s``, ``K``, ``B``).
    rate_deg_s, output, fitted : ndarray
        Commanded rate, reading and model value per row (output unit).
    line_deviation : ndarray
        Reading minus the straight line per row (output unit): the nonlinearity's raw material.
    earth_rate_deg_h : float
        Earth rate along the table axis that was removed [deg/h].
    """

    nonlinearity_ppm: float | None
    nonlinearity_noise_ppm: float | None
    pairs: tuple[dict[str, float], ...]
    scale_unit: str
    rate_deg_s: NDArray[np.float64] = field(repr=False)
    output: NDArray[np.float64] = field(repr=False)
    fitted: NDArray[np.float64] = field(repr=False)
    line_deviation: NDArray[np.float64] = field(repr=False)
    earth_rate_deg_h: float
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d: dict[str, object] = {}
        d["nonlinearity"] = (
            None if self.nonlinearity_ppm is None else {
                "value": self.nonlinearity_ppm, "noise_floor": self.nonlinearity_noise_ppm,
                "unit": "ppm of full scale"}
        )
        d["closed_form_pairs"] = [
            {"rate_deg_s": p["rate_deg_s"], "K": {"value": p["K"], "unit": self.scale_unit},
             "B": {"value": p["B"], "unit": "deg/h"}} for p in self.pairs
        ]
        d["earth_rate_along_axis"] = {"value": self.earth_rate_deg_h, "unit": "deg/h"}
        return d


@dataclass(frozen=True)
class RateObservations:
    """Rate-table readings with the rate on the gyro's input axis from the table.

    ``rate_deg_s`` (n,) commanded table rate [deg/s], ``output`` (n,) [output unit],
    ``input_rate_rad_s`` (n,) table rate plus the Earth rate along the input axis [rad/s],
    ``earth_rate_rad_s`` the Earth rate along it [rad/s].
    """

    rate_deg_s: NDArray[np.float64]
    output: NDArray[np.float64]
    input_rate_rad_s: NDArray[np.float64]
    earth_rate_rad_s: float


class GyroRateTable(Procedure[GyroRateTableSpec, RateObservations, GyroRateTableResult]):
    """Rate gyro on a rate table (IEEE Std 952 scale-factor test): K, B, asymmetry, linearity.

    Data columns ``rate_deg_s`` (commanded table rate [deg/s], signed) and ``output`` (mean
    output at that rate [output unit; count/s for pulse outputs]), in time order; the readings
    at one rate are one run (the unit of independence of the noise model).

    Raises
    ------
    IdentifiabilityError
        All rates have one sign ("add negative rates"), no non-zero rate, too few distinct rates
        for what was asked.
    """

    kind = KIND
    title = "Rate gyro on a rate table"
    spec = GyroRateTableSpec
    model = "inertest.models.rate_gyro"
    method = "weighted least squares under a noise model; closed forms from rate pairs"
    machines = (table,)
    noise_models = NOISE_MODELS
    report = "inertest.report.gyro_triad:rate_table_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None
               ) -> table.ConstantRates:
        """The plan's rate table: the gyro's input axis (x) along the table axis."""
        spec: GyroRateTableSpec = plan.procedure
        return table.ConstantRates(plan.site, spec.axis_enu,
                                   tuple(np.asarray(spec.rates_deg_s) * DEG_TO_RAD),
                                   type_b=dict(type_b or {}))

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: table.ConstantRates
               ) -> RateObservations:
        """The commanded rates checked, and the rate on the input axis of each reading."""
        rate_gyro.check_gyro(plan.instrument, KIND)
        cols = require_columns(data, ("rate_deg_s", "output"), (), procedure=KIND)
        _check_rates(cols["rate_deg_s"])
        w_in, w_e = _input_rate(motion, cols["rate_deg_s"] * DEG_TO_RAD)
        return RateObservations(cols["rate_deg_s"], cols["output"], w_in, w_e)

    def identify(self, plan: Plan, obs: RateObservations, *, sigma: float | None,
                 noise_model: str | None) -> GyroRateTableResult:
        """Scale factor, bias, asymmetry and nonlinearity by least squares."""
        spec: GyroRateTableSpec = plan.procedure
        cols = {"rate_deg_s": obs.rate_deg_s, "output": obs.output}
        inst = plan.instrument
        rate_t = cols["rate_deg_s"] * DEG_TO_RAD
        per_si = rate_gyro.raw_rate_per_si(inst.output_unit)
        y = cols["output"] / per_si  # rad/s for rate outputs, raw otherwise
        sig = None if sigma is None else known_sigma(sigma, 1.0 / per_si)
        w_in, w_e = obs.input_rate_rad_s, obs.earth_rate_rad_s
        k_unit, k_si = rate_gyro.scale_unit(inst.output_unit)
        distinct = np.unique(cols["rate_deg_s"])
        messages: list[str] = []
        not_sep: list[str] = []

        # Straight line E = K w_in + c (IEEE 952): nonlinearity is measured from it.
        line = weighted_least_squares(np.column_stack([w_in, np.ones_like(w_in)]), y, sigma=1.0)
        runs = np.char.mod("rate %.9g deg/s", cols["rate_deg_s"])
        model = str(noise_model)
        if spec.fit_k2 and distinct.size < 3:
            raise IdentifiabilityError(
                f"K2 needs at least three distinct table rates, got {distinct.size} "
                f"({', '.join(f'{r:g}' for r in distinct)} deg/s); add rates (e.g. a larger "
                "and a smaller magnitude) or set fit_k2 = false"
            )
        # Full model: E = K+ w_t [w_t > 0] + K- w_t [w_t < 0] [+ c2 w_t^2] + c, with
        # K = (K+ + K-)/2, B = c/K - W_ie.a and K2 = c2/K. When the rates do not separate K+ from
        # K-, the symmetric model E = K w_in [+ c2 w_t^2] + c stands in (no asymmetry).
        quad = [rate_t**2] if spec.fit_k2 else []
        one = np.ones_like(rate_t)
        A_as = np.column_stack([np.where(rate_t > 0, rate_t, 0.0),
                                np.where(rate_t < 0, rate_t, 0.0), *quad, one])
        asymmetric = bool(np.linalg.matrix_rank(A_as) == A_as.shape[1])
        names = ["K", "B", *(["K2"] if spec.fit_k2 else [])]
        if asymmetric:
            names += ["K_pos", "K_neg", "asymmetry"]
            design = A_as
        else:
            design = np.column_stack([rate_t, *quad, one])
            need = "a third rate of one sign" if spec.fit_k2 else "a second rate of each sign"
            not_sep.append(
                "asymmetry (K_pos, K_neg): the rates run do not separate the two directions' scale "
                f"factors from the bias{' and K2' if spec.fit_k2 else ''}; add {need} or a "
                "zero-rate reading"
            )

        def engineering(x: NDArray) -> NDArray:
            kp, kn = (x[0], x[1]) if asymmetric else (x[0], x[0])
            k = 0.5 * (kp + kn)
            out = [k / k_si, (x[-1] / k - w_e) / DEG_PER_H_TO_RAD_PER_S]
            if spec.fit_k2:
                out.append(x[-2] / k * DEG_TO_RAD / PPM)  # 1/(rad/s) -> ppm/(deg/s)
            if asymmetric:
                out += [kp / k_si, kn / k_si, (kp - kn) / k / PPM]
            return np.array(out)

        main, noise = solve(design, y, sigma_si=sig, groups=runs, noise_model=model)
        values, J = triad.complex_step_jacobian(engineering, main.x)
        cov = J @ main.covariance @ J.T
        std = np.sqrt(np.diag(cov))
        k_of = {"K": k_unit, "K_pos": k_unit, "K_neg": k_unit}
        units = {**k_of, "B": "deg/h", "K2": "ppm/(deg/s)", "asymmetry": "ppm"}
        coefficients = {
            n: Estimate(n, float(values[i]), float(std[i]), units[n]) for i, n in enumerate(names)
        }
        K = values[0] * k_si

        # Nonlinearity: per-rate mean residual of the straight line, ppm of full-scale output.
        fitted = y - main.residuals
        nl = nl_noise = None
        if distinct.size >= 3:
            inv = np.unique(cols["rate_deg_s"], return_inverse=True)[1]
            counts = np.bincount(inv)
            mean_res = np.bincount(inv, line.residuals) / counts
            fs = abs(K) * np.max(np.abs(rate_t))
            worst = int(np.argmax(np.abs(mean_res)))
            nl = float(np.max(np.abs(mean_res)) / fs / PPM)
            # Noise of that rate's mean under the noise model (its run's variance).
            var_unit = noise.unit_covariance
            var_unit = var_unit if var_unit.ndim == 1 else np.diag(var_unit)
            row = int(np.flatnonzero(inv == worst)[0])
            nl_noise = float(np.sqrt(var_unit[noise.unit_index[row]]) / fs / PPM)
        else:
            not_sep.append(
                "nonlinearity: a straight line through two distinct rates leaves no deviation to "
                "measure; add at least one more rate"
            )

        pairs = _closed_form_pairs(cols["rate_deg_s"], y, w_e, k_si)
        ident = Identification(
            coefficients=coefficients,
            combinations=(),
            not_separable=tuple(not_sep),
            covariance=cov,
            names=tuple(names),
            noise_sigma=float(noise.white_sigma * per_si),
            noise_unit=rate_gyro.raw_rate_unit(inst.output_unit),
            sigma_from_residuals=sigma is None,
            dof=int(main.dof),
            rank=int(main.rank),
            residuals=main.residuals * per_si,
            noise_model=noise.model,
            noise_components={k: v * per_si for k, v in noise.components.items()},
            checks=noise.checks,
        )
        return GyroRateTableResult(
            site_latitude_deg=plan.site.latitude_deg,
            site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident,
            nonlinearity_ppm=nl,
            nonlinearity_noise_ppm=nl_noise,
            pairs=pairs,
            scale_unit=k_unit,
            rate_deg_s=cols["rate_deg_s"],
            output=cols["output"],
            fitted=fitted * per_si,
            line_deviation=line.residuals * per_si,
            earth_rate_deg_h=w_e / DEG_PER_H_TO_RAD_PER_S,
            residual_output=main.residuals * per_si,
            output_unit=rate_gyro.raw_rate_unit(inst.output_unit),
            messages=tuple(messages),
        )

    def truth_quantities(self, truth: Mapping[str, float]) -> dict[str, float]:
        """Truth with the one-direction scale factors the result reports.

        ``K_pos = K (1 + a/2)``, ``K_neg = K (1 - a/2)`` with ``a`` the asymmetry [ppm] (the
        model :meth:`synthesize` uses).
        """
        out = {k: float(v) for k, v in truth.items()}
        k, a = out.get("K", 1.0), out.get("asymmetry", 0.0) * 1e-6
        out.update(K_pos=k * (1 + a / 2), K_neg=k * (1 - a / 2))
        return out

    def synthesize(self, plan: Plan, motion: table.ConstantRates, truth: Mapping[str, float],
                   *, noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """Columns ``rate_deg_s`` and ``output`` [output unit; count/s for pulses].

        ``truth``: ``K`` [K unit; default 1 for rate outputs, else required], ``B`` [deg/h],
        ``asymmetry`` [ppm] (K+ = K (1 + a/2), K- = K (1 - a/2)), ``K2`` [ppm/(deg/s)]. The
        Earth rate is included.
        """
        rate_gyro.check_gyro(plan.instrument, KIND)
        unknown = sorted(set(truth) - set(TRUTH_NAMES))
        if unknown:
            raise PlanError(
                f"truth for {KIND} has unknown name(s) {', '.join(unknown)}; known: "
                f"{', '.join(TRUTH_NAMES)}"
            )
        spec: GyroRateTableSpec = plan.procedure
        inst = plan.instrument
        k_unit, k_si = rate_gyro.scale_unit(inst.output_unit)
        if "K" not in truth and inst.output_unit not in RATE_UNITS:
            raise PlanError(f"truth needs the scale factor K in {k_unit} for a "
                            f"{inst.output_unit} output")
        K = float(truth.get("K", 1.0)) * k_si
        B = float(truth.get("B", 0.0)) * DEG_PER_H_TO_RAD_PER_S
        a = float(truth.get("asymmetry", 0.0)) * PPM
        k2 = float(truth.get("K2", 0.0)) * PPM / DEG_TO_RAD
        rates = np.repeat(np.asarray(spec.rates_deg_s, dtype=float), spec.samples_per_rate)
        w_t = rates * DEG_TO_RAD
        # The table rate on the input axis from the motion (which carries Type-B rate/tilt
        # errors when the uncertainty budget applies them); equal to w_t on the nominal table.
        w_in, w_e = _input_rate(motion, w_t)
        w_tab = w_in - w_e
        k_dir = K * (1 + np.sign(w_t) * a / 2)
        out_si = k_dir * w_tab + K * (w_e + B + k2 * w_tab**2)
        per_si = rate_gyro.raw_rate_per_si(inst.output_unit)
        output = out_si * per_si + noise_samples(rates.size, noise, rng)
        return {"rate_deg_s": rates, "output": output}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = GyroRateTable()


def _input_rate(
    motion: table.ConstantRates, rate_rad_s: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
    """Rate on the gyro's input axis per row [rad/s] and the Earth rate along it [rad/s].

    ``omega_i`` of the rate table's motion on the instrument's x (input) axis at the run's
    start: the table rate plus ``W_ie . a``.
    """
    distinct, inv = np.unique(rate_rad_s, return_inverse=True)
    w = np.array([motion.inputs_at_rate(float(r)).omega_i[0, 0] for r in distinct])
    return w[inv], float(motion.inputs_at_rate(0.0).omega_i[0, 0])


def _check_rates(rates_deg_s: NDArray[np.float64]) -> None:
    nonzero = rates_deg_s[rates_deg_s != 0]
    if nonzero.size == 0:
        raise IdentifiabilityError(
            "every reading is at zero table rate: the scale factor cannot be found; add "
            "positive and negative rates"
        )
    if np.all(nonzero > 0):
        raise IdentifiabilityError(
            "all table rates are positive: asymmetry needs both directions: add negative rates "
            f"(e.g. {', '.join(f'{-r:g}' for r in np.unique(nonzero)[:3])} deg/s)"
        )
    if np.all(nonzero < 0):
        raise IdentifiabilityError(
            "all table rates are negative: asymmetry needs both directions: add positive rates "
            f"(e.g. {', '.join(f'{-r:g}' for r in np.unique(nonzero)[::-1][:3])} deg/s)"
        )


def _closed_form_pairs(
    rates_deg_s: NDArray[np.float64], y: NDArray[np.float64], w_e: float, k_si: float
) -> tuple[dict[str, float], ...]:
    """K = (E+ - E-)/(2w), B = (E+ + E-)/(2K) - W_ie.a from the mean readings at +-w."""
    out = []
    for r in np.unique(np.abs(rates_deg_s[rates_deg_s > 0])):
        pos, neg = y[rates_deg_s == r], y[rates_deg_s == -r]
        if pos.size == 0 or neg.size == 0:
            continue
        ep, en = pos.mean(), neg.mean()
        K = (ep - en) / (2 * r * DEG_TO_RAD)
        B = (ep + en) / (2 * K) - w_e
        out.append({"rate_deg_s": float(r), "K": float(K / k_si),
                    "B": float(B / DEG_PER_H_TO_RAD_PER_S)})
    return tuple(out)
