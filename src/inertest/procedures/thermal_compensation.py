"""Temperature compensation of a gyro's scale factor or bias: polynomials and a BP network.

Seed ``003_f374f866dfe7c99f.txt`` (FOG scale factor calibration and compensation): the scale
factor of a fibre-optic gyro depends nonlinearly on temperature, and the seed compensates it with
a back-propagation (BP) neural network. A gyro's sensing coil lags the case temperature sensor,
so the error depends on the measured temperature *and its rate of change* (heating and cooling
give different values at the same reading: hysteresis); the bias has, in addition, a term in the
temperature rate (the Shupe effect).

Models, each a scikit-learn pipeline on the inputs ``x = (T, dT/dt)`` (or ``T`` only):

* polynomial: ``StandardScaler -> PolynomialFeatures(degree) -> LinearRegression``, the degree
  chosen by leave-one-cycle-out cross-validation on the training cycles (lowest RMS);
* BP network (the seed's model): ``StandardScaler -> MLPRegressor`` (one tanh hidden layer,
  L-BFGS, fixed ``random_state``) with the target standardised as well.

Train / validation split by temperature cycle (the last ``validation_cycles`` cycles are held
out), so the validation residual measures how well a model predicts a cycle it has not seen --
the honest uncertainty of the compensation. Residuals are reported before (deviation from the
training mean) and after compensation, in ppm of the mean scale factor or in deg/h (bias).

Data columns: ``cycle`` (temperature cycle number), ``time_s`` [s] (monotonic within a cycle),
``temperature_c`` [degC, the gyro's temperature sensor], and the quantity: ``scale_factor``
[any unit, e.g. pulse/arcsec; residuals in ppm of its mean] or ``bias_deg_h`` [deg/h]. The
temperature rate is computed from ``temperature_c`` and ``time_s`` within each cycle [degC/min].
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, IdentifiabilityError, InputError
from inertest.estimation.least_squares import weighted_least_squares
from inertest.models.thermal import (
    NetworkThermalModel,
    PolynomialThermalModel,
    ThermalModel,
    observed_range,
    observed_support,
    poly_design,
    poly_exponents,
)
from inertest.procedures.spec import require_columns
from inertest.results import envelope

if TYPE_CHECKING:
    from sklearn.pipeline import Pipeline

#: Quantities that can be compensated: data column and unit of the residuals.
QUANTITIES: dict[str, tuple[str, str]] = {
    "scale_factor": ("scale_factor", "ppm"),
    "bias": ("bias_deg_h", "deg/h"),
}
MIN_TRAIN_CYCLES = 2


@dataclass(frozen=True)
class ThermalModelFit:
    """One model's compensation quality.

    Attributes
    ----------
    name : str
        ``"polynomial"`` or ``"neural network"``.
    description : str
        Degree, or hidden layer and iterations.
    train_rms, validation_rms : float
        RMS residual after compensation on the training and validation cycles [unit].
    prediction : ndarray
        Model value at every row [unit, same reference as the data].
    converged : bool
        False if the optimiser stopped at its iteration limit (network only).
    """

    name: str
    description: str
    train_rms: float
    validation_rms: float
    prediction: NDArray[np.float64] = field(repr=False)
    converged: bool = True
    model: ThermalModel | None = field(default=None, repr=False, compare=False)
    estimator: object = field(default=None, repr=False, compare=False)

    def predict(self, temperature_c: NDArray, rate_c_per_min: NDArray | None = None) -> NDArray:
        """Model value [unit] at temperatures [degC] (and rates [degC/min] if it uses them)."""
        if self.model is None:
            raise InputError("this fit holds no exported model")
        return self.model.predict(temperature_c, rate_c_per_min)

    def summary(self, unit: str) -> dict[str, object]:
        """JSON-ready summary, residuals in ``unit`` (a block of :meth:`ThermalResult.to_dict`)."""
        return {
            "model": self.name,
            "description": self.description,
            "train_rms": {"value": self.train_rms, "unit": unit},
            "validation_rms": {"value": self.validation_rms, "unit": unit},
            "converged": self.converged,
        }


@dataclass(frozen=True)
class ThermalResult:
    """Outcome of :func:`fit_thermal`.

    Attributes
    ----------
    quantity : str
        ``"scale_factor"`` or ``"bias"``.
    unit : str
        Unit of residuals and values (``ppm`` of ``reference`` or ``deg/h``).
    reference : float
        Training mean of the quantity (in the data's unit); ``value`` is relative to it.
    inputs : tuple of str
        Model inputs (``temperature_c``, ``temperature_rate_c_per_min``).
    cycle, time_s, temperature_c, rate_c_per_min, value : ndarray
        Per row; ``value`` is the quantity's deviation from ``reference`` [unit].
    train : ndarray of bool
        Rows used for training.
    before_train_rms, before_validation_rms : float
        RMS deviation from the reference without compensation [unit].
    polynomial, network : ThermalModelFit
    cv_rms : dict
        Leave-one-cycle-out RMS of each polynomial degree [unit].
    messages : tuple of str
    serial : str
        Instrument serial ("" when not given); written into the exported models.
    """

    quantity: str
    unit: str
    reference: float
    inputs: tuple[str, ...]
    cycle: NDArray = field(repr=False)
    time_s: NDArray[np.float64] = field(repr=False)
    temperature_c: NDArray[np.float64] = field(repr=False)
    rate_c_per_min: NDArray[np.float64] = field(repr=False)
    value: NDArray[np.float64] = field(repr=False)
    train: NDArray[np.bool_] = field(repr=False)
    before_train_rms: float
    before_validation_rms: float
    polynomial: ThermalModelFit
    network: ThermalModelFit
    cv_rms: dict[int, float]
    messages: tuple[str, ...] = ()
    serial: str = ""

    kind: ClassVar[str] = "thermal-compensation"
    #: Model names accepted by :meth:`model`.
    MODEL_NAMES: ClassVar[tuple[str, ...]] = ("polynomial", "neural-network")

    def model(self, name: str = "polynomial") -> ThermalModel:
        """The fitted model as plain arrays, ready to write and to apply.

        Parameters
        ----------
        name : {"polynomial", "neural-network"}
            The polynomial carries its coefficient covariance (uncertainty of the correction);
            the network (the seed's model) carries weights, biases and scaling.
        """
        if name not in self.MODEL_NAMES:
            raise InputError(f"thermal model {name!r} unknown; use one of "
                             f"{', '.join(self.MODEL_NAMES)}")
        fit = self.polynomial if name == "polynomial" else self.network
        assert fit.model is not None
        return fit.model

    def to_dict(self) -> dict[str, object]:
        """The result envelope (no per-row arrays); the models' residuals in :attr:`unit`."""
        u = self.unit
        best = min(self.polynomial.validation_rms, self.network.validation_rms)
        improved = best < self.before_validation_rms
        check = {
            "name": "compensation on the held-out cycles",
            "verdict": "ok" if improved else "warning",
            "before_rms": {"value": self.before_validation_rms, "unit": u},
            "best_after_rms": {"value": best, "unit": u},
        }
        return envelope(self.kind, result={
            "quantity": self.quantity,
            "reference": self.reference,
            "inputs": list(self.inputs),
            "train_cycles": sorted({int(c) for c in self.cycle[self.train]}),
            "validation_cycles": sorted({int(c) for c in self.cycle[~self.train]}),
            "before": {"train_rms": {"value": self.before_train_rms, "unit": u},
                       "validation_rms": {"value": self.before_validation_rms, "unit": u}},
            "polynomial": {**self.polynomial.summary(u),
                           "cv_rms": {str(k): v for k, v in self.cv_rms.items()},
                           "cv_unit": u},
            "neural_network": self.network.summary(u),
            "models": {name: self.model(name).to_dict() for name in self.MODEL_NAMES},
        }, instrument={"serial": self.serial} if self.serial else None, checks=[check],
            messages=self.messages)


# ---------------------------------------------------------------------------------------------
# simulation


def simulate_thermal(
    *,
    cycles: int = 4,
    t_min_c: float = -40.0,
    t_max_c: float = 60.0,
    ramp_c_per_min: float = 1.0,
    dwell_min: float = 30.0,
    sample_s: float = 20.0,
    lag_s: float = 600.0,
    noise_ppm: float = 3.0,
    noise_deg_h: float = 0.01,
    scale_factor_nominal: float = 1.0,
    rng: np.random.Generator | int | None = None,
) -> dict[str, NDArray]:
    """Temperature cycles of a FOG with a lagging coil: scale factor and bias with hysteresis.

    The chamber (and case sensor) follows a trapezoid between ``t_min_c`` and ``t_max_c`` at
    ``ramp_c_per_min`` with dwells of ``dwell_min``; the coil temperature ``T_c`` lags it as a
    first-order system, ``dT_c/dt = (T - T_c) / lag_s`` (integrated exactly per sample). Errors
    (realistic for a mid-grade FOG, nonlinear in ``T_c``)::

        SF error [ppm] = 12 (T_c - 20) + 0.06 (T_c - 20)^2 + 40 tanh((T_c - 5) / 10)
        bias [deg/h]   = 0.5 + 0.004 (T_c - 20) + 2e-4 (T_c - 20)^2 + 0.3 dT_c/dt [degC/min]

    (the last term is the Shupe effect). The sensor reads ``T``; at a ramp of r degC/min the
    coil lags by ``r lag_s / 60`` degC (10 degC here): heating and cooling branches differ.

    Returns
    -------
    dict
        Columns ``cycle``, ``time_s``, ``temperature_c``, ``scale_factor`` (``nominal x (1 +
        error)``), ``bias_deg_h``, ``coil_temperature_c`` (truth, not used by the fit).
    """
    if cycles < 1 or not (t_max_c > t_min_c) or ramp_c_per_min <= 0 or sample_s <= 0:
        raise InputError("need cycles >= 1, t_max_c > t_min_c, positive ramp and sample time")
    gen = np.random.default_rng(rng)
    ramp_s = (t_max_c - t_min_c) / ramp_c_per_min * 60.0
    dwell_s = dwell_min * 60.0
    period = 2 * ramp_s + 2 * dwell_s
    n = int(round(period / sample_s))
    t = np.arange(cycles * n) * sample_s
    ph = t % period
    chamber = np.select(
        [ph < dwell_s, ph < dwell_s + ramp_s, ph < 2 * dwell_s + ramp_s],
        [t_min_c, t_min_c + (ph - dwell_s) / ramp_s * (t_max_c - t_min_c), t_max_c],
        t_max_c - (ph - 2 * dwell_s - ramp_s) / ramp_s * (t_max_c - t_min_c),
    )
    # first-order lag, exact for a piecewise-linear input over each step
    a = np.exp(-sample_s / lag_s)
    coil = np.empty_like(chamber)
    coil[0] = chamber[0]
    for k in range(1, chamber.size):
        slope = (chamber[k] - chamber[k - 1]) / sample_s
        coil[k] = (chamber[k] - slope * lag_s
                   + a * (coil[k - 1] - chamber[k - 1] + slope * lag_s))
    coil_rate = (chamber - coil) / lag_s * 60.0  # degC/min
    d = coil - 20.0
    sf_ppm = 12.0 * d + 0.06 * d**2 + 40.0 * np.tanh((coil - 5.0) / 10.0)
    bias = 0.5 + 0.004 * d + 2e-4 * d**2 + 0.3 * coil_rate
    sf_ppm = sf_ppm + gen.normal(0.0, noise_ppm, t.size)
    bias = bias + gen.normal(0.0, noise_deg_h, t.size)
    return {
        "cycle": (t // period).astype(int) + 1,
        "time_s": t,
        "temperature_c": chamber,
        "scale_factor": scale_factor_nominal * (1.0 + sf_ppm * 1e-6),
        "bias_deg_h": bias,
        "coil_temperature_c": coil,
    }


# ---------------------------------------------------------------------------------------------
# fitting


#: A time step longer than this many times the median step is a gap in the recording.
GAP_FACTOR = 5.0


def temperature_rate(cycle: NDArray, time_s: NDArray, temperature_c: NDArray) -> NDArray:
    """dT/dt within each cycle by central differences [degC/min].

    A time step longer than :data:`GAP_FACTOR` times the cycle's median step is a gap: no
    difference is taken across it (the rows on either side get one-sided differences), except
    for a row isolated between two gaps, which keeps the difference across them.
    """
    out = np.empty_like(temperature_c, dtype=float)
    for c in np.unique(cycle):
        sel = np.flatnonzero(cycle == c)
        if sel.size < 3:
            raise DataError(f"cycle {c} has {sel.size} rows; each cycle needs at least 3")
        ts = time_s[sel]
        step = np.diff(ts)
        if np.any(step <= 0):
            raise DataError(f"time_s must increase within cycle {c}; sort the rows by time")
        rate = np.gradient(temperature_c[sel], ts) * 60.0
        cuts = np.flatnonzero(step > GAP_FACTOR * np.median(step)) + 1
        for seg in np.split(np.arange(sel.size), cuts):
            if seg.size >= 2:
                rate[seg] = np.gradient(temperature_c[sel][seg], ts[seg]) * 60.0
        out[sel] = rate
    return out


def identifiable_terms(dt: NDArray, rate: NDArray | None, exponents: tuple[tuple[int, int], ...],
                       *, tol: float = 1e-6) -> tuple[tuple[int, int], ...]:
    """The terms of ``exponents`` the data determine, lowest order first.

    Columns ``x^i y^j`` of the scaled design (``x = dt / max|dt|``, ``y = rate / max|rate|``,
    each column of unit norm) are taken in order; a column whose part orthogonal to the columns
    already kept has a norm below ``tol`` is a combination of them (e.g. ``rate^2`` when the
    rate takes only the values +-r, or ``T rate^2`` when the rate is 0 at only one or two
    temperatures) and is left out: its coefficient is not identifiable from these data.
    """
    x = dt / max(float(np.max(np.abs(dt))), 1e-300)
    y = None if rate is None else rate / max(float(np.max(np.abs(rate))), 1e-300)
    keep: list[tuple[int, int]] = []
    basis = np.zeros((dt.size, 0))
    for i, j in exponents:
        col = poly_design(x, y, ((i, j),))[:, 0]
        norm = float(np.linalg.norm(col))
        if norm == 0.0:
            continue
        col = col / norm
        for _ in range(2):  # Gram-Schmidt, twice for orthogonality to rounding
            col = col - basis @ (basis.T @ col)
        left = float(np.linalg.norm(col))
        if left > tol:
            keep.append((i, j))
            basis = np.column_stack([basis, col / left])
    return tuple(keep)


def _term_label(i: int, j: int) -> str:
    parts = [b if k == 1 else f"{b}^{k}" for b, k in (("(T - T_ref)", i), ("(dT/dt)", j)) if k]
    return " ".join(parts) or "1"


def _scaled_fit(dt: NDArray, rate: NDArray | None, exps: tuple[tuple[int, int], ...],
                y: NDArray) -> tuple[NDArray, NDArray, float]:
    """Least squares in scaled regressors; coefficients, covariance, sigma in the raw units."""
    sx = max(float(np.max(np.abs(dt))), 1e-300)
    sy = 1.0 if rate is None else max(float(np.max(np.abs(rate))), 1e-300)
    A = poly_design(dt / sx, None if rate is None else rate / sy, exps)
    lf = weighted_least_squares(A, y)
    if lf.rank < len(exps):
        raise IdentifiabilityError(
            f"the polynomial terms {list(exps)} are not all determined by the training data "
            f"(rank {lf.rank} of {len(exps)}); record more varied temperatures and rates")
    d = np.array([1.0 / (sx**i * sy**j) for i, j in exps])
    return lf.x * d, lf.covariance * np.outer(d, d), float(lf.sigma)


def _cv_rms(dt: NDArray, rate: NDArray | None, exps: tuple[tuple[int, int], ...], y: NDArray,
            groups: NDArray) -> float:
    """Leave-one-cycle-out RMS (root of the mean of the folds' mean squared errors)."""
    sx = max(float(np.max(np.abs(dt))), 1e-300)
    sy = 1.0 if rate is None else max(float(np.max(np.abs(rate))), 1e-300)
    A = poly_design(dt / sx, None if rate is None else rate / sy, exps)
    mse = []
    for g in np.unique(groups):
        out = groups == g
        c, *_ = np.linalg.lstsq(A[~out], y[~out], rcond=None)
        mse.append(float(np.mean((y[out] - A[out] @ c) ** 2)))
    return float(np.sqrt(np.mean(mse)))


def fit_thermal(
    data: Mapping[str, object],
    *,
    quantity: str = "scale_factor",
    validation_cycles: int = 1,
    max_degree: int = 5,
    use_rate: bool = True,
    hidden: int = 10,
    max_iter: int = 3000,
    random_state: int = 0,
    t_ref_c: float | None = None,
    serial: str = "",
) -> ThermalResult:
    """Fit polynomial (degree by cross-validation) and BP-network compensation models.

    Parameters
    ----------
    data : mapping
        Columns ``cycle``, ``time_s``, ``temperature_c`` and ``scale_factor`` or ``bias_deg_h``.
    quantity : {"scale_factor", "bias"}
    validation_cycles : int
        Number of last cycles held out for validation.
    max_degree : int
        Highest polynomial degree tried.
    use_rate : bool
        Use the temperature rate as a second input (captures the lag / hysteresis).
    hidden : int
        Neurons in the network's hidden layer.
    max_iter : int
        L-BFGS iteration limit of the network; if reached, the result says so.
    random_state : int
        Seed of the network's initial weights (fixed: results are reproducible).
    t_ref_c : float, optional
        Reference temperature ``T_ref`` [degC] of the polynomial in ``(T - T_ref)``; default
        the training mean rounded to 0.1 degC.
    serial : str
        Instrument serial, written into the exported models.

    Notes
    -----
    The chosen polynomial is refitted by least squares in ``(T - T_ref)`` [degC] and ``dT/dt``
    [degC/min] (:class:`~inertest.models.thermal.PolynomialThermalModel`; the same
    function space as the cross-validated pipeline), its coefficient covariance from the
    training residuals taken as white. The network is exported as arrays
    (:class:`~inertest.models.thermal.NetworkThermalModel`); its predictions here are
    the numpy forward pass of those arrays.
    """
    # scikit-learn (~1.5 s to import) loads only when a thermal model is fitted.
    from inertest.errors import import_extra

    import_extra("sklearn", "fitting thermal models (the neural network and its polynomial "
                            "rival)")
    from sklearn.compose import TransformedTargetRegressor
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    if quantity not in QUANTITIES:
        raise InputError(f"quantity {quantity!r} unknown; use one of {', '.join(QUANTITIES)}")
    column, unit = QUANTITIES[quantity]
    need = ("cycle", "time_s", "temperature_c", column)
    cols = require_columns(data, need, (), procedure="thermal")
    if validation_cycles < 1 or max_degree < 1 or hidden < 1 or max_iter < 1:
        raise InputError("validation_cycles, max_degree, hidden and max_iter must be >= 1")
    cycle = cols["cycle"].astype(int)
    order = np.lexsort((cols["time_s"], cycle))
    cycle = cycle[order]
    time_s, temp, raw = cols["time_s"][order], cols["temperature_c"][order], cols[column][order]
    ids = np.unique(cycle)
    if ids.size < MIN_TRAIN_CYCLES + validation_cycles:
        raise IdentifiabilityError(
            f"{ids.size} temperature cycle(s) found; cross-validating the polynomial order needs "
            f"{MIN_TRAIN_CYCLES} training cycles and validation {validation_cycles} more: record "
            f"at least {MIN_TRAIN_CYCLES + validation_cycles} cycles (or lower validation_cycles)"
        )
    if np.ptp(temp) < 5.0:
        raise IdentifiabilityError(
            f"the temperature spans only {np.ptp(temp):.3g} degC: no temperature dependence can "
            "be found; cycle over the operating range"
        )
    rate = temperature_rate(cycle, time_s, temp)
    train = ~np.isin(cycle, ids[-validation_cycles:])
    if use_rate and np.ptp(rate[train]) < 1e-3:
        raise IdentifiabilityError(
            "the temperature rate is constant in the training cycles, so its effect cannot be "
            "found; ramp the temperature up and down, or fit without the rate (use_rate=False)"
        )
    reference = float(np.mean(raw[train]))
    if quantity == "scale_factor":
        if reference == 0:
            raise DataError("the mean scale factor is 0; ppm residuals need a non-zero scale")
        y = (raw / reference - 1.0) * 1e6
    else:
        reference = 0.0
        y = raw.copy()
    X = np.column_stack([temp, rate]) if use_rate else temp[:, None]
    inputs = ("temperature_c", "temperature_rate_c_per_min")[: X.shape[1]]

    def rms(r: NDArray) -> float:
        return float(np.sqrt(np.mean(r**2)))

    t_ref = float(np.round(np.mean(temp[train]), 1)) if t_ref_c is None else float(t_ref_c)
    if not np.isfinite(t_ref):
        raise InputError(f"t_ref_c must be a finite temperature [degC], got {t_ref_c!r}")
    # Polynomial: degree by leave-one-cycle-out CV on the training cycles, each degree with
    # only the terms the training data determine (a rate sampled at a few values, or a zero
    # rate seen at only the dwell temperatures, leaves higher rate powers unidentifiable).
    dt_train = temp[train] - t_ref
    r_train = rate[train] if use_rate else None
    cv: dict[int, float] = {}
    terms: dict[int, tuple[tuple[int, int], ...]] = {}
    for deg in range(1, max_degree + 1):
        terms[deg] = identifiable_terms(dt_train, r_train, poly_exponents(deg, use_rate))
        cv[deg] = _cv_rms(dt_train, r_train, terms[deg], y[train], cycle[train])
    # Parsimony: the lowest degree within 2 % of the best CV RMS (plus a floor for noise-free
    # data, where every degree above the true one fits to rounding).
    floor = 1.02 * min(cv.values()) + 1e-9 * float(np.sqrt(np.mean(y[train] ** 2)))
    best = min(d for d, v in cv.items() if v <= floor)
    support = observed_support(temp[train], rate[train]) if use_rate else (None, None)
    common: dict[str, Any] = dict(
        quantity=quantity, unit=unit, reference=reference, inputs=inputs,
        temperature_range_c=observed_range(temp[train]),
        rate_range_c_per_min=observed_range(rate[train]) if use_rate else None,
        serial=serial, support=support[0], support_tolerance=support[1],
    )
    exps = terms[best]
    dropped = [e for e in poly_exponents(best, use_rate) if e not in exps]
    coef, cov, sigma = _scaled_fit(dt_train, r_train, exps, y[train])
    poly_model = PolynomialThermalModel(
        **common, t_ref_c=t_ref, exponents=exps, coefficients=coef, covariance=cov,
        noise=sigma)
    p_pred = poly_model.predict(temp, rate if use_rate else None)
    poly_val = rms(y[~train] - p_pred[~train])
    poly_fit = ThermalModelFit(
        "polynomial", f"degree {best} in {', '.join(inputs)}"
        + (f" ({len(exps)} of {len(exps) + len(dropped)} terms identifiable)" if dropped else ""),
        rms(y[train] - p_pred[train]), poly_val, p_pred,
        model=replace(poly_model, validation_rms=poly_val))

    net = TransformedTargetRegressor(
        regressor=Pipeline([
            ("scale", StandardScaler()),
            ("mlp", MLPRegressor(hidden_layer_sizes=(hidden,), activation="tanh",
                                 solver="lbfgs", alpha=1e-4, max_iter=max_iter,
                                 random_state=random_state)),
        ]),
        transformer=StandardScaler(),
    )
    # L-BFGS stopping at max_iter warns; catch it and report it in the result instead.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        net.fit(X[train], y[train])
    converged = not any(issubclass(w.category, ConvergenceWarning) for w in caught)
    n_iter = int(net.regressor_.named_steps["mlp"].n_iter_)
    mlp = net.regressor_.named_steps["mlp"]
    xs = net.regressor_.named_steps["scale"]
    net_model = NetworkThermalModel(
        **common, x_mean=np.array(xs.mean_, dtype=float), x_scale=np.array(xs.scale_, dtype=float),
        weights=tuple(np.array(w, dtype=float) for w in mlp.coefs_),
        biases=tuple(np.array(b, dtype=float) for b in mlp.intercepts_),
        activation=str(mlp.activation), y_mean=float(net.transformer_.mean_[0]),
        y_scale=float(net.transformer_.scale_[0]))
    n_pred = net_model.predict(temp, rate if use_rate else None)
    net_val = rms(y[~train] - n_pred[~train])
    net_fit = ThermalModelFit(
        "neural network", f"BP network, {len(inputs)}-{hidden}-1 tanh, L-BFGS {n_iter} iterations",
        rms(y[train] - n_pred[train]), net_val, n_pred, converged,
        model=replace(net_model, validation_rms=net_val), estimator=net)
    messages = []
    if dropped:
        n_rates = np.unique(np.round(rate[train], 6)).size if use_rate else 0
        messages.append(
            "the training data do not determine the polynomial terms "
            + ", ".join(_term_label(i, j) for i, j in dropped)
            + (f" (the rate takes {n_rates} distinct values, seen at few temperatures)"
               if use_rate and n_rates <= 10 else "")
            + ": they are left out; the model is valid only near the temperature x rate "
            "combinations of the training cycles (valid_range.observed)")
    if best == max_degree:
        messages.append(
            f"the highest polynomial degree tried ({max_degree}) fits best in cross-validation; "
            "a higher max_degree may fit better"
        )
    if not converged:
        messages.append(
            f"the neural network did not converge in {max_iter} iterations; its residuals are "
            "shown as they are, and may improve with a higher max_iter"
        )
    return ThermalResult(
        quantity=quantity, unit=unit, reference=reference, inputs=inputs, cycle=cycle,
        time_s=time_s, temperature_c=temp, rate_c_per_min=rate, value=y, train=train,
        before_train_rms=rms(y[train] - np.mean(y[train])),
        before_validation_rms=rms(y[~train] - np.mean(y[train])),
        polynomial=poly_fit, network=net_fit, cv_rms=cv, messages=tuple(messages),
        serial=serial,
    )


def _polynomial(degree: int) -> Pipeline:
    from sklearn.linear_model import LinearRegression
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import PolynomialFeatures, StandardScaler

    return Pipeline([
        ("scale", StandardScaler()),
        ("poly", PolynomialFeatures(degree, include_bias=False)),
        ("lin", LinearRegression()),
    ])
