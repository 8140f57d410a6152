"""Thermal compensation models that can be put into an instrument: plain arrays, no pickles.

A model fitted by :func:`inertest.procedures.thermal_compensation.fit_thermal` is exported as
one of two frozen dataclasses that hold only numbers (and serialise to versioned JSON, format
:data:`FORMAT_VERSION`), so an instrument's firmware, or any other program, can evaluate it:

* :class:`PolynomialThermalModel`: ``value [unit] = sum_k c_k (T - T_ref)^i_k (dT/dt)^j_k``
  with ``T`` [degC], ``dT/dt`` [degC/min], the coefficients' covariance (from the residuals of
  the training cycles), so the correction carries its propagated uncertainty;
* :class:`NetworkThermalModel`: the seed's BP network (seed ``003_f374f866dfe7c99f.txt``):
  ``z = (x - x_mean) / x_scale``, ``h = tanh(z W1 + b1)``, ``y = (h W2 + b2) y_scale + y_mean``
  (weights, biases and scalers as arrays; the forward pass is rebuilt here in numpy).

``value`` is the bias [deg/h] or the scale-factor deviation [ppm] from ``reference`` (the
training mean of the scale factor, in the data's unit). Compensation (:meth:`compensate`)::

    bias:          corrected = raw - bias(T, dT/dt)                       [deg/h]
    scale factor:  corrected = raw / (reference (1 + 1e-6 ppm(T, dT/dt)))

Each model states the temperature (and rate) range of its training data; outside it the model
extrapolates, and :meth:`out_of_range` measures by how much (values beyond the range by less
than :data:`RANGE_RTOL` of its width count as inside: rounding, not extrapolation). A model with
the rate also records the temperature x rate combinations it was trained on (``observed``: the
training points thinned to a grid of :data:`SUPPORT_FRACTION` of each span, which is also the
tolerance): a row inside the box but far from every training point (e.g. 10 degC at rate 0 when
the chamber dwelt only at the ends) is an extrapolation too, see :meth:`outside_support`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError

#: Version of the model file format (``format_version`` in the JSON).
FORMAT_VERSION = 1
#: ``kind`` of a model file.
MODEL_KIND = "thermal-model"
QUANTITY_UNITS = {"scale_factor": "ppm", "bias": "deg/h"}
INPUT_NAMES = ("temperature_c", "temperature_rate_c_per_min")
#: Relative tolerance of the range check, as a fraction of the range's width.
RANGE_RTOL = 1e-9
#: Grid step of the observed (T, dT/dt) support and its tolerance, as a fraction of each span.
SUPPORT_FRACTION = 0.05


@dataclass(frozen=True, kw_only=True)
class _ThermalModel:
    """Fields shared by both model types.

    Attributes
    ----------
    quantity : {"scale_factor", "bias"}
    unit : str
        Unit of the model value (``ppm`` of ``reference`` or ``deg/h``).
    reference : float
        Training mean of the scale factor [data unit] (``0`` for the bias).
    inputs : tuple of str
        ``("temperature_c",)`` or ``("temperature_c", "temperature_rate_c_per_min")``.
    temperature_range_c : tuple of float
        Training temperatures [degC] (min, max): the valid range.
    rate_range_c_per_min : tuple of float or None
        Training temperature rates [degC/min] (min, max) when the model uses the rate.
    serial : str
        Instrument serial ("" when unknown).
    validation_rms : float
        RMS residual on the held-out cycles [unit]: the compensation's accuracy on new data.
    support : ndarray, shape (m, 2), or None
        Training ``(T [degC], dT/dt [degC/min])`` points thinned to a grid (rate models only).
    support_tolerance : tuple of float or None
        Distance [degC], [degC/min] within which a row counts as near a training point.
    """

    quantity: str
    unit: str
    reference: float
    inputs: tuple[str, ...]
    temperature_range_c: tuple[float, float]
    rate_range_c_per_min: tuple[float, float] | None = None
    serial: str = ""
    validation_rms: float = float("nan")
    support: NDArray[np.float64] | None = field(default=None, repr=False)
    support_tolerance: tuple[float, float] | None = None

    model_type: ClassVar[str] = ""

    @property
    def uses_rate(self) -> bool:
        """Whether the model needs the temperature rate as a second input."""
        return len(self.inputs) == 2

    def _inputs(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        t = np.atleast_1d(np.asarray(temperature_c, dtype=float))
        if not self.uses_rate:
            return t, None
        if rate_c_per_min is None:
            raise InputError("this thermal model uses the temperature rate: give the rate "
                             "[degC/min] (CLI: --time-column)")
        r = np.broadcast_to(np.asarray(rate_c_per_min, dtype=float), t.shape)
        return t, r

    def predict(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                ) -> NDArray[np.float64]:
        """Model value [unit] at temperatures [degC] (and rates [degC/min])."""
        raise NotImplementedError

    def predict_std(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                    ) -> NDArray[np.float64] | None:
        """Standard uncertainty of the model value [unit] from the coefficients, if known."""
        return None

    def out_of_range(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Distance of each row outside the valid range: temperature [degC], rate [degC/min].

        Zero inside the range, and within :data:`RANGE_RTOL` of its width beyond it.
        """
        t, r = self._inputs(temperature_c, rate_c_per_min)
        dt = _beyond(t, self.temperature_range_c)
        dr = None
        if r is not None and self.rate_range_c_per_min is not None:
            dr = _beyond(r, self.rate_range_c_per_min)
        return dt, dr

    def outside_support(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                        ) -> NDArray[np.bool_]:
        """Rows whose (T, dT/dt) is farther than the tolerance from every training point.

        All False for a temperature-only model or one without a recorded support.
        """
        t, r = self._inputs(temperature_c, rate_c_per_min)
        if r is None or self.support is None or self.support_tolerance is None:
            return np.zeros(t.shape, dtype=bool)
        from scipy.spatial import cKDTree

        tol = np.asarray(self.support_tolerance, dtype=float)
        tree = cKDTree(self.support / tol)
        dist, _ = tree.query(np.column_stack([t, r]) / tol)
        return np.asarray(dist > 1.0 + 1e-9)

    def compensate(self, raw: ArrayLike, temperature_c: ArrayLike,
                   rate_c_per_min: ArrayLike | None = None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Compensated output and the standard uncertainty of the correction.

        Parameters
        ----------
        raw : array_like, shape (n,)
            Raw output: rate [deg/h] for a bias model; any quantity proportional to the scale
            factor for a scale-factor model (e.g. pulses, or the measured scale factor itself).
        temperature_c, rate_c_per_min : array_like, shape (n,)
            Temperature [degC] and its rate [degC/min] of each row.

        Returns
        -------
        corrected : ndarray, shape (n,)
            ``raw - bias(T)`` [deg/h] or ``raw / scale(T)`` [raw unit / scale-factor unit].
        std : ndarray or None
            Standard uncertainty of ``corrected`` due to the model's coefficients (same unit);
            None when the model has no coefficient covariance (network).
        """
        y = np.asarray(raw, dtype=float)
        value = self.predict(temperature_c, rate_c_per_min)
        sd = self.predict_std(temperature_c, rate_c_per_min)
        if self.quantity == "bias":
            return y - value, sd
        factor = 1.0 + 1e-6 * value
        out = y / (self.reference * factor)
        return out, None if sd is None else np.abs(out) * 1e-6 * sd / np.abs(factor)

    def _common_dict(self) -> dict[str, object]:
        return {
            "kind": MODEL_KIND,
            "format_version": FORMAT_VERSION,
            "model_type": self.model_type,
            "serial": self.serial,
            "quantity": self.quantity,
            "unit": self.unit,
            "reference": self.reference,
            "reference_note": ("training mean of the scale factor, in the data's unit; the model "
                               "value is the deviation from it in ppm"
                               if self.quantity == "scale_factor" else "bias model: no reference"),
            "inputs": list(self.inputs),
            "input_units": ["degC", "degC/min"][: len(self.inputs)],
            "valid_range": {
                "temperature_c": list(self.temperature_range_c),
                "temperature_rate_c_per_min": (None if self.rate_range_c_per_min is None
                                               else list(self.rate_range_c_per_min)),
                **({"observed": {
                    "note": ("temperature x rate combinations of the training data (thinned to "
                             "a grid); a row farther than the tolerance from all of them is an "
                             "extrapolation"),
                    "points_c_and_c_per_min": self.support.tolist(),
                    "tolerance": list(self.support_tolerance),
                    "tolerance_units": ["degC", "degC/min"]}}
                   if self.support is not None and self.support_tolerance is not None else {}),
            },
            "validation_rms": {"value": self.validation_rms, "unit": self.unit},
            "compensation": ("corrected = raw - bias(T, dT/dt)" if self.quantity == "bias" else
                             "corrected = raw / (reference * (1 + 1e-6 * ppm(T, dT/dt)))"),
        }

    def to_dict(self) -> dict[str, object]:
        """Versioned JSON document of the model (plain numbers and lists)."""
        raise NotImplementedError


@dataclass(frozen=True, kw_only=True)
class PolynomialThermalModel(_ThermalModel):
    """``value [unit] = sum_k c_k (T - T_ref)^i_k (dT/dt)^j_k``, with covariance.

    Attributes
    ----------
    t_ref_c : float
        Reference temperature ``T_ref`` [degC].
    exponents : tuple of (int, int)
        ``(i_k, j_k)``: powers of ``(T - T_ref)`` [degC] and of ``dT/dt`` [degC/min].
    coefficients : ndarray, shape (p,)
        ``c_k`` [unit / (degC^i_k (degC/min)^j_k)].
    covariance : ndarray, shape (p, p)
        Covariance of the coefficients (noise from the training residuals).
    noise : float
        Residual standard deviation of the training fit [unit].
    """

    t_ref_c: float
    exponents: tuple[tuple[int, int], ...]
    coefficients: NDArray[np.float64] = field(repr=False)
    covariance: NDArray[np.float64] = field(repr=False)
    noise: float = float("nan")

    model_type: ClassVar[str] = "polynomial"

    def design(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
               ) -> NDArray[np.float64]:
        """Regressors ``(T - T_ref)^i (dT/dt)^j`` of each row, shape (n, p)."""
        t, r = self._inputs(temperature_c, rate_c_per_min)
        return poly_design(t - self.t_ref_c, r, self.exponents)

    def predict(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                ) -> NDArray[np.float64]:
        """Model value [unit]."""
        return self.design(temperature_c, rate_c_per_min) @ self.coefficients

    def predict_std(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                    ) -> NDArray[np.float64]:
        """Standard uncertainty of the model value [unit]: ``sqrt(phi^T C phi)``."""
        phi = self.design(temperature_c, rate_c_per_min)
        return np.sqrt(np.clip(np.einsum("ij,jk,ik->i", phi, self.covariance, phi), 0.0, None))

    def term_units(self) -> list[str]:
        """Unit of each coefficient."""
        out = []
        for i, j in self.exponents:
            den = [p for p in (_power("degC", i), _power("(degC/min)", j)) if p]
            out.append(self.unit + ("/" + " ".join(den) if den else ""))
        return out

    def equation(self) -> str:
        """The model written out, e.g. ``bias [deg/h] = c0 + c1 (T - T_ref) + ...``."""
        name = "bias" if self.quantity == "bias" else "scale factor deviation"
        terms = []
        for k, (i, j) in enumerate(self.exponents):
            rate = _power("dT/dt" if j == 1 else "(dT/dt)", j)
            parts = [p for p in (_power("(T - T_ref)", i), rate) if p]
            terms.append(" ".join([f"c{k}", *parts]))
        return (f"{name} [{self.unit}] = {' + '.join(terms)}; T [degC], T_ref = "
                f"{self.t_ref_c:g} degC" + (", dT/dt [degC/min]" if self.uses_rate else ""))

    def to_dict(self) -> dict[str, object]:
        """Versioned JSON of the model: coefficients with units, covariance, equation."""
        units = self.term_units()
        std = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        return {
            **self._common_dict(),
            "equation": self.equation(),
            "t_ref_c": self.t_ref_c,
            "terms": [{"name": f"c{k}", "power_of_t_minus_t_ref": i, "power_of_rate": j,
                       "value": float(c), "std": float(s), "unit": u}
                      for k, ((i, j), c, s, u) in enumerate(zip(
                          self.exponents, self.coefficients, std, units, strict=True))],
            "covariance": {"names": [f"c{k}" for k in range(len(self.exponents))],
                           "matrix": self.covariance.tolist(),
                           "units": "products of the terms' units"},
            "noise": {"value": self.noise, "unit": self.unit},
        }


@dataclass(frozen=True, kw_only=True)
class NetworkThermalModel(_ThermalModel):
    """One-hidden-layer BP network as plain arrays.

    Attributes
    ----------
    x_mean, x_scale : ndarray, shape (n_in,)
        Input standardisation ``z = (x - x_mean) / x_scale`` (``x`` in degC, degC/min).
    weights : tuple of ndarray
        ``W1`` (n_in, n_hidden), ``W2`` (n_hidden, 1).
    biases : tuple of ndarray
        ``b1`` (n_hidden,), ``b2`` (1,).
    activation : str
        Hidden-layer activation (``tanh``); the output layer is linear.
    y_mean, y_scale : float
        Output scaling ``value = y y_scale + y_mean`` [unit].
    """

    x_mean: NDArray[np.float64] = field(repr=False)
    x_scale: NDArray[np.float64] = field(repr=False)
    weights: tuple[NDArray[np.float64], ...] = field(repr=False)
    biases: tuple[NDArray[np.float64], ...] = field(repr=False)
    activation: str = "tanh"
    y_mean: float = 0.0
    y_scale: float = 1.0

    model_type: ClassVar[str] = "neural-network"
    _ACTIVATIONS: ClassVar[dict[str, object]] = {
        "tanh": np.tanh, "relu": lambda a: np.maximum(a, 0.0), "identity": lambda a: a,
        "logistic": lambda a: 1.0 / (1.0 + np.exp(-a)),
    }

    def predict(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                ) -> NDArray[np.float64]:
        """Model value [unit] by the network's forward pass in numpy."""
        t, r = self._inputs(temperature_c, rate_c_per_min)
        x = t[:, None] if r is None else np.column_stack([t, r])
        act = self._ACTIVATIONS[self.activation]
        a = (x - self.x_mean) / self.x_scale
        for W, b in zip(self.weights[:-1], self.biases[:-1], strict=True):
            a = act(a @ W + b)  # type: ignore[operator]
        y = a @ self.weights[-1] + self.biases[-1]
        return np.asarray(y[:, 0] * self.y_scale + self.y_mean, dtype=float)

    def to_dict(self) -> dict[str, object]:
        """Versioned JSON of the network: weights, biases, activation, scaling."""
        return {
            **self._common_dict(),
            "forward_pass": ("z = (x - input_mean) / input_scale; h = activation(z W1 + b1); "
                             "value = (h W2 + b2) * output_scale + output_mean; x = (T [degC]"
                             + (", dT/dt [degC/min])" if self.uses_rate else ")")),
            "activation": self.activation,
            "input_mean": self.x_mean.tolist(),
            "input_scale": self.x_scale.tolist(),
            "weights": [w.tolist() for w in self.weights],
            "biases": [b.tolist() for b in self.biases],
            "output_mean": self.y_mean,
            "output_scale": self.y_scale,
        }


ThermalModel = PolynomialThermalModel | NetworkThermalModel


def poly_design(dt: NDArray[np.float64], rate: NDArray[np.float64] | None,
                exponents: Sequence[tuple[int, int]]) -> NDArray[np.float64]:
    """Columns ``dt^i rate^j`` for each ``(i, j)`` of ``exponents``, shape (n, p)."""
    cols = []
    for i, j in exponents:
        c = dt**i
        if j:
            if rate is None:
                raise InputError("a rate term needs the temperature rate")
            c = c * rate**j
        cols.append(c)
    return np.column_stack(cols) if cols else np.zeros((dt.size, 0))


def observed_support(temperature_c: NDArray[np.float64], rate_c_per_min: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], tuple[float, float]]:
    """Training (T, dT/dt) points thinned to a grid of :data:`SUPPORT_FRACTION` of each span.

    Returns the points, shape (m, 2), and the tolerance (grid step) [degC], [degC/min].
    """
    t = np.asarray(temperature_c, dtype=float)
    r = np.asarray(rate_c_per_min, dtype=float)
    tol = (max(SUPPORT_FRACTION * float(np.ptp(t)), 1e-6),
           max(SUPPORT_FRACTION * float(np.ptp(r)), 1e-6))
    cells = np.round(np.column_stack([t / tol[0], r / tol[1]]) * 2.0)
    _, first = np.unique(cells, axis=0, return_index=True)
    return np.column_stack([t, r])[np.sort(first)], tol


