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
  It is the mean rate, except for rate records in memory from 65,536 samples on, where it is
  estimated from every 32nd sample (no pass of its own; the results agree to rounding).

Records larger than memory: pass a read-only ``np.memmap`` or any 1-D array-like that supports
``len()`` and slicing (such as :class:`inertest.io.raw_samples.SampleFile`); the phase is then
built chunk by chunk and never held whole, with the same result as in memory (to rounding).
Every tau of every statistic but TOTDEV, and the noise-type sums, come from one pass that reads
and integrates each chunk once; memory is bounded by ``(2 + L)`` chunks of float64 phase,
``L`` the number of distinct lags longer than a chunk (at most ``_MAX_CURSORS`` per pass; on the
octave grid ``L <= 3 log2(N / CHUNK)``): about 90 MB of buffers for octave OADEV at 2e8
samples, 150 MB for every statistic. TOTDEV reads its windows per tau. An ``np.ndarray`` stays
in memory at any size (its phase costs 8 bytes per sample more) unless ``stream=True``.
"""

from __future__ import annotations

import math
import mmap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import DataError, InputError
from inertest.noise.confidence import (
    _TOTDEV_BC,
    B1_MIN_AVERAGES,
    MIN_ACF_AVERAGES,
    ONE_SIGMA,
    RN_MIN_M,
    Lag1,
    alpha_from_lag1,
    b1_alpha,
    b1_decide,
    chi2_interval,
    edf_greenhall_many,
    r1_of_state,
    rn_decide,
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

#: Samples per chunk when streaming.
CHUNK = 1 << 20
#: In memory, taus are summed in groups of about this many samples (one progress tick each).
_GROUP_WORK = 1 << 24

#: In memory, samples from which the m = 1, 2 noise-type rows and x[::4] are taken while
#: integrating (below, the record stays in cache between the passes anyway).
_FUSE_ROWS = 1 << 16

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
        on the whole record (lag-1 autocorrelation checked by R(n); below 30 averages the
        type of the longest lag-1 tau unless R(n) or B1 shows a change). Below 3 averages
        nothing can be identified: the type of smallest EDF is used (the widest interval any
        type would give).
    alpha_rule : tuple of str
        The rule that decided ``alpha`` at each tau (keys of
        :data:`inertest.noise.confidence.NOISE_RULES`).
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
    alpha_rule: tuple[str, ...] = ()

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
            "alpha_rule": list(self.alpha_rule),
            "dev_lo": self.dev_lo.tolist(),
            "dev_hi": self.dev_hi.tolist(),
            "confidence": self.confidence,
        }


# --------------------------------------------------------------------------- phase sources


@runtime_checkable
class _Record(Protocol):
    """A 1-D record read by index and by slice: an array, a memory map, a ``SampleFile``."""

    def __len__(self) -> int: ...

    def __getitem__(self, key: int | slice, /) -> Any: ...


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
    def __init__(self, x: NDArray, tau0: float, owned: Sequence[NDArray] = ()) -> None:
        self.x = x
        self.size = x.size
        self.tau0 = tau0
        self.chunk = max(1, x.size)
        # Taken while the phase was built (phase_source(fuse=...)): noise-type rows 0-1 by m,
        # Hadamard sums by m, and x[::4] (scratch the HDEV sums may overwrite).
        self.rows: dict[int, NDArray] = {}
        self.hdev: dict[int, float] = {}
        self.quarter: NDArray | None = None
        # Work arrays of _work_array (phase, x[::4]) that deviations() hands back when done.
        self.owned = list(owned)

    def read(self, start: int, stop: int) -> NDArray:
        return self.x[start:stop]


#: Bytes of a transparent huge page (Linux, x86-64 and arm64 with 4 KiB base pages).
_HUGE_PAGE = 1 << 21


#: Work arrays handed back by :func:`deviations` (by length), at most this many bytes in all.
_SPARE_BYTES = 32 << 20
_spare: dict[int, NDArray] = {}


def _release_work(arrays: Sequence[NDArray]) -> None:
    """Keep finished work arrays for the next record of the same length.

    Records of one length come in series (the channels of one recording, repeated analyses),
    and a reused array has no page faults to take: HDEV at 1e6 samples 0.3 ms (10 %) faster.
    Up to :data:`_SPARE_BYTES` are kept (the phase of 4e6 samples); larger ones are released.
    """
    for a in arrays:
        if 8 * a.size < _HUGE_PAGE // 2:
            continue
        held = 8 * sum(v.size for v in _spare.values())
        if held + 8 * a.size <= _SPARE_BYTES:
            _spare[a.size] = a


def _work_array(n: int) -> NDArray:
    """An uninitialised float64 array of ``n`` elements for the phase and its decimations.

    A spare array of this length (:func:`_release_work`) is reused (``dict.pop`` is atomic:
    two threads never get the same one).

    Arrays of half a huge page or more are mapped anonymously, aligned to 2 MiB and advised
    for transparent huge pages: a fresh 8 MB phase then costs 4 page faults instead of about 900
    (about 1 us each on a virtual machine; 1.4 ms of the 5 ms of an HDEV at 1e6 samples).
    The mapping is released with the array. Where that is not available (other systems, huge
    pages off) this is ``np.empty``.
    """
    spare = _spare.pop(n, None)
    if spare is not None:
        return spare
    nbytes = 8 * n
    advise = getattr(mmap, "MADV_HUGEPAGE", None)
    flags = getattr(mmap, "MAP_PRIVATE", 0) | getattr(mmap, "MAP_ANONYMOUS", 0)
    if nbytes < _HUGE_PAGE // 2 or advise is None or not flags:
        return np.empty(n)
    try:
        mm = mmap.mmap(-1, nbytes + _HUGE_PAGE, flags=flags)
        mm.madvise(advise)
    except (OSError, ValueError):
        return np.empty(n)
    start = np.frombuffer(mm, dtype=np.uint8, count=1).ctypes.data
    return np.frombuffer(mm, dtype=np.float64, count=n, offset=(-start) % _HUGE_PAGE)


def _not_finite(blk: NDArray, offset: int) -> DataError:
    """The error for a record whose sum is not finite (``blk`` starts at sample ``offset``)."""
    bad = np.flatnonzero(~np.isfinite(blk))
    if bad.size == 0:
        return DataError(
            "the data are too large to sum (the running sum overflows a float64); give them "
            "in a smaller unit"
        )
    return DataError(
        f"the data contain NaN or infinite values (first at sample {offset + int(bad[0])}); "
        "remove or interpolate them, or analyse the clean stretches separately"
    )


def _block_mean(y: ArrayLike, progress: Progress | None = None, total: int = 0) -> float:
    """Mean of a long array, summed in fixed blocks (same digits in memory and streaming)."""
    a = y
    n = len(a)  # type: ignore[arg-type]
    s = 0.0
    for i in range(0, n, CHUNK):
        blk = np.asarray(a[i : i + CHUNK], dtype=np.float64)  # type: ignore[index]
        bs = float(np.sum(blk))
        if not math.isfinite(bs):
            raise _not_finite(blk, i)
        s += bs
        if progress is not None:
            progress(min(n, i + CHUNK), total)
    return s / n


#: In memory, the fused phase build integrates about the mean of every ``_LEVEL_STRIDE``-th
#: sample (see :func:`phase_source`).
_LEVEL_STRIDE = 32


def _level(y: NDArray) -> float:
    """The constant rate the fused phase build removes: an estimate of the mean of ``y``.

    Below :data:`_FUSE_ROWS` samples the exact mean (:func:`_block_mean`; the record is in
    cache). Above, the mean of every :data:`_LEVEL_STRIDE`-th sample: it reads one cache line
    in four where the exact mean reads the record (a tenth of the time of an HDEV at 1e6
    samples), and every statistic here is invariant to the constant left (a straight line of
    phase). The line makes the phase larger (about sqrt(32) times for white noise), and summed
    in one running sum it cost up to 45x in rounding (4e-11 at the longest taus of a float32
    record). :func:`kernels.integrate_fused` therefore restarts the running sum every tile
    (as every other phase build does, :func:`kernels.integrate`). Against an exact rational
    reference (review 20, records of 1e6 samples; in brackets the exact mean with one running
    sum, as the streamed path had it until issue 31): white, offset and float32 records within
    8e-13 (1.2e-11), a drifting rate 4e-10 (1.1e-8), a random-walk rate 9e-11 (2e-11): all far
    below the digits a deviation has.
    """
    if y.size < _FUSE_ROWS:
        return _block_mean(y)
    return float(np.mean(y[::_LEVEL_STRIDE]))


def _samples(y: ArrayLike, start: int, stop: int) -> NDArray:
    """Samples ``y[start:stop]`` as an array the kernels read as it is.

    Float32 or float64 in native byte order and contiguous (no float64 copy of a float32
    block); anything else is converted to float64.
    """
    blk = np.asarray(y[start:stop])  # type: ignore[index]
    if blk.dtype in (np.float32, np.float64) and blk.dtype.isnative and blk.flags.c_contiguous:
        return blk
    return np.ascontiguousarray(blk, dtype=np.float64)


class _RatePhase(_Phase):
    """Phase of a (possibly memory-mapped) rate record, rebuilt per read from checkpoints.

    The phase's running sum restarts every ``kernels.TILE`` samples of the record
    (:func:`kernels.integrate`), as in memory, so a read from a checkpoint, a cursor and the
    one pass give the same digits, and the rounding does not pile up over the record.
    """

    def __init__(self, y: ArrayLike, tau0: float, mean: float) -> None:
        self.y = y
        self.n = len(y)  # type: ignore[arg-type]
        self.size = self.n + 1
        self.tau0 = tau0
        self.mean = mean
        self.chunk = CHUNK
        self._checkpoints: NDArray | None = None

    @property
    def checkpoints(self) -> NDArray:
        """State ``(base, c)`` of the running sum at sample ``k CHUNK``, shape (k, 2).

        Built on first use (``kernels.integrate``).
        """
        if self._checkpoints is None:
            state = (0.0, 0.0)
            ck = [state]
            buf = np.empty(CHUNK + 1)
            from inertest.noise import kernels  # numba: loaded on first use
            for i in range(0, self.n, CHUNK):
                blk = _samples(self.y, i, i + CHUNK)
                state = kernels.integrate(blk, self.mean, i, *state, self.tau0,
                                          buf[: blk.size + 1])
                ck.append(state)
            self._checkpoints = np.asarray(ck)
        return self._checkpoints

    def read(self, start: int, stop: int) -> NDArray:
        start = max(0, start)
        stop = min(self.size, stop)
        if stop <= start:
            return np.empty(0)
        k = start // CHUNK
        base = k * CHUNK
        blk = _samples(self.y, base, stop - 1)
        out = np.empty(blk.size + 1)
        from inertest.noise import kernels

        b, c = self.checkpoints[k]
        kernels.integrate(blk, self.mean, base, float(b), float(c), self.tau0, out)
        return out[start - base : stop - base]


class _AnglePhase(_Phase):
    """Phase given directly (angle input), minus the straight line through its end points."""

    def __init__(self, x: _Record, tau0: float) -> None:
        self.xr = x
        self.size = len(x)
        self.tau0 = tau0
        self.chunk = CHUNK
        self.first = float(x[0])
        last = float(x[self.size - 1])
        self.slope = (last - self.first) / (self.size - 1) if self.size > 1 else 0.0

    def read(self, start: int, stop: int) -> NDArray:
        start = max(0, start)
        stop = min(self.size, stop)
        raw = np.asarray(self.xr[start:stop], dtype=np.float64)
        k = np.arange(start, stop, dtype=np.float64)
        return _minus_line(raw, self.first, self.slope, k)


#: Veltkamp's splitting constant for float64 (2**27 + 1).
_SPLIT = 134217729.0


def _minus_line(raw: NDArray, first: float, slope: float, k: NDArray) -> NDArray:
    """``raw - (first + slope k)`` with the line carried to twice the working precision.

    A phase growing at a constant rate is large beside its residual; the plain expression
    rounds each point by about eps |raw| (7e-10 of ADEV at 1e6 samples of a 5 rad/s
    angle record). Here the line is an unevaluated sum ``s + e`` (Dekker's two-product and
    Knuth's two-sum, exact in float64 arithmetic), ``raw - s`` is exact where the residual is
    small beside ``raw`` (Sterbenz), and the residual keeps its own digits.
    """
    p = slope * k
    c = _SPLIT * slope  # Dekker: slope * k = p + ep exactly
    sh = c - (c - slope)
    sl = slope - sh
    ck = _SPLIT * k
    kh = ck - (ck - k)
    kl = k - kh
    ep = ((sh * kh - p) + sh * kl + sl * kh) + sl * kl
    s = first + p  # Knuth: first + p = s + es exactly
    bb = s - first
    es = (first - (s - bb)) + (p - bb)
    return (raw - s) - (es + ep)


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
    data: ArrayLike, rate: float, data_type: str = "rate", *, stream: bool | None = None,
    fuse: str = "",
) -> _Phase:
    """Validate the input and build the phase points (SP 1065: N rates -> N + 1 phases).

    ``fuse`` (rate records in memory): ``"octave"`` also takes the noise-type rows at m = 1
    and 2 while integrating, and ``x[::4]`` (where the octave decimations start);
    ``"hadamard"`` also the Hadamard sums at m = 1 and 2 (see ``kernels.integrate_fused``).
    The fused build removes an estimate of the mean rate (:func:`_level`), the others the
    exact mean: the phases differ by a straight line, which none of the statistics sees
    (their results agree to rounding).
    """
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
    if n < min_samples("oadev", data_type):
        raise DataError(
            f"the record has {n} samples; Allan-family statistics need at least "
            f"{min_samples('oadev', data_type)} {data_type} samples (more than 100 for a useful "
            "tau range): record longer"
        )
    if stream is None:
        # Memory maps and file-backed array-likes stream; arrays in memory stay in memory,
        # at any size (the phase costs 8 bytes per sample more).
        stream = isinstance(data, np.memmap) or not isinstance(data, np.ndarray)
    if data_type == "rate":
        from inertest.noise import kernels  # numba: loaded on first use

        if stream:
            return _RatePhase(data, tau0, _block_mean(data))
        yc = np.ascontiguousarray(data, dtype=np.float64)
        if fuse not in ("octave", "hadamard"):
            mean = _block_mean(yc)
            x = _work_array(n + 1)
            kernels.integrate(yc, mean, 0, 0.0, 0.0, tau0, x)
            return _MemoryPhase(x, tau0, owned=[x])
        # No pass for the exact mean: the level removed is estimated (_level), and a NaN or
        # an infinity anywhere makes the last phase point not finite.
        level = _level(yc)
        x = _work_array(n + 1)
        two = n >= 6
        third = two and fuse == "hadamard"
        quarter = _work_array(n // 4 + 1 if two else 0)
        rows = np.zeros((2, 2, kernels.LAG1_FIELDS))
        h1, h2 = kernels.integrate_fused(yc, level, tau0, x, quarter, rows, third)
        if not math.isfinite(x[n]):
            _release_work([x, quarter])
            raise _not_finite(yc, 0)
        mp = _MemoryPhase(x, tau0, owned=[x, quarter])
        mp.rows[1] = rows[0]
        if two:
            mp.rows[2] = rows[1]
            mp.quarter = quarter
        if third:
            mp.hdev.update({1: h1, 2: h2})
        return mp
    _check_finite_angle(data)
    # An array, or an array-like with shape and __getitem__ (converted above otherwise) that
    # len() took: a record read by index and slice.
    assert isinstance(data, _Record)
    src = _AnglePhase(data, tau0)
    if stream:
        return src
    return _MemoryPhase(src.read(0, src.size), tau0)


# --------------------------------------------------------------------------- tau grids


def min_samples(statistic: str, data_type: str = "rate") -> int:
    """Fewest samples for which ``statistic`` has one term (at tau0).

    Three phase points (one second difference) for the Allan family and TOTDEV, four (one
    third difference) for the Hadamard ones; rate samples are one fewer (SP 1065: N rates ->
    N + 1 phase points).
    """
    points = 4 if statistic in ("hdev", "ohdev") else 3
    return points - 1 if data_type == "rate" else points


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
            f"the record ({nx} phase points) is too short for {statistic}; it needs at least "
            f"{min_samples(statistic, 'rate')} rate samples ({min_samples(statistic, 'angle')} "
            "angle samples)"
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
            f"tau {t[m > mmax][0]:.10g} s is too long for {statistic} on this record; the "
            f"longest is {mmax / rate:.10g} s"
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


def _variances(statistic: str, ssq: NDArray, ms: NDArray, ns: NDArray,
               tau0: float) -> NDArray:
    """:func:`_variance` at many taus (the same arithmetic, element by element)."""
    tau = ms * tau0
    n = ns.astype(np.float64)
    if statistic in ("adev", "oadev", "totdev"):
        return ssq / (2.0 * n * tau * tau)
    if statistic in ("mdev", "tdev"):
        m = ms.astype(np.float64)
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



# --------------------------------------------------------------------------- one streamed pass
# Streaming evaluates every tau of every statistic in one pass over the record. Each term is
# indexed by the largest phase index p it reads; its other points lie at lags 0 < L <= 3m
# behind p. The pass integrates each chunk of phase once (the running sum restarted every
# kernels.TILE samples of the record, its state carried from chunk to chunk, so the points are
# the digits of a phase built whole with the same level) and keeps the last CHUNK points
# as a tail: lags up to one chunk are views of that buffer. Each longer lag L gets its own
# cursor, a second integrator running L points behind, shared by every tau that needs that lag
# (on the octave grid the lags 2m of one tau and m of the next coincide). Memory: the buffer
# (2 chunks) plus one chunk per long lag, at most _MAX_CURSORS per pass (more taus, more passes).

#: Long lags (more than one chunk) served per pass; each costs one chunk of memory.
_MAX_CURSORS = 24


class _Cursor:
    """Phase points ``x[p], x[p+1], ...`` produced in order from ``p = 0`` (one integrator)."""

    def __init__(self, src: _Phase) -> None:
        self.src = src
        self.pos = 0
        self.state = (0.0, 0.0)  # of the running sum (kernels.integrate)
        self.buf = np.empty(0)

    def next(self, count: int, out: NDArray | None = None) -> NDArray:
        """The next ``count`` points (in ``out[:count]`` when given; ``out`` one longer)."""
        src = self.src
        p, q = self.pos, self.pos + count
        self.pos = q
        if not isinstance(src, _RatePhase):
            x = src.read(p, q)
            if out is None:
                return x
            out[:count] = x
            return out[:count]
        from inertest.noise import kernels  # numba: loaded on first use

        if out is None:
            if self.buf.size < count + 1:
                self.buf = np.empty(count + 1)
            out = self.buf
        blk = _samples(src.y, p, min(q, src.n))
        self.state = kernels.integrate(blk, src.mean, p, *self.state, src.tau0,
                                       out[: blk.size + 1])
        return out[:count]


def _lags(statistic: str, m: int) -> tuple[int, ...]:
    """Lags of the points of one term behind its last point, oldest first."""
    if statistic in ("oadev", "adev"):
        return (2 * m, m, 0)
    return (3 * m, 2 * m, m, 0)


def _stream_pass(src: _Phase, requests: Sequence[tuple[str, int]], orders: dict[int, int],
                 points: dict[int, int], tick: Callable[[int], None]
                 ) -> tuple[dict[tuple[str, int], float], dict[int, NDArray],
                            dict[int, NDArray]]:
    """Sums of squares of ``requests`` (statistic, m) and noise-type data in one pass.

    ``orders[m]``: lag-1 sums of the decimated phase ``x[0], x[m], ...`` and its differences
    (that many rows, see ``kernels.lag1_update``) are wanted; ``points[m]``: the decimated
    phase itself (``count + 1`` points, for the B1 ratio). TOTDEV is not handled here.

    The overlapping Allan sums at ``2 m <= chunk`` are taken by first point, one chunk behind
    the integration: when chunk ``[p0, p1)`` is in, the terms that start in ``[p0 - chunk,
    p0)`` have all their points in the buffer, and ``kernels.allan_sums`` sums them for every
    such tau at once, as in memory (three octaves per pass, tiles that stay in cache; a pass
    over m, 2m and 4m reads 8m ahead, and 2 (4m) <= chunk); the terms that start in the last
    chunk are summed after it.
    """
    from inertest.noise import kernels  # numba: loaded on first use

    chunk = CHUNK
    nx = src.size
    long_lags = sorted({lag for s, m in requests for lag in _lags(s, m) if lag > chunk})
    if len(long_lags) > _MAX_CURSORS:  # bounded memory: split the taus into several passes
        head: list[tuple[str, int]] = []
        seen: set[int] = set()
        rest: list[tuple[str, int]] = []
        for s, m in sorted(requests, key=lambda r: r[1]):
            new = {lag for lag in _lags(s, m) if lag > chunk} - seen
            if rest or (head and len(seen) + len(new) > _MAX_CURSORS):
                rest.append((s, m))
            else:
                head.append((s, m))
                seen |= new
        sums, states, pts = _stream_pass(src, head, orders, points, tick)
        more, _, _ = _stream_pass(src, rest, {}, {}, tick)
        sums.update(more)
        return sums, states, pts
    cursors = {lag: _Cursor(src) for lag in long_lags}
    main = _Cursor(src)
    buf = np.zeros(2 * chunk + 1)  # buf[chunk + p - p0] = x[p] for p0 - chunk <= p < p1
    sums = {r: 0.0 for r in requests}
    short = np.array(sorted(m for s, m in requests if s == "oadev" and 2 * m <= chunk),
                     dtype=np.int64)
    short_sums = np.zeros(short.size)
    work = sum(_work(s, m, nx) for s, m in requests)
    requests = [r for r in requests if not (r[0] == "oadev" and 2 * r[1] <= chunk)]
    windows = {r: 0.0 for r in requests if r[0] in ("mdev", "tdev")}  # s_j of modified Allan
    states = {m: np.zeros((k, kernels.LAG1_FIELDS)) for m, k in orders.items()}
    counts = {m: (nx - 1) // m for m in set(orders) | set(points)}
    pieces: dict[int, list[NDArray]] = {m: [] for m in points}
    for p0 in range(0, nx, chunk):
        p1 = min(nx, p0 + chunk)
        main.next(p1 - p0, buf[chunk:])
        if short.size and p0:  # the terms starting in the chunk before
            first_point = p0 - chunk
            count = np.clip(np.minimum(p0, nx - 2 * short) - first_point, 0, None)
            short_sums += kernels.allan_sums(buf, short, count, False)
        seg = {lag: c.next(p1 - max(p0, lag)) for lag, c in cursors.items() if p1 > lag}

        def win(lag: int, a: int, b: int, p0: int = p0, seg: dict = seg) -> NDArray:
            """``x[a - lag : b - lag]`` for positions ``p0 <= a <= b <= p1``."""
            if lag <= chunk:
                return buf[chunk + a - lag - p0 : chunk + b - lag - p0]
            base = max(p0, lag)
            return seg[lag][a - base : b - base]

        for r in requests:
            s, m = r
            lags = _lags(s, m)
            first = lags[0]  # position of the first term
            if s in ("oadev", "ohdev"):
                a, b = max(p0, first), min(p1, nx)
                if b > a:
                    w = [win(lag, a, b) for lag in lags]
                    if s == "oadev":
                        sums[r] += kernels.sum_second_diff(w[0], w[1], w[2], 1)
                    else:
                        sums[r] += kernels.sum_third_diff(w[0], w[1], w[2], w[3], 1)
            elif s in ("adev", "hdev"):
                n = _terms(s, m, nx)
                a = max(p0, first)
                a += (-a) % m  # terms at multiples of m
                b = min(p1, first + (n - 1) * m + 1)
                if b > a:
                    w = [win(lag, a, b) for lag in lags]
                    if s == "adev":
                        sums[r] += kernels.sum_second_diff(w[0], w[1], w[2], m)
                    else:
                        sums[r] += kernels.sum_third_diff(w[0], w[1], w[2], w[3], m)
            else:  # modified Allan: window sum s_0 over p in [2m, 3m), then the recursion
                a, b = max(p0, 2 * m), min(p1, 3 * m)
                if b > a:
                    windows[r] += kernels.second_diff_sum(win(2 * m, a, b), win(m, a, b),
                                                          win(0, a, b))
                a, b = max(p0, first), min(p1, nx)
                if b > a:
                    w = [win(lag, a, b) for lag in lags]
                    acc, windows[r] = kernels.sum_modified(w[0], w[1], w[2], w[3], windows[r],
                                                           b - a)
                    sums[r] += acc
        x = buf[chunk : chunk + p1 - p0]
        for m, count in counts.items():
            a = p0 + (-p0) % m
            b = min(p1, count * m + 1)
            if b > a:
                if m in states:
                    kernels.lag1_extend(x[a - p0 : b - p0 : m], states[m])  # strided: no copy
                if m in pieces:
                    pieces[m].append(x[a - p0 : b - p0 : m].copy())
        buf[:chunk] = buf[chunk : 2 * chunk]
        tick(work * p1 // nx - work * p0 // nx)
    if short.size:  # the terms starting in the last chunk, now at buf[0]
        first_point = (nx - 1) // chunk * chunk
        count = np.clip(nx - 2 * short - first_point, 0, None)
        short_sums += kernels.allan_sums(buf[: nx - first_point], short, count, False)
        sums.update({("oadev", int(m)): float(v) for m, v in zip(short, short_sums,
                                                                 strict=True)})
    for r in windows:  # the last term of the modified Allan sum
        sums[r] += windows[r] * windows[r]
    return sums, states, {m: np.concatenate(v) for m, v in pieces.items()}


def _family(statistic: str) -> str:
    return "hadamard" if statistic in ("hdev", "ohdev") else "allan"


#: Degree of the trend removed from the decimated phase before its lag-1 autocorrelation
#: (a frequency offset and drift; one less for each difference): Riley & Greenhall (2004),
#: as allantools' autocorr_noise_id does.
_DETREND = 2

#: Marks a tau whose noise type cannot be identified (fewer than 3 averages).
_NO_TYPE = 99


def _noise_type(src: _Phase, m: int, family: str,
                sums: dict[tuple[str, int], float] | None = None,
                state: NDArray | None = None, points: NDArray | None = None
                ) -> tuple[int | None, str]:
    """Noise type alpha at tau = m tau0 from the whole record (SP 1065 5.6), and the rule.

    At least :data:`MIN_ACF_AVERAGES` averages: lag-1 autocorrelation of the decimated phase
    and its differences (Riley & Greenhall 2004; dmax 2 for the Allan family, 3 for Hadamard).
    Fewer: B1 ratio of the frequency averages (1 where B1 says phase noise: which one,
    R(n) tells in :func:`_settle_types`). None when fewer than 3 averages. The rule is
    ``"lag1"``, ``"b1"`` or ``"min-edf"`` (:data:`NOISE_RULES`).
    ``sums`` caches the OADEV and MDEV sums of squares by (statistic, m). A streamed record
    passes what its one pass gathered: ``state``, the lag-1 sums (at least ``dmax + 1`` rows),
    or ``points``, the decimated phase; in memory ``state`` may hold rows 0-1 already summed.
    """
    from inertest.noise import kernels  # numba: loaded on first use

    count = (src.size - 1) // m
    dmax, alpha_min = (3, -4) if family == "hadamard" else (2, -2)
    if count >= MIN_ACF_AVERAGES:
        if isinstance(src, _MemoryPhase):
            # orders 0 and 1 first: for most noise types the decision falls there
            rows = kernels.lag1_first_two(src.x, m, count) if state is None else state
            r1 = [r1_of_state(row, _DETREND - d) for d, row in enumerate(rows[:2])]
            if all(_delta(r) >= 0.25 for r in r1):
                state = kernels.lag1_sums(src.x, m, count, dmax + 1)
                r1 += [r1_of_state(row) for row in state[2:]]
            return alpha_from_lag1(r1 + [0.0] * (dmax + 1 - len(r1)), phase=True,
                                   alpha_min=alpha_min), "lag1"
        if state is not None:
            state = state[: dmax + 1]
        else:
            acc = Lag1(dmax, detrend=_DETREND)
            for blk in _decimated(src, m, count):
                acc.add(blk)
            state = acc.state
        return alpha_from_lag1([r1_of_state(row, max(0, _DETREND - d))
                                for d, row in enumerate(state)], phase=True,
                               alpha_min=alpha_min), "lag1"
    if count < 3:
        return None, "min-edf"
    alpha: int | None
    if isinstance(src, _MemoryPhase):
        var, avar = kernels.b1_stats(src.x, m, count)
        alpha = b1_decide(var, avar, count, alpha_min=alpha_min)
    else:
        xs = points if points is not None else np.concatenate(list(_decimated(src, m, count)))
        alpha = b1_alpha(np.diff(xs), alpha_min=alpha_min)
    return alpha, "b1"


def _rn_ratio(src: _Phase, mm: int,
              sums: dict[tuple[str, int], float] | None) -> float | None:
    """R(n) = MVAR/AVAR at averaging factor ``mm`` (SP 1065 5.6.3); None where AVAR is zero.

    The OADEV and MDEV sums of squares are taken from ``sums`` (by (statistic, m)) when there,
    else computed (in memory: one pass for both; streamed: one more pass over the record) and
    left there.
    """
    from inertest.noise import kernels  # numba: loaded on first use

    n_mod, n_oa = _terms("mdev", mm, src.size), _terms("oadev", mm, src.size)
    cache = {} if sums is None else sums
    if isinstance(src, _MemoryPhase):
        one = np.array([mm], dtype=np.int64)
        if ("mdev", mm) not in cache and ("oadev", mm) not in cache:  # one pass for both
            cache["mdev", mm], cache["oadev", mm] = (
                float(v) for v in kernels.modified_allan_pair(src.x, mm, n_mod, n_oa))
        if ("mdev", mm) not in cache:
            cache["mdev", mm] = float(kernels.modified_sums(src.x, one, np.array([n_mod]))[0])
        if ("oadev", mm) not in cache:
            cache["oadev", mm] = float(kernels.allan_sums(src.x, one, np.array([n_oa]),
                                                          False)[0])
    else:
        need = [(k, mm) for k in ("mdev", "oadev") if (k, mm) not in cache]
        if need:
            cache.update(_stream_pass(src, need, {}, {}, _no_tick)[0])
    mvar = _variance("mdev", cache["mdev", mm], mm, n_mod, 1.0)
    avar = _variance("oadev", cache["oadev", mm], mm, n_oa, 1.0)
    return mvar / avar if avar > 0 else None


#: Blocks per averaging window of the strided R(n) (:func:`_rn_strided`): with 30 or more
#: averages, and with fewer (where every term counts).
_RN_BLOCKS, _RN_BLOCKS_FEW = 8, 64
#: R(n) is taken from at most this many averages at the start of the record.
_RN_MAX_AVERAGES = 1024


def _rn_block(mm: int, nx: int) -> int:
    """Block size of the strided R(n) at ``mm`` (a power of two)."""
    few = (nx - 1) // mm < MIN_ACF_AVERAGES
    return max(1, mm // (_RN_BLOCKS_FEW if few else _RN_BLOCKS))


def _rn_strided(src: _Phase, mms: Sequence[int],
                cache: dict[int, tuple[NDArray, NDArray]]) -> dict[int, float | None]:
    """R(n) = MVAR/AVAR at each power of two ``mm`` from terms ``b`` samples apart.

    The overlapping estimators (SP 1065 eqs. 14, 16) restricted to the terms that start at
    multiples of ``b`` (:func:`_rn_block`: ``mm / 8``, or ``mm / 64`` below 30 averages):
    their expectations are those of the full ones, and 8 or 64 starts per tau keep most of
    their precision (neighbouring terms share most of their data). A window sum of ``mm``
    phase points is a sum of block sums of ``b`` points (``kernels.rn_block_sums``). Where the
    record holds more than :data:`_RN_MAX_AVERAGES` averages only its first that many are
    used (R(n) then varies by a few per cent, where the decision needs a factor of 2).
    ``cache`` keeps the block sums and ``x[::b]`` over the whole record by ``b``; coarser
    blocks are summed from the finest there, so the record is read once; streamed, the
    finest blocks asked for come from one pass. None where the strided AVAR is zero.
    """
    from inertest.noise import kernels  # numba: loaded on first use

    nx = src.size
    whole = [mm for mm in mms if (nx - 1) // mm <= _RN_MAX_AVERAGES]
    want = sorted({_rn_block(mm, nx) for mm in whole} - set(cache))
    for b in want:
        base = max((c for c in cache if c < b and b % c == 0), default=0)
        if base:  # coarser blocks from finer ones: sums of whole blocks, every r-th point
            blocks, points = cache[base]
            cs, _ = kernels.block_sums(blocks, b // base)
            _, ps = kernels.block_sums(points, b // base)
            cache[b] = cs[: nx // b], ps
        elif isinstance(src, _MemoryPhase):
            x = src.x
            nb = nx // b
            cache[b] = ((x, x) if b == 1 else kernels.block_sums(x, b) if b < 32
                        else (x[: nb * b].reshape(nb, b).sum(axis=1), x[::b].copy()))
        else:
            step = max(b, (CHUNK // b) * b)
            parts = [kernels.block_sums(np.ascontiguousarray(src.read(a, min(nx, a + step))), b)
                     for a in range(0, nx, step)]
            cache[b] = (np.concatenate([p[0] for p in parts]),
                        np.concatenate([p[1] for p in parts]))
    out: dict[int, float | None] = {}
    for mm in mms:
        b = _rn_block(mm, nx)
        if mm in whole:
            blocks, points = cache[b]
        else:  # the first _RN_MAX_AVERAGES averages only
            head = np.ascontiguousarray(src.read(0, _RN_MAX_AVERAGES * mm + 1))
            blocks, points = (head, head) if b == 1 else kernels.block_sums(head, b)
        msum, asum, n_mod, n_oa = kernels.rn_block_sums(blocks, points, mm // b)
        avar = asum / n_oa if n_oa else 0.0
        out[mm] = msum / (n_mod * mm * mm) / avar if avar > 0 and n_mod else None
    return out


def _lag1_decide_many(rows: NDArray, alpha_min: int) -> NDArray:
    """:func:`alpha_from_lag1` (phase data) at many taus from their lag-1 rows 0-1.

    ``rows`` has shape ``(K, 2, LAG1_FIELDS)``; the arithmetic is that of :func:`r1_of_state`
    (the decimated phase less a quadratic, its difference less a line) and
    :func:`alpha_from_lag1`, element by element (one numba loop). Where neither order decides
    (both ``delta >= 0.25``: higher orders are needed) the result is ``_NO_TYPE``.
    """
    from inertest.noise import kernels  # numba: loaded on first use

    return kernels.lag1_decide_two(np.ascontiguousarray(rows, dtype=np.float64), _DETREND,
                                   alpha_min, _NO_TYPE)


def _delta(r1: float) -> float:
    """Riley & Greenhall's ``delta = r1 / (1 + r1)`` (as :func:`alpha_from_lag1` forms it)."""
    return r1 / (1.0 + r1) if r1 > -1.0 else -1.0


def _no_tick(k: int) -> None:
    return None


def _edf_many(statistic: str, alpha: NDArray, ms: NDArray, ns: NDArray, nx: int) -> NDArray:
    """EDF of one statistic at many taus (Greenhall's algorithm; TOTDEV: SP 1065 Table 11)."""
    if statistic == "totdev":
        out = np.empty(ms.size)
        ph = alpha >= 1
        if ph.any():
            out[ph] = edf_greenhall_many(alpha[ph], 2, ms[ph], nx - 2 * ms[ph], modified=False,
                                         overlapping=True)
        for a in (0, -1, -2):
            sel = ~ph & (np.maximum(alpha, -2) == a)
            b, c = _TOTDEV_BC[a]
            out[sel] = b * nx / ms[sel] - c
        return out
    d = 3 if statistic in ("hdev", "ohdev") else 2
    return edf_greenhall_many(alpha, d, ms, ns, modified=statistic in ("mdev", "tdev"),
                              overlapping=statistic not in ("adev", "hdev"))


def _settle_types(src: _Phase, statistic: str, ms: NDArray, ns: NDArray, raw: NDArray,
                  rules: list[str], blocks: dict[int, tuple[NDArray, NDArray]],
                  sums: dict[tuple[str, int], float]) -> tuple[NDArray, list[str]]:
    """The noise type at each tau from the per-tau decisions, R(n) and the neighbouring taus.

    ``raw`` and ``rules`` are :func:`_noise_type`'s decisions at the taus ``ms`` (ascending).
    The taus are visited from the shortest; the type settled at the last tau the lag-1 method
    decided is the *anchor* for the longer taus (rules: :data:`NOISE_RULES`):

    * a lag-1 verdict of phase noise (alpha 1, 2) after frequency noise at the tau before is
      capped at that type: for a sum of independent power-law noises the dominant type can
      only fall as tau grows (``sigma^2 = sum h_alpha tau^(-1-alpha)``), and with a few tens
      of averages the lag-1 method takes white FM for phase noise at 2-26 % of taus;
    * any other lag-1 verdict of phase noise at ``m >= RN_MIN_M`` is checked by R(n) =
      MVAR/AVAR (:func:`rn_decide`, R(n) from :func:`_rn_strided` at the power of two at or
      below ``m``); where the two differ the type of smaller EDF of the two is used, and
      R(n)'s type is the anchor. The decimated phase of flicker PM looks white at long taus
      (aliasing: Riley & Greenhall's delta falls from 0.4 at m = 4 to 0.1 at m = 1024 of
      65536 points), so the lag-1 method alone takes flicker PM, and with a few tens of
      averages white FM, for white PM: intervals 2-10x too narrow (Monte Carlo,
      tests/noise/test_noise_type_mc.py);
    * 3-29 averages, after a phase-noise anchor: R(n) says whether phase noise goes on, and
      which (never a type above that of the tau before); B1 cannot tell phase from frequency
      noise with so few averages;
    * 3-29 averages, after a frequency-noise anchor: the anchor's type, or one step below it
      where B1 (8 or more averages, :data:`B1_MIN_AVERAGES`) says lower (the type cannot
      rise; with 3-7 averages B1 picks the wrong type for 35-75 % of records of one pure
      type);
    * fewer than 3 averages: the type of smallest EDF (:func:`_alpha_and_edf`).

    Without an anchor (records of fewer than 60 samples) B1 decides, and where it says
    phase noise, R(n) at ``min(m, N/3)`` tells white from flicker PM from white FM (SP 1065
    5.6.3, Stable32's rule, the full overlapping MVAR and AVAR: ``sums``).
    """
    nx = src.size
    alpha = raw.copy()
    out = list(rules)
    anchor: int | None = None
    typed: dict[int, int | None] = {}

    def rn_m(m: int) -> int:
        mm = min(m, nx // 3)
        return 1 << (mm.bit_length() - 1)  # R(n) at a power of two: one per octave

    if not isinstance(src, _MemoryPhase) and any(
            r == "lag1" and a >= 1 and rn_m(int(m)) >= RN_MIN_M
            for r, a, m in zip(rules, raw, ms, strict=True)):
        # streamed: every R(n) this may need from one more pass over the record
        need = sorted({rn_m(int(m)) for r, m in zip(rules, ms, strict=True)
                       if r != "min-edf" and rn_m(int(m)) >= RN_MIN_M})
        typed.update({mm: None if r is None else rn_decide(r, mm)
                      for mm, r in _rn_strided(src, need, blocks).items()})

    def rn_type(m: int) -> int | None:
        mm = rn_m(m)
        if mm < RN_MIN_M:
            return None
        if mm not in typed:
            r = _rn_strided(src, [mm], blocks)[mm]
            typed[mm] = None if r is None else rn_decide(r, mm)
        return typed[mm]

    for i, m in enumerate(int(v) for v in ms):
        a, how = int(alpha[i]), out[i]
        if how == "lag1" and a >= 1 and i > 0 and 0 >= alpha[i - 1] != _NO_TYPE:
            a, how = int(alpha[i - 1]), "lag1+cap"  # no phase noise after frequency noise
            anchor = a
        elif how == "lag1":
            t = rn_type(m) if a >= 1 else None
            if t is not None and t == a:
                how = "lag1+rn"
            anchor = a if t is None else t  # phase noise or not: R(n) is the better judge
            if t is not None and t != a:
                e = _edf_many(statistic, np.array([a, t]), ms[[i, i]], ns[[i, i]], nx)
                a, how = (a if e[0] <= e[1] else t), "lag1|rn"
        elif how == "b1" and anchor is None and a == 1:  # phase noise: R(n) says which
            mm = min(m, nx // 3)
            rn = _rn_ratio(src, mm, sums)
            if rn is not None:
                a, how = rn_decide(rn, mm), "b1+rn"
        elif how != "min-edf" and anchor is not None:
            t = rn_type(m) if anchor >= 1 else None
            if t is not None:  # after phase noise: R(n) says whether it goes on (once
                a, how = min(t, anchor, int(alpha[i - 1])), "rn"  # gone, it stays gone)
            elif a > anchor or (a < anchor and (nx - 1) // m < B1_MIN_AVERAGES):
                a, how = anchor, "anchor"
            elif a < anchor:
                a, how = anchor - 1, "b1-step"
        alpha[i] = a
        out[i] = how
    return alpha, out


def _alpha_and_edf(statistic: str, alpha: NDArray, ms: NDArray, ns: NDArray,
                   nx: int) -> tuple[NDArray, NDArray]:
    """Noise types and EDFs at many taus.

    Where the type cannot be identified (fewer than 3 averages, ``alpha == _NO_TYPE``) the type
    of smallest EDF is used, so the interval is the widest any noise type would give.
    """
    alpha = alpha.copy()
    edf = np.empty(ms.size)
    known = alpha != _NO_TYPE
    if known.any():
        edf[known] = _edf_many(statistic, alpha[known], ms[known], ns[known], nx)
    if not known.all():
        lo = -4 if _family(statistic) == "hadamard" else -2
        cands = np.arange(lo, 3)
        u = ~known
        e = np.vstack([_edf_many(statistic, np.full(int(u.sum()), a), ms[u], ns[u], nx)
                       for a in cands])
        k = np.argmin(e, axis=0)  # ties: the smallest alpha, as min() over (edf, alpha)
        edf[u] = e[k, np.arange(k.size)]
        alpha[u] = cands[k]
    return alpha, edf


def _memory_sums(x: NDArray, statistic: str, ms: NDArray, ns: NDArray,
                 rows: dict[int, NDArray]) -> NDArray:
    """Sums of squares of one statistic at every tau of a phase record held in memory.

    HDEV also leaves the noise-type rows 0-1 of each m in ``rows`` (same decimated series).
    """
    from inertest.noise import kernels  # numba: loaded on first use

    if statistic == "hdev":
        ssq, r = kernels.hadamard_decimated(x, ms, ns)
        rows.update({int(m): r[k] for k, m in enumerate(ms)})
        return ssq
    if statistic in ("adev", "oadev"):
        return kernels.allan_sums(x, ms, ns, statistic == "adev")
    if statistic in ("hdev", "ohdev"):
        return kernels.hadamard_sums(x, ms, ns, statistic == "hdev")
    if statistic in ("mdev", "tdev"):
        return kernels.modified_sums(x, ms, ns)
    return kernels.total_sums(x, ms)


def _work(statistic: str, m: int, nx: int) -> int:
    """Work units (samples visited) of one statistic at one tau, for progress reports."""
    if statistic == "totdev":
        return nx
    return _terms(statistic, m, nx) * (m if statistic in ("adev", "hdev") else 1)


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
        Force the chunked path (default: for memory maps and file-backed array-likes only).
    """
    unknown = [s for s in stats if s not in STATISTICS]
    if unknown or not stats:
        raise InputError(
            f"unknown statistic {unknown[0] if unknown else ''!r}; choose from "
            f"{', '.join(STATISTICS)}"
        )
    if not (0.0 < confidence < 1.0):
        raise InputError(f"confidence must be between 0 and 1, got {confidence}")
    big = hasattr(data, "__len__") and len(data) >= _FUSE_ROWS  # type: ignore[arg-type]
    src = phase_source(data, rate, data_type, stream=stream,
                       fuse="hadamard" if "hdev" in stats else "octave" if big else "")
    nx = src.size
    grids = {s: averaging_factors(taus, 1.0 / src.tau0, s, nx) for s in stats}
    work = sum(_work(s, int(m), nx) for s in stats for m in grids[s])
    done = [0]

    def tick(k: int) -> None:
        done[0] += k
        if progress is not None:
            progress(min(done[0], work), work)

    alpha_cache: dict[tuple[int, str], tuple[int | None, str]] = {}
    rn_blocks: dict[int, tuple[NDArray, NDArray]] = {}  # strided R(n) data, by block size
    sums: dict[tuple[str, int], float] = {}  # OADEV, MDEV sums by m, reused for R(n)
    states: dict[int, NDArray] = {}
    points: dict[int, NDArray] = {}
    if isinstance(src, _MemoryPhase):
        states.update(src.rows)
    if not isinstance(src, _MemoryPhase):
        # every tau of every statistic (but TOTDEV) and the noise-type data in one pass
        reqs = sorted({("mdev" if s == "tdev" else s, int(m))
                       for s in stats if s != "totdev" for m in grids[s]})
        orders: dict[int, int] = {}
        wanted: dict[int, int] = {}
        for s in stats:
            for m in (int(v) for v in grids[s]):
                count = (nx - 1) // m
                if count >= MIN_ACF_AVERAGES:
                    orders[m] = max(orders.get(m, 0), 4 if _family(s) == "hadamard" else 3)
                elif count >= 3:
                    wanted[m] = count
        sums, states, points = _stream_pass(src, reqs, orders, wanted, tick)
    out: dict[str, DeviationResult] = {}
    for s in stats:
        ms = np.asarray(grids[s], dtype=np.int64)
        ns = np.array([_terms(s, int(m), nx) for m in ms], dtype=np.int64)
        ssq = np.empty(ms.size)
        if (isinstance(src, _MemoryPhase) and s == "hdev" and src.quarter is not None
                and ms.size >= 2 and ms[0] == 1 and ms[1] == 2):
            # m = 1, 2 summed while the phase was built; the rest from x[::4], in place
            from inertest.noise import kernels  # numba: loaded on first use

            ssq[0], ssq[1] = src.hdev[1], src.hdev[2]
            if ms.size > 2:
                ssq[2:], r = kernels.hadamard_from(src.x, ms[2:], ns[2:], src.quarter, 4)
                states.update({int(m): r[k] for k, m in enumerate(ms[2:])})
            src.quarter = None
            tick(sum(_work(s, int(m), nx) for m in ms))
        elif isinstance(src, _MemoryPhase):
            # Taus in groups of about _GROUP_WORK samples: one kernel call per group, a
            # progress tick after each.
            i = 0
            while i < ms.size:
                j, w = i, 0
                while j < ms.size and (j - i < 3 or w < _GROUP_WORK):  # 3: octave passes
                    w += _work(s, int(ms[j]), nx)
                    j += 1
                ssq[i:j] = _memory_sums(src.x, s, ms[i:j], ns[i:j], states)
                tick(w)
                i = j
            if s in ("oadev", "mdev", "tdev"):
                kind = "oadev" if s == "oadev" else "mdev"
                sums.update({(kind, int(m)): float(v) for m, v in zip(ms, ssq, strict=True)})
        elif s == "totdev":
            for i, m in enumerate(int(v) for v in ms):
                ssq[i] = _sum_squares(src, s, m, int(ns[i]), tick)
        else:
            kind = "mdev" if s == "tdev" else s
            ssq[:] = [sums[kind, int(m)] for m in ms]
        var = _variances(s, ssq, ms, ns, src.tau0)
        if isinstance(src, _MemoryPhase):  # noise-type rows 0-1 of every new m in one call
            new = np.array([m for m in ms if int(m) not in states
                            and (nx - 1) // m >= MIN_ACF_AVERAGES
                            and (int(m), _family(s)) not in alpha_cache], dtype=np.int64)
            if new.size:
                from inertest.noise import kernels  # numba: loaded on first use

                # x[::4] from the phase build (when no HDEV sums still need it) starts the
                # decimations; it is scratch, used once
                quarter = None if src.hdev else src.quarter  # None: start afresh
                rows = kernels.lag1_rows_many(src.x, new,
                                              np.empty(0) if quarter is None else quarter,
                                              0 if quarter is None else 4)
                if quarter is not None:
                    src.quarter = None
                states.update({int(m): rows[k] for k, m in enumerate(new)})
        if isinstance(src, _MemoryPhase):  # lag-1 decisions at orders 0-1: all taus at once
            fam = _family(s)
            todo = [int(m) for m in ms if (int(m), fam) not in alpha_cache and int(m) in states
                    and (nx - 1) // int(m) >= MIN_ACF_AVERAGES]
            if todo:
                got = _lag1_decide_many(np.stack([states[m][:2] for m in todo]),
                                        -4 if fam == "hadamard" else -2)
                alpha_cache.update({(m, fam): (int(a), "lag1")
                                    for m, a in zip(todo, got, strict=True) if a != _NO_TYPE})
        alph = np.empty(ms.size, dtype=np.int64)
        rules: list[str] = []
        for i, m in enumerate(int(v) for v in ms):
            key = (m, _family(s))
            if key not in alpha_cache:
                alpha_cache[key] = _noise_type(src, m, key[1], sums, states.get(m),
                                               points.get(m))
            a, how = alpha_cache[key]
            alph[i] = _NO_TYPE if a is None else a
            rules.append(how)
        alph, rules = _settle_types(src, s, ms, ns, alph, rules, rn_blocks, sums)
        alph, edf = _alpha_and_edf(s, alph, ms, ns, nx)
        lo, hi = chi2_interval(var, edf, confidence)
        t = ms * src.tau0
        dev, dlo, dhi = np.sqrt(var), np.sqrt(lo), np.sqrt(hi)
        if s == "tdev":
            f = t / math.sqrt(3.0)
            dev, dlo, dhi = dev * f, dlo * f, dhi * f
        out[s] = DeviationResult(
            statistic=s, taus=t, dev=dev, n=ns, edf=edf, alpha=alph, dev_lo=dlo, dev_hi=dhi,
            confidence=confidence, rate_hz=1.0 / src.tau0, data_type=data_type, name=_NAMES[s],
            n_samples=nx - 1, alpha_rule=tuple(rules),
        )
    if done[0] < work:  # streamed MDEV and TDEV share one sum
        tick(work - done[0])
    if isinstance(src, _MemoryPhase):  # nothing returned refers to them
        _release_work(src.owned)
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
