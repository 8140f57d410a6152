"""IEEE Std 952-1997 noise identification: five power-law terms fitted to the Allan variance.

Model (IEEE Std 952-1997 Annex C, Table C.2)::

    sigma^2(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2

Q quantization [rate unit x s], N angle/velocity random walk [rate unit x sqrt(s)], B bias
instability [rate unit], K rate random walk [rate unit / sqrt(s)], R rate ramp [rate unit / s].
The coefficients' squares are fitted by bounded least squares to the overlapping Allan
variances, each weighted by its chi-squared standard deviation ``model(tau) sqrt(2/edf)``
(iterated so the weights do not favour points that happen to fall low). B is bounded by the
flat floor: ``0.664 B`` can never exceed the upper 1-sigma limit of any measured deviation.

The fit is judged by ``chi2/dof`` with those weights: above :data:`CHI2_LIMIT` the five-term
model does not describe the record (dither, vibration, a bounded angle motion, a trend...),
no term is reported as resolved and a :class:`NoiseFitWarning` is issued. A term is
*resolved* only when the model fits, the term is more than :data:`SIGNIFICANCE` standard
deviations above zero and it is the largest term somewhere on the tau range; otherwise only
an upper bound is reported: the largest value the term could have without exceeding the upper
confidence limit of any measured point.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import lsq_linear
from scipy.stats import chi2 as _chi2

from inertest.errors import DataError
from inertest.noise.deviations import DeviationResult, oadev
from inertest.units import (
    ARCSEC_TO_RAD,
    DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S,
    DEG_PER_H_TO_RAD_PER_S,
    DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S,
    HOUR_TO_S,
    M_PER_S_PER_SQRT_H_TO_M_PER_S_PER_SQRT_S,
    MICRO_G_TO_M_PER_S2,
)

#: Terms in the order of the model.
TERMS = ("Q", "N", "B", "K", "R")
TERM_NAMES = {
    "Q": "quantization",
    "N": "random walk (angle / velocity)",
    "B": "bias instability",
    "K": "rate random walk",
    "R": "rate ramp",
}
#: How many standard deviations above zero the fitted square of a resolved term must be
#: (about 97.7 % one-sided for a Gaussian estimate).
SIGNIFICANCE = 2.0
#: Largest chi2/dof (EDF-based weights) for which the model is taken to fit. The overlapping
#: variances at neighbouring taus are correlated, and where two terms overlap the EDF of the
#: identified single noise type is too large, so a correct model scatters more than an
#: uncorrelated chi-squared law: 60 simulated records of the model (N+K, Q+N, 1e5 samples)
#: reached 7.1. Real records the model cannot describe give 1e3 and more.
CHI2_LIMIT = 10.0
_B_FACTOR = 2.0 * math.log(2.0) / math.pi


class NoiseFitWarning(UserWarning):
    """The five-term model does not describe the Allan variance of the record."""

# Engineering units per instrument: term -> (unit, factor from SI to that unit).
_ENG = {
    "gyro": {
        "Q": ("arcsec", 1.0 / ARCSEC_TO_RAD),
        "N": ("deg/sqrt(h)", 1.0 / DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S),
        "B": ("deg/h", 1.0 / DEG_PER_H_TO_RAD_PER_S),
        "K": ("deg/h/sqrt(h)", 1.0 / DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S),
        "R": ("deg/h^2", HOUR_TO_S / DEG_PER_H_TO_RAD_PER_S),
    },
    "accelerometer": {
        "Q": ("m/s", 1.0),
        "N": ("m/s/sqrt(h)", 1.0 / M_PER_S_PER_SQRT_H_TO_M_PER_S_PER_SQRT_S),
        "B": ("ug", 1.0 / MICRO_G_TO_M_PER_S2),
        "K": ("ug/sqrt(h)", math.sqrt(HOUR_TO_S) / MICRO_G_TO_M_PER_S2),
        "R": ("ug/h", HOUR_TO_S / MICRO_G_TO_M_PER_S2),
    },
}
_SI = {
    "gyro": {"Q": "rad", "N": "rad/sqrt(s)", "B": "rad/s", "K": "rad/s/sqrt(s)", "R": "rad/s^2"},
    "accelerometer": {"Q": "m/s", "N": "m/s/sqrt(s)", "B": "m/s^2", "K": "m/s^2/sqrt(s)",
                      "R": "m/s^3"},
    None: {"Q": "s", "N": "sqrt(s)", "B": "1", "K": "1/sqrt(s)", "R": "1/s"},
}


def basis(taus: NDArray) -> NDArray:
    """Design matrix ``A`` with ``sigma^2 = A @ [Q^2, N^2, B^2, K^2, R^2]``, shape (n, 5)."""
    t = np.asarray(taus, dtype=float)
    return np.column_stack([3.0 / t**2, 1.0 / t, np.full_like(t, _B_FACTOR), t / 3.0, t**2 / 2.0])


@dataclass(frozen=True)
class NoiseTerm:
    """One term of the five-term model.

    ``value``/``std`` are in SI (``unit_si``); ``value_eng``/``std_eng`` in ``unit``. When the
    term is not resolved ``value`` is None and ``upper_bound`` says how large it could be.
    """

    name: str
    description: str
    resolved: bool
    value: float | None
    std: float | None
    upper_bound: float
    unit_si: str
    value_eng: float | None
    std_eng: float | None
    upper_bound_eng: float
    unit: str
    note: str

    def to_dict(self) -> dict[str, object]:
        """JSON-ready mapping (engineering and SI units)."""
        return {
            "description": self.description,
            "resolved": self.resolved,
            "value": self.value_eng,
            "std": self.std_eng,
            "upper_bound": self.upper_bound_eng,
            "unit": self.unit,
            "value_si": self.value,
            "std_si": self.std,
            "upper_bound_si": self.upper_bound,
            "unit_si": self.unit_si,
            "note": self.note,
        }


@dataclass(frozen=True)
class NoiseModel:
    """Result of :func:`identify_noise`: the five terms and the fitted Allan variance."""

    terms: dict[str, NoiseTerm]
    coefficients_sq: NDArray  # fitted [Q^2, N^2, B^2, K^2, R^2], SI
    covariance_sq: NDArray  # (5, 5) covariance of the squares (zeros for terms at the bound)
    taus: NDArray
    instrument: str | None
    chi2_per_dof: float
    dof: int = 0
    fits: bool = True
    verdict: str = ""
    max_misfit: float = 1.0  # largest ratio between model and measured deviation (>= 1)
    checks: tuple[str, ...] = ()

    def model_dev(self, taus: NDArray, term: str | None = None) -> NDArray:
        """Model deviation at ``taus`` (all terms, or one term's asymptote)."""
        a = basis(np.asarray(taus, dtype=float))
        p = self.coefficients_sq.copy()
        if term is not None:
            keep = TERMS.index(term)
            p = np.where(np.arange(5) == keep, p, 0.0)
        return np.sqrt(a @ p)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready mapping ``{name: term}`` plus fit quality."""
        return {
            "model": "IEEE Std 952-1997 Annex C five-term Allan variance",
            "instrument": self.instrument,
            "terms": {k: t.to_dict() for k, t in self.terms.items()},
            "chi2_per_dof": self.chi2_per_dof,
            "dof": self.dof,
            "fits": self.fits,
            "verdict": self.verdict,
            "max_misfit": self.max_misfit,
            "checks": list(self.checks),
        }


def simulate_noise(
    n: int, rate: float, *, q: float = 0.0, n_rw: float = 0.0, b: float = 0.0, k: float = 0.0,
    r: float = 0.0, rng: np.random.Generator | int | None = None,
) -> NDArray:
    """Rate samples whose Allan variance is the five-term model (IEEE Std 952 Annex C).

    Parameters
    ----------
    n : int
        Number of rate samples.
    rate : float
        Sample rate [Hz].
    q, n_rw, b, k, r : float
        Q [u s], N [u sqrt(s)], B [u], K [u/sqrt(s)], R [u/s] in SI (u: rad/s or m/s^2).
    rng : numpy Generator, int or None

    Notes
    -----
    Q: white angle noise of standard deviation Q (SP 1065: AVAR = 3 sigma_x^2 / tau^2);
    N: white rate noise N/sqrt(tau0); K: random walk with steps K sqrt(tau0); R: ramp R t;
    B: flicker noise synthesised in the frequency domain with one-sided PSD h/f, h = B^2/pi, so
    that AVAR = 2 ln2 h = (2 ln2/pi) B^2 (synthesised over 2n samples, first n kept, to avoid the
    periodicity of the FFT).
    """
    g = np.random.default_rng(rng)
    tau0 = 1.0 / rate
    y = np.zeros(n)
    if n_rw > 0:
        y += (n_rw / math.sqrt(tau0)) * g.standard_normal(n)
    if k > 0:
        y += np.cumsum((k * math.sqrt(tau0)) * g.standard_normal(n))
    if r > 0:
        y += r * tau0 * np.arange(n)
    if q > 0:
        x = q * g.standard_normal(n + 1)
        y += np.diff(x) / tau0
    if b > 0:
        m = 2 * n
        f = np.fft.rfftfreq(m, tau0)
        amp = np.zeros_like(f)
        amp[1:] = np.sqrt((b * b / math.pi) / f[1:] * m / (4.0 * tau0))
        spec = amp * (g.standard_normal(f.size) + 1j * g.standard_normal(f.size))
        y += np.fft.irfft(spec, m)[:n]
    return y


#: Bootstrap records longer than this are simulated at a lower rate over the same duration.
_BOOT_MAX = 1 << 20


def _bootstrap_std(p: NDArray, taus: NDArray, rate: float, n: int, n_boot: int,
                   rng: np.random.Generator) -> NDArray:
    """Std of the fitted squares over records simulated from the fitted model.

    The overlapping Allan variances at neighbouring taus share data, so a fit that treats them
    as independent understates the uncertainty; simulating the whole chain does not.
    """
    dec = max(1, math.ceil(n / _BOOT_MAX))
    rate_b, n_b = rate / dec, n // dec
    m_b = np.unique(np.rint(taus * rate_b))
    m_b = m_b[(m_b >= 1) & (m_b <= (n_b - 1) // 2)]
    sq = np.sqrt(p)
    fits = []
    for _ in range(n_boot):
        y = simulate_noise(n_b, rate_b, q=sq[0], n_rw=sq[1], b=sq[2], k=sq[3], r=sq[4], rng=rng)
        res = oadev(y, rate_b, m_b / rate_b)
        fits.append(_fit(res.taus, res.var, np.maximum(res.edf, 1.0))[0])
    return np.std(np.asarray(fits), axis=0, ddof=1)


def _fit(taus: NDArray, var: NDArray, edf: NDArray,
         upper: NDArray | None = None) -> tuple[NDArray, NDArray, float]:
    """Iteratively reweighted bounded least squares of the squares (0 <= p <= upper).

    Returns (p, weights, chi2 per dof) with the weights ``1 / (model sqrt(2/edf))``.
    """
    a = basis(taus)
    sd = var * np.sqrt(2.0 / edf)
    p = np.zeros(5)
    hi = np.full(5, np.inf) if upper is None else upper
    for _ in range(8):
        w = 1.0 / np.where(sd > 0, sd, np.max(sd) if np.max(sd) > 0 else 1.0)
        aw = a * w[:, None]
        scale = np.where(np.max(np.abs(aw), axis=0) > 0, np.max(np.abs(aw), axis=0), 1.0)
        sol = lsq_linear(aw / scale, var * w, bounds=(np.zeros(5), hi * scale),
                         method="bvls", tol=1e-12)
        p = sol.x / scale
        model = a @ p
        sd_new = np.where(model > 0, model, var) * np.sqrt(2.0 / edf)
        if np.allclose(sd_new, sd, rtol=1e-6):
            break
        sd = sd_new
    w = 1.0 / sd
    resid = (var - a @ p) * w
    dof = max(1, taus.size - int((p > 0).sum()))
    return p, w, float(np.sum(resid * resid)) / dof


def identify_noise(
    result: DeviationResult, *, instrument: str | None = "gyro", n_boot: int = 30,
    rng: np.random.Generator | int | None = 0,
) -> NoiseModel:
    """Fit the five IEEE 952 terms to an (overlapping) Allan deviation.

    Parameters
    ----------
    result : DeviationResult
        Allan deviation (``oadev`` preferred, or ``adev``) of a rate record in SI units
        (rad/s for gyros, m/s^2 for accelerometers).
    instrument : {"gyro", "accelerometer", None}
        Chooses the engineering units; None: dimensionless input (fractional frequency),
        terms in s, sqrt(s), 1, 1/sqrt(s), 1/s.
    n_boot : int
        Simulated records for the uncertainty (parametric bootstrap of the whole chain:
        simulate the fitted model, compute its Allan deviation, refit; the std is the scatter
        of the refits). 0 uses the weighted least-squares covariance alone, which ignores the
        correlation of neighbouring taus.
    rng : numpy Generator, int or None
        Seed of the bootstrap (fixed by default so a report is reproducible).

    Returns
    -------
    NoiseModel

    Warns
    -----
    NoiseFitWarning
        When chi2/dof exceeds :data:`CHI2_LIMIT`: the model does not describe the record and
        no term is resolved (the message is also in ``NoiseModel.checks``).
    """
    if result.statistic not in ("oadev", "adev"):
        raise DataError(
            f"noise identification fits the Allan variance; got {result.statistic}, use oadev"
        )
    # About one point per octave: denser grids ("all") add correlated points, not information.
    keep = np.zeros(result.taus.size, dtype=bool)
    last = -np.inf
    for i, t in enumerate(result.taus):
        if result.n[i] >= 1 and t >= 1.9 * last:
            keep[i] = True
            last = t
    taus = result.taus[keep]
    var = result.var[keep]
    edf = np.maximum(result.edf[keep], 1.0)
    if taus.size < 2:
        raise DataError(
            "noise identification needs the Allan deviation at 2 or more taus; record longer"
        )
    a = basis(taus)
    dev = np.sqrt(var)
    # B is bounded by the flat floor: its deviation 0.664 B never exceeds any measured
    # deviation's upper (1-sigma) confidence limit, so one low point of few averages does not
    # pin it, and no point contradicts it.
    upper = np.full(5, np.inf)
    upper[2] = float(np.min(result.dev_hi[keep] ** 2)) / _B_FACTOR
    # Iteratively reweighted LS: weights from the model, not from the noisy points themselves.
    p, w, chi2 = _fit(taus, var, edf, upper)
    active = p > 0
    dof = max(1, taus.size - int(active.sum()))
    model_dev = np.sqrt(np.maximum(a @ p, 0.0))
    with np.errstate(divide="ignore"):
        ratio = np.where(model_dev > 0, model_dev / dev, np.inf)
    max_misfit = float(np.max(np.maximum(ratio, 1.0 / ratio)))
    fits = bool(chi2 <= CHI2_LIMIT)
    checks: list[str] = []
    if fits:
        verdict = (f"the five-term model fits: chi2/dof = {chi2:.3g} with {dof} dof "
                   f"(limit {CHI2_LIMIT:g}); largest model/measured deviation ratio "
                   f"{max_misfit:.3g}")
    else:
        k = int(np.argmax(np.maximum(ratio, 1.0 / ratio)))
        verdict = (f"the five-term model does not fit: chi2/dof = {chi2:.3g} with {dof} dof "
                   f"(limit {CHI2_LIMIT:g}); it misses the Allan deviation by {max_misfit:.3g}x "
                   f"at tau = {taus[k]:.4g} s; no term is reported as resolved (look for "
                   "dither, vibration, motion or a trend in the record)")
        checks.append(verdict)
        warnings.warn(verdict, NoiseFitWarning, stacklevel=2)
    aw = a * w[:, None]
    cov = np.zeros((5, 5))
    if active.any():
        sub = aw[:, active]
        c = np.linalg.pinv(sub.T @ sub)
        idx = np.flatnonzero(active)
        cov[np.ix_(idx, idx)] = c
    if n_boot >= 2 and active.any() and result.n_samples >= 64:
        g = np.random.default_rng(rng)
        sb = _bootstrap_std(p, taus, result.rate_hz, result.n_samples, n_boot, g)
        d = np.sqrt(np.diag(cov))
        scale = np.where(d > 0, sb / np.where(d > 0, d, 1.0), 0.0)
        cov = cov * np.outer(scale, scale)
    # Largest value each term could have alone under every point's upper confidence limit
    # (two-sided 95 %: chi-squared lower quantile of the edf).
    var_hi = var * edf / _chi2.ppf(0.025, edf)
    ub_sq = np.min(var_hi[:, None] / a, axis=0)
    ub_sq[2] = min(ub_sq[2], upper[2])  # never above the flat floor
    contrib = a * p[None, :]
    dominant = np.zeros(5, dtype=bool)
    if active.any():
        dominant[np.unique(np.argmax(contrib, axis=1))] = True
    kind = instrument if instrument in _ENG else None
    terms: dict[str, NoiseTerm] = {}
    for i, name in enumerate(TERMS):
        std_sq = math.sqrt(max(cov[i, i], 0.0))
        significant = p[i] > 0 and p[i] > SIGNIFICANCE * std_sq
        resolved = bool(fits and significant and dominant[i])
        unit_si = _SI[kind][name]
        unit, f = _ENG[kind][name] if kind else (unit_si, 1.0)
        ub = math.sqrt(max(ub_sq[i], p[i]))
        if resolved:
            val = math.sqrt(p[i])
            std = std_sq / (2.0 * val)  # delta method: d sqrt(p) = dp / (2 sqrt(p))
            note = "resolved"
            terms[name] = NoiseTerm(name, TERM_NAMES[name], True, val, std, ub, unit_si,
                                    val * f, std * f, ub * f, unit, note)
        else:
            if not fits:
                note = "not resolved: the five-term model does not fit this record"
            elif p[i] <= 0:
                note = "not resolved: the fit puts it at zero; only an upper bound is known"
            elif not dominant[i]:
                note = "not resolved: never the largest term on the tau range"
            else:
                note = f"not resolved: less than {SIGNIFICANCE:g} sigma above zero"
            terms[name] = NoiseTerm(name, TERM_NAMES[name], False, None, None, ub, unit_si,
                                    None, None, ub * f, unit, note)
    if p[2] > 0 and p[2] >= upper[2] * (1.0 - 1e-9):
        checks.append("bias instability B sits at its bound: 0.664 B equals the smallest "
                      "upper confidence limit of the measured deviations")
    return NoiseModel(terms=terms, coefficients_sq=p, covariance_sq=cov, taus=taus,
                      instrument=kind, chi2_per_dof=chi2, dof=dof, fits=fits, verdict=verdict,
                      max_misfit=max_misfit, checks=tuple(checks))
