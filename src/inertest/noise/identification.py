"""IEEE Std 952-1997 noise identification: five power-law terms fitted to the Allan variance.

Model (IEEE Std 952-1997 Annex C, Table C.2)::

    sigma^2(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2

Q quantization [rate unit x s], N angle/velocity random walk [rate unit x sqrt(s)], B bias
instability [rate unit], K rate random walk [rate unit / sqrt(s)], R rate ramp [rate unit / s].
The coefficients' squares are fitted by non-negative least squares to the overlapping Allan
variances, each weighted by its chi-squared standard deviation ``model(tau) sqrt(2/edf)``
(iterated so the weights do not favour points that happen to fall low). A term is *resolved*
only when it is more than :data:`SIGNIFICANCE` standard deviations above zero and is the largest
term somewhere on the tau range; otherwise only an upper bound is reported: the largest value
the term could have without exceeding the upper confidence limit of any measured point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls
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
_B_FACTOR = 2.0 * math.log(2.0) / math.pi

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
    None: {"Q": "u*s", "N": "u*sqrt(s)", "B": "u", "K": "u/sqrt(s)", "R": "u/s"},
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


def _fit(taus: NDArray, var: NDArray, edf: NDArray) -> tuple[NDArray, NDArray, float]:
    """Iteratively reweighted NNLS of the squares; returns (p, weights, chi2 per dof)."""
    a = basis(taus)
    sd = var * np.sqrt(2.0 / edf)
    p = np.zeros(5)
    for _ in range(6):
        w = 1.0 / np.where(sd > 0, sd, np.max(sd) if np.max(sd) > 0 else 1.0)
        p, _ = nnls(a * w[:, None], var * w)
        model = a @ p
        sd_new = np.where(model > 0, model, var) * np.sqrt(2.0 / edf)
        if np.allclose(sd_new, sd, rtol=1e-6):
            break
        sd = sd_new
    w = 1.0 / sd
    resid = (var - a @ p) * w
    dof = max(1, taus.size - int((p > 0).sum()))
    return p, w, float(resid @ resid) / dof


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
        Chooses the engineering units; None reports SI-like units of the input ("u").
    n_boot : int
        Simulated records for the uncertainty (parametric bootstrap of the whole chain:
        simulate the fitted model, compute its Allan deviation, refit). 0 uses the weighted
        least-squares covariance alone, which ignores the correlation of neighbouring taus.
    rng : numpy Generator, int or None
        Seed of the bootstrap (fixed by default so a report is reproducible).

    Returns
    -------
    NoiseModel
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
    # Iteratively reweighted NNLS: weights from the model, not from the noisy points themselves.
    p, w, chi2 = _fit(taus, var, edf)
    aw = a * w[:, None]
    active = p > 0
    cov = np.zeros((5, 5))
    if active.any():
        sub = aw[:, active]
        c = np.linalg.pinv(sub.T @ sub)
        idx = np.flatnonzero(active)
        cov[np.ix_(idx, idx)] = c
    if n_boot >= 2 and active.any() and result.n_samples >= 64:
        g = np.random.default_rng(rng)
        sb = _bootstrap_std(p, taus, result.rate_hz, result.n_samples, n_boot, g)
        # Keep the larger of the two: the bootstrap sees the correlations, the covariance
        # cannot be beaten by a lucky simulation.
        d = np.sqrt(np.diag(cov))
        scale = np.where(d > 0, np.sqrt(np.maximum(d**2, sb**2)) / np.where(d > 0, d, 1.0), 0.0)
        cov = cov * np.outer(scale, scale)
    # Largest value each term could have alone under every point's upper confidence limit
    # (two-sided 95 %: chi-squared lower quantile of the edf).
    var_hi = var * edf / _chi2.ppf(0.025, edf)
    ub_sq = np.min(var_hi[:, None] / a, axis=0)
    contrib = a * p[None, :]
    dominant = np.zeros(5, dtype=bool)
    if active.any():
        dominant[np.unique(np.argmax(contrib, axis=1))] = True
    kind = instrument if instrument in _ENG else None
    terms: dict[str, NoiseTerm] = {}
    for i, name in enumerate(TERMS):
        std_sq = math.sqrt(max(cov[i, i], 0.0))
        significant = p[i] > 0 and p[i] > SIGNIFICANCE * std_sq
        resolved = bool(significant and dominant[i])
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
            if p[i] <= 0:
                note = "not resolved: the fit puts it at zero; only an upper bound is known"
            elif not dominant[i]:
                note = "not resolved: never the largest term on the tau range"
            else:
                note = f"not resolved: less than {SIGNIFICANCE:g} sigma above zero"
            terms[name] = NoiseTerm(name, TERM_NAMES[name], False, None, None, ub, unit_si,
                                    None, None, ub * f, unit, note)
    return NoiseModel(terms=terms, coefficients_sq=p, covariance_sq=cov, taus=taus,
                      instrument=kind, chi2_per_dof=chi2)