def observed_range(x: ArrayLike) -> tuple[float, float]:
    """``(min, max)`` of ``x``, each rounded to 10 significant digits of the larger magnitude.

    The valid range of a model is the range of its training inputs; rates computed from
    temperatures and times carry round-off (-1.0000000000000284 degC/min for -1). Rounding
    to 1e-10 of the magnitude removes it and moves each end by less than the range check's
    tolerance (:data:`RANGE_RTOL`), so every training row stays inside.
    """
    a = np.asarray(x, dtype=float)
    lo, hi = float(np.min(a)), float(np.max(a))
    mag = max(abs(lo), abs(hi))
    if mag == 0 or not np.isfinite(mag):
        return lo, hi
    digits = 9 - int(np.floor(np.log10(mag)))
    return round(lo, digits), round(hi, digits)


def _beyond(x: NDArray[np.float64], rng: tuple[float, float]) -> NDArray[np.float64]:
    lo, hi = rng
    tol = RANGE_RTOL * max(hi - lo, abs(lo), abs(hi), 1e-300)
    d = np.maximum(lo - x, 0.0) + np.maximum(x - hi, 0.0)
    return np.where(d > tol, d, 0.0)


def poly_exponents(degree: int, use_rate: bool) -> tuple[tuple[int, int], ...]:
    """All ``(i, j)`` with ``i + j <= degree`` (``j = 0`` without the rate), by total degree."""
    return tuple((d - j, j) for d in range(degree + 1) for j in range(d + 1 if use_rate else 1))


