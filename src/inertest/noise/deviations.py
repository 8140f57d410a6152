"""Allan-family deviations with the conventions of NIST SP 1065 (Riley 2008).

Conventions
-----------
* Rate input: ``N`` samples ``y`` (e.g. rad/s, or fractional frequency) at ``rate`` Hz become the
  ``N + 1`` phase (angle) points ``x_0 = 0, x_k = tau0 * sum_{i<k} y_i`` (SP 1065 eq. 4 with a
  leading zero). Angle input is used as the phase directly. The deviation has the unit of the
  rate (angle input: angle unit per second).
* ``tau = m tau0``; the number of terms ``n`` per tau is that of SP 1065 for ``N_x`` phase points:
  ADEV ``floor((N_x - 1)/m) - 1``, OADEV ``N_x - 2m``, MDEV/TDEV ``N_x - 3m + 1``,
  HDEV ``floor((N_x - 1)/m) - 2``, OHDEV ``N_x - 3m``, TOTDEV ``N_x - 2`` (reflected phase).
* A constant rate (a straight line of phase) is removed before the sums. Every statistic here is
  exactly invariant to it; removing it keeps the running sums small, so they do not lose digits.

Records larger than memory: pass a read-only ``np.memmap``, any 1-D array-like that supports
``len()`` and slicing (such as :class:`inertest.io.raw_samples.SampleFile`), or an array larger
than :data:`STREAM_THRESHOLD`; the phase is then rebuilt chunk by chunk from checkpoints of the
running sum and never held whole, with the same result as in memory.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import DataError, InputError
from inertest.noise.confidence import (
    MIN_ACF_AVERAGES,
    ONE_SIGMA,
    Lag1,
    alpha_from_lag1,
    b1_alpha,
    chi2_interval,
    edf_greenhall,
    edf_totdev,
)

#: Statistics known, in the order reports list them.
STATISTICS = ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")
_NAMES = {
    "adev": "Allan deviation",
    "oadev": "overlapping Allan deviation",
    "mdev": "modified Allan deviation",
    "tdev": "time deviation",
    "hdev": "Hadamard deviation",
    "ohdev": "overlapping Hadamard deviation",
    "totdev": "total deviation",
}
DATA_TYPES = ("rate", "angle")
TAU_GRIDS = ("octave", "decade", "all")

#: Arrays with more samples than this (or memory maps) are processed in chunks.
STREAM_THRESHOLD = 1 << 25
#: Samples per chunk when streaming.
CHUNK = 1 << 20

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class DeviationResult:
    """One Allan-family statistic on a tau grid, with confidence intervals.

    Attributes
    ----------
    statistic : str
        ``"oadev"``, ``"mdev"``, ... (see :data:`STATISTICS`).
    taus : ndarray
        Averaging times [s].
    dev : ndarray
        Deviation [rate unit; TDEV: rate unit x s].
    n : ndarray of int
        Number of terms averaged at each tau (SP 1065 conventions).
    edf : ndarray
        Equivalent degrees of freedom of each variance.
    alpha : ndarray of int
        Power-law noise type used for the EDF (``S_y ~ f**alpha``), identified at each tau
        on the whole record (lag-1 autocorrelation, or B1 and R(n) below 30 averages).
    dev_lo, dev_hi : ndarray
        Chi-squared confidence interval of ``dev`` at level ``confidence``.
    confidence : float
        Two-sided confidence level of the interval (default 0.683, 1 sigma).
    """

    statistic: str
    taus: NDArray
    dev: NDArray
    n: NDArray
    edf: NDArray
    alpha: NDArray
    dev_lo: NDArray
    dev_hi: NDArray
    confidence: float = ONE_SIGMA
    rate_hz: float = 1.0
    data_type: str = "rate"
    name: str = field(default="")
    n_samples: int = 0

    @property
    def var(self) -> NDArray:
        """Variance ``dev**2``."""
        return self.dev**2

    def to_dict(self) -> dict[str, object]:
        """Plain lists for JSON."""
        return {
            "statistic": self.statistic,
            "tau": self.taus.tolist(),
            "dev": self.dev.tolist(),
            "n": self.n.tolist(),
            "edf": self.edf.tolist(),
            "alpha": self.alpha.tolist(),
            "dev_lo": self.dev_lo.tolist(),
            "dev_hi": self.dev_hi.tolist(),
            "confidence": self.confidence,
        }


# --------------------------------------------------------------------------- phase sources


class _Phase:
    """Phase points ``x[0:size]`` readable by slices (views in memory, rebuilt when streaming)."""

    size: int
    tau0: float

    def read(self, start: int, stop: int) -> NDArray:  # pragma: no cover - interface
        raise NotImplementedError

    def read_reflected(self, start: int, stop: int) -> NDArray:
        """``x*`` of SP 1065 eq. 25: the phase reflected about both end points."""
        nx = self.size
        parts = []
        hi = min(stop, 0)
        if hi > start:
            x0 = self.read(0, 1)[0]
            parts.append(2.0 * x0 - self.read(1 - hi, 1 - start)[::-1])
        a, b = max(start, 0), min(stop, nx)
        if b > a:
            parts.append(self.read(a, b))
        lo = max(start, nx)
        if stop > lo:
            xl = self.read(nx - 1, nx)[0]
            parts.append(2.0 * xl - self.read(2 * nx - 1 - stop, 2 * nx - 1 - lo)[::-1])
        return parts[0] if len(parts) == 1 else np.concatenate(parts)


class _MemoryPhase(_Phase):
    def __init__(self, x: NDArray, tau0: float) -> None:
        self.x = x
        self.size = x.size
        self.tau0 = tau0
        self.chunk = max(1, x.size)

    def read(self, start: int, stop: int) -> NDArray:
        return self.x[start:stop]


def _block_mean(y: ArrayLike, progress: Progress | None = None, total: int = 0) -> float:
    """Mean of a long array, summed in fixed blocks (same digits in memory and streaming)."""
    a = y
    n = len(a)  # type: ignore[arg-type]
    s = 0.0
    for i in range(0, n, CHUNK):
        blk = np.asarray(a[i : i + CHUNK], dtype=np.float64)  # type: ignore[index]
        bs = float(np.sum(blk))
        if not math.isfinite(bs):
            bad = i + int(np.flatnonzero(~np.isfinite(blk))[0])
            raise DataError(
                f"the data contain NaN or infinite values (first at sample {bad}); remove or "
                "interpolate them, or analyse the clean stretches separately"
            )
        s += bs
        if progress is not None:
            progress(min(n, i + CHUNK), total)
    return s / n


class _RatePhase(_Phase):
    """Phase of a (possibly memory-mapped) rate record, rebuilt per read from checkpoints."""

    def __init__(self, y: ArrayLike, tau0: float, mean: float) -> None:
        self.y = y
        self.n = len(y)  # type: ignore[arg-type]
        self.size = self.n + 1
        self.tau0 = tau0
        self.mean = mean
        self.chunk = CHUNK
        # cum[k] = sum_{i<k} (y_i - mean), sequentially accumulated: checkpoints every CHUNK.
        ck = [0.0]
        c = 0.0
        buf = np.empty(CHUNK + 1)
        from inertest.noise import kernels  # numba: loaded on first use
        for i in range(0, self.n, CHUNK):
            blk = np.ascontiguousarray(y[i : i + CHUNK], dtype=np.float64)  # type: ignore[index]
            c = kernels.integrate(blk, mean, c, tau0, buf[: blk.size + 1])
            ck.append(c)
        self.checkpoints = np.asarray(ck)

    def read(self, start: int, stop: int) -> NDArray:
        start = max(0, start)
        stop = min(self.size, stop)
        if stop <= start:
            return np.empty(0)
        k = start // CHUNK
        base = k * CHUNK
        blk = np.ascontiguousarray(self.y[base : stop - 1], dtype=np.float64)  # type: ignore[index]
        out = np.empty(blk.size + 1)
        from inertest.noise import kernels

        kernels.integrate(blk, self.mean, float(self.checkpoints[k]), self.tau0, out)
        return out[start - base : stop - base]


class _AnglePhase(_Phase):
    """Phase given directly (angle input), minus the straight line through its end points."""

    def __init__(self, x: ArrayLike, tau0: float) -> None:
        self.xr = x
        self.size = len(x)  # type: ignore[arg-type]
        self.tau0 = tau0
        self.chunk = CHUNK
        self.first = float(x[0])  # type: ignore[index]
        last = float(x[self.size - 1])  # type: ignore[index]
        self.slope = (last - self.first) / (self.size - 1) if self.size > 1 else 0.0

    def read(self, start: int, stop: int) -> NDArray:
        start = max(0, start)
        stop = min(self.size, stop)
        raw = np.asarray(self.xr[start:stop], dtype=np.float64)  # type: ignore[index]
        return raw - (self.first + self.slope * np.arange(start, stop, dtype=np.float64))


def _check_finite_angle(x: ArrayLike) -> None:
    n = len(x)  # type: ignore[arg-type]
    for i in range(0, n, CHUNK):
        blk = np.asarray(x[i : i + CHUNK], dtype=np.float64)  # type: ignore[index]
        if not np.all(np.isfinite(blk)):
            bad = i + int(np.flatnonzero(~np.isfinite(blk))[0])
            raise DataError(
                f"the data contain NaN or infinite values (first at sample {bad}); remove or "
                "interpolate them, or analyse the clean stretches separately"
            )


def phase_source(
    data: ArrayLike, rate: float, data_type: str = "rate", *, stream: bool | None = None
) -> _Phase:
    """Validate the input and build the phase points (SP 1065: N rates -> N + 1 phases)."""
    if data_type not in DATA_TYPES:
        raise InputError(f"data_type {data_type!r} is not known; use 'rate' or 'angle'")
    try:
        rate_f = float(rate)
    except (TypeError, ValueError):
        raise InputError(f"rate must be a number of samples per second, got {rate!r}") from None
    if not (math.isfinite(rate_f) and rate_f > 0):
        raise InputError(
            f"rate must be a positive sampling rate in Hz, got {rate!r}; give the sample rate "
            "of the record (e.g. --rate 100)"
        )
    tau0 = 1.0 / rate_f
    if not hasattr(data, "shape") or not hasattr(data, "__getitem__"):
        data = np.asarray(data, dtype=np.float64)  # lists, tuples: in memory
    if isinstance(data, np.ndarray) and data.ndim != 1:
        data = np.asarray(data, dtype=np.float64).ravel() if 1 in data.shape else data
        if data.ndim != 1:
            raise InputError(f"data must be one column of samples, got shape {data.shape}")
    n = len(data)  # type: ignore[arg-type]
    if n < 3:
        raise DataError(
            f"the record has {n} samples; Allan-family statistics need at least 3 (more than "
            "100 for a useful tau range): record longer"
        )
    if stream is None:
        # Memory maps and file-backed array-likes stream; so do very long arrays.
        stream = isinstance(data, np.memmap) or not isinstance(data, np.ndarray) or (
            n > STREAM_THRESHOLD)
    if data_type == "rate":
        from inertest.noise import kernels  # numba: loaded on first use

        mean = _block_mean(data)
        if stream:
            return _RatePhase(data, tau0, mean)
        x = np.empty(n + 1)
        kernels.integrate(np.ascontiguousarray(data, dtype=np.float64), mean, 0.0, tau0, x)
        return _MemoryPhase(x, tau0)
    _check_finite_angle(data)
    src = _AnglePhase(data, tau0)
    if stream:
        return src
    return _MemoryPhase(src.read(0, src.size), tau0)


# --------------------------------------------------------------------------- tau grids


def max_m(statistic: str, nx: int) -> int:
    """Largest averaging factor with at least one term (TOTDEV: half the record)."""
    if statistic in ("adev", "oadev", "totdev"):
        return (nx - 1) // 2
    if statistic in ("mdev", "tdev"):
        return nx // 3
    return (nx - 1) // 3


def averaging_factors(taus: str | Sequence[float] | ArrayLike, rate: float, statistic: str,
                      nx: int) -> NDArray:
    """Averaging factors ``m`` (tau = m / rate) of a named grid or of taus in seconds."""
    mmax = max_m(statistic, nx)
    if mmax < 1:
        raise DataError(
            f"the record ({nx - 1} samples) is too short for {statistic}; it needs at least "
            f"{4 if statistic in ('hdev', 'ohdev') else 3} samples"
        )
    if isinstance(taus, str):
        if taus == "octave":
            return 2 ** np.arange(int(math.floor(math.log2(mmax))) + 1)
        if taus == "decade":
            ms = []
            dec = 1
            while dec <= mmax:
                ms += [v for v in (dec, 2 * dec, 4 * dec) if v <= mmax]
                dec *= 10
            return np.asarray(ms, dtype=np.int64)
        if taus == "all":
            return np.arange(1, mmax + 1)
        raise InputError(
            f"taus {taus!r} is not known; use 'octave', 'decade', 'all' or a list of seconds"
        )
    t = np.atleast_1d(np.asarray(taus, dtype=float))
    if t.size == 0 or not np.all(np.isfinite(t)) or np.any(t <= 0):
        raise InputError(f"taus must be positive numbers of seconds, got {t.tolist()}")
    m = np.rint(t * rate)
    bad = np.abs(m - t * rate) > 1e-6 * np.maximum(m, 1.0)
    if np.any(bad | (m < 1)):
        tb = t[bad | (m < 1)][0]
        raise InputError(
            f"tau {tb:g} s is not a multiple of the sample interval {1.0 / rate:g} s; "
            "give taus that are whole multiples of 1/rate"
        )
    if np.any(m > mmax):
        raise InputError(
            f"tau {t[m > mmax][0]:g} s is too long for {statistic} on this record; the longest "
            f"is {mmax / rate:g} s"
        )
    return np.unique(m.astype(np.int64))


# --------------------------------------------------------------------------- sums


def _terms(statistic: str, m: int, nx: int) -> int:
    if statistic == "adev":
        return (nx - 1) // m - 1
    if statistic == "oadev":
        return nx - 2 * m
    if statistic in ("mdev", "tdev"):
        return nx - 3 * m + 1
    if statistic == "hdev":
        return (nx - 1) // m - 2
    if statistic == "ohdev":
        return nx - 3 * m
    return nx - 2  # totdev


def _sum_squares(src: _Phase, statistic: str, m: int, n: int, tick: Callable[[int], None]) -> float:
    """Sum of the squared differences of one statistic at one tau, chunk by chunk."""
    from inertest.noise import kernels  # numba: loaded on first use

    c = src.chunk if isinstance(src, _MemoryPhase) else CHUNK
    total = 0.0
    if statistic in ("oadev", "ohdev"):
        for j0 in range(0, n, c):
            j1 = min(n, j0 + c)
            w = [src.read(j0 + k * m, j1 + k * m) for k in range(4 if statistic == "ohdev" else 3)]
            if statistic == "oadev":
                total += kernels.sum_second_diff(w[0], w[1], w[2], 1)
            else:
                total += kernels.sum_third_diff(w[0], w[1], w[2], w[3], 1)
            tick(j1 - j0)
    elif statistic in ("adev", "hdev"):
        per = max(1, c // m)  # terms per chunk
        for t0 in range(0, n, per):
            t1 = min(n, t0 + per)
            a, b = t0 * m, (t1 - 1) * m + 1
            w = [src.read(a + k * m, b + k * m) for k in range(3 if statistic == "adev" else 4)]
            if statistic == "adev":
                total += kernels.sum_second_diff(w[0], w[1], w[2], m)
            else:
                total += kernels.sum_third_diff(w[0], w[1], w[2], w[3], m)
            tick((t1 - t0) * m)
    elif statistic in ("mdev", "tdev"):
        s = 0.0
        for i0 in range(0, m, c):
            i1 = min(m, i0 + c)
            s += kernels.second_diff_sum(src.read(i0, i1), src.read(i0 + m, i1 + m),
                                         src.read(i0 + 2 * m, i1 + 2 * m))
        for j0 in range(0, n, c):
            j1 = min(n, j0 + c)
            u1 = min(j1, n - 1)  # the window after the last term is not needed
            w = [src.read(j0 + k * m, u1 + k * m) for k in range(4)]
            acc, s = kernels.sum_modified(w[0], w[1], w[2], w[3], s, j1 - j0)
            total += acc
            tick(j1 - j0)
    else:  # totdev, i = 1 .. nx-2 with the reflected phase
        last = src.size - 1
        for j0 in range(1, last, c):
            j1 = min(last, j0 + c)
            w0 = src.read_reflected(j0 - m, j1 - m)
            w1 = src.read(j0, j1)
            w2 = src.read_reflected(j0 + m, j1 + m)
            total += kernels.sum_second_diff(w0, w1, w2, 1)
            tick(j1 - j0)
    return total


def _variance(statistic: str, ssq: float, m: int, n: int, tau0: float) -> float:
    tau = m * tau0
    if statistic in ("adev", "oadev", "totdev"):
        return ssq / (2.0 * n * tau * tau)
    if statistic in ("mdev", "tdev"):
        return ssq / (2.0 * m * m * n * tau * tau)
    return ssq / (6.0 * n * tau * tau)


def _decimated(src: _Phase, m: int, count: int):  # noqa: ANN202 - generator of blocks
    """Blocks of the decimated phase ``x[0], x[m], ..., x[count m]`` (bounded memory)."""
    npts = count + 1
    if isinstance(src, _MemoryPhase):
        for a in range(0, npts, CHUNK):
            b = min(npts, a + CHUNK)
            yield src.x[a * m : (b - 1) * m + 1 : m]
        return
    per = max(1, CHUNK // m)  # decimated points per read
    for a in range(0, npts, per):
        b = min(npts, a + per)
        yield src.read(a * m, (b - 1) * m + 1)[::m].copy()  # do not keep the chunk alive


def _family(statistic: str) -> str:
    return "hadamard" if statistic in ("hdev", "ohdev") else "allan"


def _noise_type(src: _Phase, m: int, family: str) -> int | None:
    """Noise type alpha at tau = m tau0 from the whole record (SP 1065 5.6).

    At least :data:`MIN_ACF_AVERAGES` averages: lag-1 autocorrelation of the decimated phase
    and its differences (Riley & Greenhall 2004; dmax 2 for the Allan family, 3 for Hadamard).
    Fewer: B1 ratio of the frequency averages, with R(n) = MVAR/AVAR between white and flicker
    phase noise (Stable32's method for short series). None when fewer than 3 averages.
    """
    count = (src.size - 1) // m
    dmax, alpha_min = (3, -4) if family == "hadamard" else (2, -2)
    if count >= MIN_ACF_AVERAGES:
        accs = [Lag1() for _ in range(dmax + 1)]
        carry: list[float | None] = [None] * dmax
        for blk in _decimated(src, m, count):
            z = np.asarray(blk, dtype=np.float64)
            for k in range(dmax + 1):
                accs[k].add(z)
                if k == dmax or z.size == 0:
                    break
                prev = carry[k]
                carry[k] = float(z[-1])
                z = np.diff(z) if prev is None else np.diff(np.concatenate(([prev], z)))
        return alpha_from_lag1([a.r1() for a in accs], phase=True, alpha_min=alpha_min)
    xs = np.concatenate(list(_decimated(src, m, count)))
    ybar = np.diff(xs)
    alpha = b1_alpha(ybar, alpha_min=alpha_min)
    if alpha == 1:  # phase noise: R(n) tells white from flicker
        mm = min(m, src.size // 3)
        tick = _no_tick
        n_mod, n_oa = _terms("mdev", mm, src.size), _terms("oadev", mm, src.size)
        mvar = _variance("mdev", _sum_squares(src, "mdev", mm, n_mod, tick), mm, n_mod, 1.0)
        avar = _variance("oadev", _sum_squares(src, "oadev", mm, n_oa, tick), mm, n_oa, 1.0)
        if avar > 0:
            alpha = b1_alpha(ybar, alpha_min=alpha_min, rn=mvar / avar, m=mm)
    return alpha


def _no_tick(k: int) -> None:
    return None


def _edf(statistic: str, alpha: int, m: int, n: int, nx: int) -> float:
    if statistic == "totdev":
        return edf_totdev(alpha, m, nx)
    d = 3 if statistic in ("hdev", "ohdev") else 2
    return edf_greenhall(alpha, d, m, n, modified=statistic in ("mdev", "tdev"),
                         overlapping=statistic not in ("adev", "hdev"))


def _alpha_and_edf(statistic: str, alpha: int | None, m: int, n: int,
                   nx: int) -> tuple[int, float]:
    """Noise type and EDF at one tau.

    When the type cannot be identified (fewer than 3 averages) the type of smallest EDF is
    used, so the interval is the widest any noise type would give.
    """
    if alpha is not None:
        return alpha, _edf(statistic, alpha, m, n, nx)
    lo = -4 if _family(statistic) == "hadamard" else -2
    cands = [(_edf(statistic, a, m, n, nx), a) for a in range(lo, 3)]
    e, a = min(cands)
    return a, e


def deviations(
    data: ArrayLike,
    rate: float,
    stats: Sequence[str] = ("oadev",),
    taus: str | Sequence[float] | ArrayLike = "octave",
    data_type: str = "rate",
    *,
    confidence: float = ONE_SIGMA,
    progress: Progress | None = None,
    stream: bool | None = None,
) -> dict[str, DeviationResult]:
    """Several Allan-family statistics of one record (the phase is built once).

    Parameters
    ----------
    data : array_like, shape (N,)
        Rate samples (``data_type="rate"``, e.g. rad/s) or angle samples (``"angle"``, e.g. rad).
        A read-only ``np.memmap`` is processed in chunks in bounded memory.
    rate : float
        Sample rate [Hz]; tau0 = 1/rate.
    stats : sequence of str
        Names from :data:`STATISTICS`.
    taus : {"octave", "decade", "all"} or sequence of float
        Tau grid, or taus in seconds (whole multiples of 1/rate).
    confidence : float
        Two-sided level of the chi-squared intervals.
    progress : callable, optional
        Called as ``progress(done, total)`` with work units (samples processed).
    stream : bool, optional
        Force the chunked path (default: for memory maps and records over 2**25 samples).
    """
    unknown = [s for s in stats if s not in STATISTICS]
    if unknown or not stats:
        raise InputError(
            f"unknown statistic {unknown[0] if unknown else ''!r}; choose from "
            f"{', '.join(STATISTICS)}"
        )
    if not (0.0 < confidence < 1.0):
        raise InputError(f"confidence must be between 0 and 1, got {confidence}")
    src = phase_source(data, rate, data_type, stream=stream)
    nx = src.size
    grids = {s: averaging_factors(taus, 1.0 / src.tau0, s, nx) for s in stats}
    work = sum(
        (nx if s == "totdev" else _terms(s, int(m), nx) * (int(m) if s in ("adev", "hdev") else 1))
        for s in stats for m in grids[s]
    )
    done = [0]

    def tick(k: int) -> None:
        done[0] += k
        if progress is not None:
            progress(min(done[0], work), work)

    alpha_cache: dict[tuple[int, str], int | None] = {}
    out: dict[str, DeviationResult] = {}
    for s in stats:
        ms = grids[s]
        var = np.empty(ms.size)
        ns = np.empty(ms.size, dtype=np.int64)
        edf = np.empty(ms.size)
        alph = np.empty(ms.size, dtype=np.int64)
        for i, m in enumerate(int(v) for v in ms):
            n = _terms(s, m, nx)
            var[i] = _variance(s, _sum_squares(src, s, m, n, tick), m, n, src.tau0)
            ns[i] = n
            key = (m, _family(s))
            if key not in alpha_cache:
                alpha_cache[key] = _noise_type(src, m, key[1])
            alph[i], edf[i] = _alpha_and_edf(s, alpha_cache[key], m, n, nx)
        lo, hi = chi2_interval(var, edf, confidence)
        t = ms * src.tau0
        dev, dlo, dhi = np.sqrt(var), np.sqrt(lo), np.sqrt(hi)
        if s == "tdev":
            f = t / math.sqrt(3.0)
            dev, dlo, dhi = dev * f, dlo * f, dhi * f
        out[s] = DeviationResult(
            statistic=s, taus=t, dev=dev, n=ns, edf=edf, alpha=alph, dev_lo=dlo, dev_hi=dhi,
            confidence=confidence, rate_hz=1.0 / src.tau0, data_type=data_type, name=_NAMES[s],
            n_samples=nx - 1,
        )
    return out


def _one(statistic: str):  # noqa: ANN202 - builds the public functions below
    def f(
        data: ArrayLike,
        rate: float,
        taus: str | Sequence[float] | ArrayLike = "octave",
        data_type: str = "rate",
        *,
        confidence: float = ONE_SIGMA,
        progress: Progress | None = None,
        stream: bool | None = None,
    ) -> DeviationResult:
        return deviations(data, rate, (statistic,), taus, data_type, confidence=confidence,
                          progress=progress, stream=stream)[statistic]

    f.__name__ = statistic
    f.__qualname__ = statistic
    f.__doc__ = (
        f"{_NAMES[statistic].capitalize()} (NIST SP 1065) of rate or angle samples.\n\n"
        "Parameters and result as :func:`deviations` for one statistic: returns a\n"
        ":class:`DeviationResult` with ``.taus`` [s], ``.dev``, ``.n``, ``.edf``, ``.dev_lo``,\n"
        "``.dev_hi``.\n"
    )
    return f


adev = _one("adev")
oadev = _one("oadev")
mdev = _one("mdev")
tdev = _one("tdev")
hdev = _one("hdev")
ohdev = _one("ohdev")
totdev = _one("totdev")