def _power(base: str, k: int) -> str:
    return "" if k == 0 else base if k == 1 else f"{base}^{k}"


def check_model_header(doc: Mapping[str, object], *, kind: str, version: int, what: str,
                       fix: str) -> None:
    """Refuse a model document of another ``kind`` or ``format_version`` (InputError, ``fix``)."""
    if doc.get("kind") != kind:
        raise InputError(f'not a {what}: "kind" is {doc.get("kind")!r}, expected "{kind}" '
                         f"({fix})")
    found = doc.get("format_version")
    if found != version:
        raise InputError(f"{what} format_version {found!r} is not supported (this inertest "
                         f"reads {version}); {fix}")


def model_from_dict(doc: Mapping[str, object]) -> ThermalModel:
    """Rebuild a model from its JSON document (:meth:`to_dict`); bad documents raise InputError."""
    check_model_header(doc, kind=MODEL_KIND, version=FORMAT_VERSION, what="thermal model",
                       fix="write one with inertest thermal fit --model-out")
    try:
        quantity = str(doc["quantity"])
        if quantity not in QUANTITY_UNITS:
            raise InputError(f"thermal model quantity {quantity!r} unknown; expected "
                             f"{' or '.join(QUANTITY_UNITS)}")
        inputs = tuple(str(s) for s in doc["inputs"])  # type: ignore[attr-defined]
        if inputs not in (INPUT_NAMES[:1], INPUT_NAMES):
            raise InputError(f"thermal model inputs {list(inputs)} unknown; expected "
                             f"{list(INPUT_NAMES[:1])} or {list(INPUT_NAMES)}")
        rng = doc["valid_range"]
        t_rng = tuple(float(v) for v in rng["temperature_c"])  # type: ignore[index]
        r_raw = rng.get("temperature_rate_c_per_min")  # type: ignore[attr-defined]
        r_rng = None if r_raw is None else tuple(float(v) for v in r_raw)
        vr = doc.get("validation_rms") or {}
        obs = rng.get("observed")  # type: ignore[attr-defined]
        support = tol = None
        if obs is not None:
            support = np.array(obs["points_c_and_c_per_min"], dtype=float).reshape(-1, 2)
            tol = tuple(float(v) for v in obs["tolerance"])
            if len(tol) != 2 or not all(np.isfinite(tol)) or min(tol) <= 0 or support.size == 0:
                raise InputError("thermal model valid_range.observed needs points and two "
                                 "positive tolerances; rewrite it with thermal fit")
        common = dict(
            quantity=quantity, unit=QUANTITY_UNITS[quantity], reference=float(doc["reference"]),  # type: ignore[arg-type]
            inputs=inputs, temperature_range_c=t_rng, rate_range_c_per_min=r_rng,
            serial=str(doc.get("serial", "")),
            validation_rms=float(vr.get("value", float("nan"))),  # type: ignore[attr-defined]
            support=support, support_tolerance=tol,
        )
        kind = doc.get("model_type")
        if kind == PolynomialThermalModel.model_type:
            terms = doc["terms"]
            exps = tuple((int(t["power_of_t_minus_t_ref"]), int(t["power_of_rate"]))
                         for t in terms)  # type: ignore[attr-defined]
            coef = np.array([float(t["value"]) for t in terms])  # type: ignore[attr-defined]
            cov = np.asarray(doc["covariance"]["matrix"], dtype=np.float64)  # type: ignore[index]
            if cov.shape != (coef.size, coef.size):
                raise InputError(f"thermal model covariance is {cov.shape}, expected "
                                 f"({coef.size}, {coef.size})")
            if any(j and len(inputs) == 1 for _, j in exps):
                raise InputError("thermal model has a rate term but no rate input")
            model: ThermalModel = PolynomialThermalModel(
                **common, t_ref_c=float(doc["t_ref_c"]), exponents=exps,  # type: ignore[arg-type]
                coefficients=coef, covariance=cov,
                noise=float((doc.get("noise") or {}).get("value", float("nan"))))  # type: ignore[attr-defined]
        elif kind == NetworkThermalModel.model_type:
            act = str(doc["activation"])
            if act not in NetworkThermalModel._ACTIVATIONS:
                raise InputError(f"thermal network activation {act!r} unknown; expected one "
                                 f"of {', '.join(NetworkThermalModel._ACTIVATIONS)}")
            ws = tuple(np.array(w, dtype=float) for w in doc["weights"])  # type: ignore[attr-defined]
            bs = tuple(np.array(b, dtype=float) for b in doc["biases"])  # type: ignore[attr-defined]
            x_mean = np.array(doc["input_mean"], dtype=float)
            x_scale = np.array(doc["input_scale"], dtype=float)
            n_in = len(inputs)
            shapes_ok = (len(ws) == len(bs) >= 1 and x_mean.shape == x_scale.shape == (n_in,)
                         and ws[0].ndim == 2 and ws[0].shape[0] == n_in
                         and ws[-1].ndim == 2 and ws[-1].shape[1] == 1
                         and all(w.ndim == 2 and b.shape == (w.shape[1],)
                                 for w, b in zip(ws, bs, strict=True))
                         and all(a.shape[1] == b.shape[0]
                                 for a, b in zip(ws[:-1], ws[1:], strict=True)))
            if not shapes_ok:
                raise InputError("thermal network weights, biases and input scaling have "
                                 "inconsistent shapes; rewrite the file with thermal fit")
            model = NetworkThermalModel(
                **common, x_mean=x_mean, x_scale=x_scale, weights=ws, biases=bs,  # type: ignore[arg-type]
                activation=act, y_mean=float(doc["output_mean"]),  # type: ignore[arg-type]
                y_scale=float(doc["output_scale"]))  # type: ignore[arg-type]
        else:
            raise InputError(f"thermal model_type {kind!r} unknown; expected polynomial or "
                             "neural-network")
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"thermal model document is incomplete or malformed ({type(exc).__name__}"
                         f": {exc}); rewrite it with inertest thermal fit --model-out") from None
    arrays = [model.temperature_range_c]
    if model.rate_range_c_per_min is not None:
        arrays.append(model.rate_range_c_per_min)
    if not all(len(a) == 2 and a[0] <= a[1] for a in arrays):
        raise InputError("thermal model valid_range must be [min, max] pairs with min <= max")
    return model
