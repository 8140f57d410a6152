"""The whole-IMU noise analysis of :func:`inertest.noise.imu.analyse_imu_noise`, streamed.

For records longer than memory (a day at 1 kHz is 86.4 M samples per channel): the time stamps
and channels come as 1-D array-likes that are read in slices (``len()``, ``a[i:j]``; e.g.
:class:`inertest.io.raw_samples.SampleFile`), never whole. Every step of the in-memory analysis
is done here block by block, to the same definitions:

* time stamps (:func:`inertest.noise.imu.check_time_stamps`): the median positive interval
  exactly (:func:`exact_median`); gaps and non-increasing stamps;
  the longest clean segment; the jitter (standard deviation of the intervals in it, blocks
  combined by Chan et al.'s pairwise update);
* outliers (:func:`inertest.noise.imu.find_outliers`): the running median of each block with
  ``window // 2`` samples of its neighbours on each side, which is exactly the running median
  of the whole; the robust sigma from the exact medians of the residuals and of their absolute
  deviations (:func:`exact_median`: histogram passes, then the values of the one bin holding
  the middle rank sorted);
* clipping and the straight line of ``detrend`` (least squares from streamed sums) as lazy views
  of the channel, recomputed on each slice;
* the overlapping Allan deviation from :func:`inertest.noise.deviations.deviations` on those
  views (its chunked path), and the Welch PSD as the mean of the segment periodograms computed
  group by group (:func:`psd_welch_stream`; the same segments as ``scipy.signal.welch``).

The results are those of the in-memory analysis to rounding (the order of the sums differs);
outlier counts and the segment are exact. Memory: a few blocks of :data:`BLOCK` samples, plus
the Allan deviation's chunk buffers (:mod:`inertest.noise.deviations`), whatever the length.
"""

from __future__ import annotations

import contextlib
import math
import tempfile
import warnings
from collections.abc import Callable, Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import DataError, InputError
from inertest.noise.deviations import deviations
from inertest.noise.identification import EVENT_CHECK_MAX_SAMPLES, identify_noise
from inertest.noise.imu import (
    _KALIBR_UNITS,
    _SI_RATE,
    GAP_POLICIES,
    GAP_WINDOW,
    MAD_TO_SIGMA,
    MIN_SAMPLES,
    OUTLIER_POLICIES,
    OUTLIER_THRESHOLD,
    OUTLIER_WINDOW,
    ChannelNoise,
    Gap,
    ImuNoiseResult,
    TimingReport,
    _kalibr_term,
    missing_samples,
    nominal_interval,
    refuse_gaps,
    timing_messages,
)

#: Samples per block.
BLOCK = 1 << 20
#: Bins of each histogram pass of :func:`exact_median`.
_BINS = 1 << 16
#: A bin holding at most this many values (and at most :data:`BLOCK`) is sorted in memory.
_SORT_CAP = 1 << 22
#: Longest Welch segment, log2 [samples] (that of :func:`inertest.noise.imu.psd_welch`).
PSD_MAX_LOG2 = 16
#: Welch segments transformed at a time (memory: this many segments and their spectra).
PSD_GROUP = 8
#: ``progress(stage, done, total)``: a stage's name and its work units.
StageProgress = Callable[[str, int, int], None]

assert set(_KALIBR_UNITS)  # the Kalibr terms are those of the in-memory analysis


def _blocks(a: ArrayLike, start: int, stop: int, block: int | None = None,
            overlap: int = 0) -> Iterator[tuple[int, NDArray]]:
    """``(i, a[i - overlap : i + block])`` for i from ``start`` (clipped at ``start``)."""
    block = BLOCK if block is None else block
    for i in range(start, stop, block):
        lo = max(start, i - overlap)
        yield i, np.asarray(a[lo:min(stop, i + block)], dtype=np.float64)  # type: ignore[index]


# ------------------------------------------------------------------------------ medians


def exact_median(passes: Callable[[], Iterator[NDArray]], count: int) -> float:
    """The median (as ``np.median``) of ``count`` values given block by block.

    ``passes()`` starts a new pass over the values. A first pass finds their range; each next
    one histograms the values still in play into :data:`_BINS` equal bins and keeps the bin
    holding the middle rank(s), as the exact interval of values that fall in it; once at most
    :data:`_SORT_CAP` values (and one block) are in play, a last pass collects and sorts them:
    three passes for most records, a few more for heavily tied ones.
    """
    if count == 0:
        return math.nan
    lo, hi = math.inf, -math.inf
    for v in passes():
        if v.size:
            lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
    ranks = sorted({(count - 1) // 2, count // 2})
    return float(np.mean(_select(passes, ranks, count, lo, hi)))


def _select(passes: Callable[[], Iterator[NDArray]], ranks: list[int], n: int, lo: float,
            hi: float) -> list[float]:
    """The values of ``ranks`` (0-based, ascending) among the values of ``passes`` in a range.

    ``n`` values of ``passes`` lie in ``[lo, hi]``, ``lo`` and ``hi`` the smallest and
    largest of them; the ranks count from ``lo``. Each histogram pass also keeps the smallest
    and largest value of every bin: the bin index grows with the value (every float operation
    of :func:`_bin_of` is monotone), so the members of the chosen bin are exactly the values
    between those two, the range of the next pass.
    """
    cap = min(_SORT_CAP, BLOCK)  # what is sorted in memory: at most one block
    while True:
        if lo == hi:  # one value repeated (ties): nothing to hold
            return [lo] * len(ranks)

        def inside(lo: float = lo, hi: float = hi) -> Iterator[NDArray]:
            for v in passes():
                yield v[(v >= lo) & (v <= hi)]

        if n <= cap:
            values = np.sort(np.concatenate([v for v in inside()] or [np.empty(0)]))
            return [float(values[r]) for r in ranks]
        width = (hi - lo) / _BINS
        counts = np.zeros(_BINS + 1, dtype=np.int64)
        mins = np.full(_BINS + 1, np.inf)
        maxs = np.full(_BINS + 1, -np.inf)
        for v in inside():
            idx = _bin_of(v, lo, width)
            counts += np.bincount(idx, minlength=_BINS + 1)
            np.minimum.at(mins, idx, v)
            np.maximum.at(maxs, idx, v)
        cum = np.cumsum(counts)
        bins = [int(np.searchsorted(cum, r, side="right")) for r in ranks]
        starts = [int(cum[b - 1]) if b > 0 else 0 for b in bins]
        if len(set(bins)) > 1:  # the two middle ranks part: each on its own
            return [_select(passes, [r - s], int(counts[b]), float(mins[b]), float(maxs[b]))[0]
                    for r, b, s in zip(ranks, bins, starts, strict=True)]
        b = bins[0]
        ranks = [r - starts[0] for r in ranks]
        n, lo, hi = int(counts[b]), float(mins[b]), float(maxs[b])


def _bin_of(v: NDArray, lo: float, width: float) -> NDArray[np.int64]:
    return np.clip(((v - lo) / width).astype(np.int64), 0, _BINS)


# ------------------------------------------------------------------------------ time stamps


def stream_time_stamps(t: ArrayLike | None, *, n: int, rate_hz: float | None = None,
                       gaps: str = "refuse", block: int | None = None) -> TimingReport:
    """:func:`inertest.noise.imu.check_time_stamps` over stamps read in blocks (same errors)."""
    if gaps not in GAP_POLICIES:
        raise InputError(f"unknown gap policy {gaps!r}; use one of {', '.join(GAP_POLICIES)}")
    if rate_hz is not None and not (math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"the sample rate must be a positive number of Hz, got {rate_hz!r}")
    if t is None:
        if rate_hz is None:
            raise InputError("a recording without time stamps needs its sample rate; give it")
        return TimingReport(n, 1.0 / rate_hz, 0.0, (), (), (0, n), from_stamps=False)
    size = len(t)  # type: ignore[arg-type]
    if size < 2:
        raise DataError("the time stamps must be one column of at least 2 values")
    t0 = float(np.asarray(t[0:1])[0])  # type: ignore[index]
    m = 0
    for i, ts in _blocks(t, 0, size, block, overlap=1):
        if not np.all(np.isfinite(ts)):
            k = int(np.flatnonzero(~np.isfinite(ts))[0])
            j = max(0, i - 1) + k if i else k
            raise DataError(f"time stamp {j} is {ts[k]}; remove the row or fill in its time")
        m += int(np.count_nonzero(np.diff(ts) > 0))
    if m == 0:
        raise DataError("the time stamps never increase; check the time column and its unit")

    def positive() -> Iterator[NDArray]:
        for _, ts in _blocks(t, 0, size, block, overlap=1):
            d = np.diff(ts)
            yield d[d > 0]

    median = exact_median(positive, m)
    interval = nominal_interval(median, rate_hz)
    non_inc: list[Gap] = []
    gap_list: list[Gap] = []
    # Gaps are missing samples (:func:`inertest.noise.imu.missing_samples`): its windows reach
    # GAP_WINDOW stamps either side of an interval, and stop at gaps found that far again, so
    # each block read with 2 GAP_WINDOW + 2 stamps more on each side counts exactly as the
    # whole record in memory would.
    step = BLOCK if block is None else block
    margin = 2 * GAP_WINDOW + 2
    for i in range(0, size - 1, step):
        lo, hi = max(0, i - margin), min(size, i + step + 1 + margin)
        ts = np.asarray(t[lo:hi], dtype=np.float64)  # type: ignore[index]
        dt = np.diff(ts)
        miss = missing_samples(ts, median)
        for k in range(i - lo, min(i + step, size - 1) - lo):
            if dt[k] <= 0:
                non_inc.append(Gap(lo + k + 1, float(ts[k] - t0), float(dt[k])))
            elif miss[k] > 0:
                gap_list.append(Gap(lo + k + 1, float(ts[k] - t0), float(dt[k]), int(miss[k])))
    if (non_inc or gap_list) and gaps == "refuse":
        refuse_gaps(non_inc, gap_list, interval)
    cuts = np.union1d([g.index for g in non_inc], [g.index for g in gap_list]).astype(np.int64)
    edges = np.r_[0, cuts, size]
    k = int(np.argmax(np.diff(edges)))
    seg = (int(edges[k]), int(edges[k + 1]))
    # jitter: population std of the intervals inside the segment, blocks combined (Chan)
    cnt, mean, m2 = 0, 0.0, 0.0
    for _, ts in _blocks(t, seg[0], seg[1], block, overlap=1):
        d = np.diff(ts)
        if d.size == 0:
            continue
        bm = float(np.mean(d))
        bm2 = float(np.sum((d - bm) ** 2))
        tot = cnt + d.size
        delta = bm - mean
        mean += delta * d.size / tot
        m2 += bm2 + delta * delta * cnt * d.size / tot
        cnt = tot
    jitter = math.sqrt(m2 / cnt) if cnt > 1 else 0.0
    return TimingReport(int(size), interval, jitter, tuple(gap_list), tuple(non_inc), seg)


# ------------------------------------------------------------------------------ channels


class ChannelView:
    """Samples ``[s0, s1)`` of a channel, clipped about its running median and detrended.

    An array-like (``len``, ``shape``, slices with step 1) whose slices are computed from the
    source on demand: ``clip = (limit, window)`` clips ``y - med`` to ``+-limit``
    (:func:`inertest.noise.imu.find_outliers`' median), ``line = (c0, c1, rate)`` subtracts
    ``c1 t + c0`` with ``t = k / rate`` (k from the segment's start).
    """

    def __init__(self, src: ArrayLike, s0: int, s1: int,
                 clip: tuple[float, int] | None = None,
                 line: tuple[float, float, float] | None = None) -> None:
        self.src, self.s0, self.s1 = src, s0, s1
        self.clip, self.line = clip, line
        self.shape = (s1 - s0,)
        self.ndim = 1

    def __len__(self) -> int:
        return self.s1 - self.s0

    def medians(self, a: int, b: int, window: int) -> tuple[NDArray, NDArray]:
        """Raw samples ``[a, b)`` of the segment and their running median (exact)."""
        from scipy.ndimage import median_filter

        h = window // 2
        lo, hi = max(0, a - h), min(len(self), b + h)
        raw = np.asarray(self.src[self.s0 + lo:self.s0 + hi],  # type: ignore[index]
                         dtype=np.float64)
        med = median_filter(raw, size=window, mode="nearest")
        return raw[a - lo:a - lo + (b - a)], med[a - lo:a - lo + (b - a)]

    def __getitem__(self, key: slice) -> NDArray:
        if not isinstance(key, slice):
            raise IndexError("ChannelView reads slices")
        a, b, step = key.indices(len(self))
        if step != 1:
            raise IndexError("ChannelView reads contiguous slices only")
        if b <= a:
            return np.empty(0)
        if self.clip is not None:
            lim, window = self.clip
            y, med = self.medians(a, b, window)
            y = med + np.clip(y - med, -lim, lim)
        else:
            y = np.asarray(self.src[self.s0 + a:self.s0 + b],  # type: ignore[index]
                           dtype=np.float64)
        if self.line is not None:
            c0, c1, rate = self.line
            y = y - (c1 * (np.arange(a, b) / rate) + c0)
        return y

    def __array__(self, dtype: object = None, copy: object = None) -> NDArray:
        return self[0:len(self)]


@contextlib.contextmanager
def _phase_file(view: ChannelView, rate: float) -> Iterator[NDArray | None]:
    """The phase of a rate channel (mean removed) in a temporary memory-mapped file.

    What :func:`inertest.noise.identification.largest_event` builds in memory, written block
    by block (the running sum carried into each block as its first term, so that it adds in
    the same order); None past :data:`~inertest.noise.identification.EVENT_CHECK_MAX_SAMPLES`
    samples, where the in-memory analysis skips the check too. The file is removed on exit.
    """
    m = len(view)
    if m > EVENT_CHECK_MAX_SAMPLES:
        yield None
        return
    total = 0.0
    for a in range(0, m, BLOCK):
        total += float(np.sum(view[a:min(m, a + BLOCK)]))
    mean, tau0 = total / m, 1.0 / rate
    with tempfile.TemporaryDirectory(prefix="inertest-phase-") as tmp:
        x = np.lib.format.open_memmap(f"{tmp}/phase.npy", mode="w+", dtype=np.float64,
                                      shape=(m + 1,))
        x[0] = carry = 0.0
        for a in range(0, m, BLOCK):
            b = min(m, a + BLOCK)
            run = np.cumsum(np.r_[carry, (view[a:b] - mean) * tau0])
            x[a + 1:b + 1] = run[1:]
            carry = float(run[-1])
        x.flush()
        try:
            yield x
        finally:
            del x  # the map is closed before its file goes


def psd_welch_stream(y: ArrayLike, rate_hz: float, *, group: int | None = None
                     ) -> tuple[NDArray, NDArray]:
    """:func:`inertest.noise.imu.psd_welch` over a sliced array-like, in groups of segments.

    The mean of the same Hann-windowed, half-overlapping segment periodograms as
    ``scipy.signal.welch``, ``group`` segments at a time.
    """
    from scipy.signal import welch

    group = PSD_GROUP if group is None else group
    n = len(y)  # type: ignore[arg-type]
    k = int(math.floor(math.log2(max(n / 8.0, 16.0))))
    nper = min(1 << min(k, PSD_MAX_LOG2), n)
    step = nper - nper // 2
    segments = (n - nper) // step + 1
    total: NDArray | None = None
    f: NDArray | None = None
    for k0 in range(0, segments, group):
        k1 = min(segments, k0 + group)
        part = np.asarray(y[k0 * step:(k1 - 1) * step + nper], dtype=np.float64)  # type: ignore[index]
        f, p = welch(part, fs=rate_hz, window="hann", nperseg=nper, detrend="constant",
                     scaling="density", return_onesided=True)
        total = p * (k1 - k0) if total is None else total + p * (k1 - k0)
    assert total is not None and f is not None
    return f[1:], (total / segments)[1:]


def _line(y: ChannelView, rate: float) -> tuple[float, float]:
    """Least-squares ``c0 + c1 t`` of a view, ``t = k / rate``, from streamed centred sums."""
    m = len(y)
    tc = (m - 1) / 2.0 / rate  # mean of t
    sy, sty, stt = 0.0, 0.0, 0.0
    for a in range(0, m, BLOCK):
        v = y[a:min(m, a + BLOCK)]
        t = np.arange(a, a + v.size) / rate - tc
        sy += float(np.sum(v))
        sty += float(np.dot(t, v))
        stt += float(np.dot(t, t))
    c1 = sty / stt if stt > 0 else 0.0
    return sy / m - c1 * tc, c1


def analyse_imu_noise_stream(
    t: ArrayLike | None,
    channels: Sequence[ArrayLike],
    *,
    gyro_names: Sequence[str],
    accel_names: Sequence[str],
    rate_hz: float | None = None,
    gaps: str = "refuse",
    outliers: str = "keep",
    outlier_threshold: float = OUTLIER_THRESHOLD,
    detrend: bool = False,
    progress: StageProgress | None = None,
    time_unit: str | None = None,
) -> ImuNoiseResult:
    """:func:`inertest.noise.imu.analyse_imu_noise` on array-likes read in slices.

    Parameters
    ----------
    t : 1-D array-like [s] or None
        Time stamps (any origin).
    channels : sequence of 1-D array-likes
        The gyro channels [rad/s] (``len(gyro_names)`` of them), then the accelerometer
        channels [m/s^2].
    gyro_names, accel_names : sequence of str
        Channel names, one per channel.
    rate_hz, gaps, outliers, outlier_threshold, detrend, time_unit
        As :func:`inertest.noise.imu.analyse_imu_noise`.
    progress : callable, optional
        ``progress(stage, done, total)``: the stage (``"time stamps"``, ``"<channel>"``) and
        its work units.

    Returns
    -------
    ImuNoiseResult
        Equal to the in-memory analysis to rounding (module docstring).
    """
    if outliers not in OUTLIER_POLICIES:
        raise InputError(f"unknown outlier policy {outliers!r}; use one of "
                         f"{', '.join(OUTLIER_POLICIES)}")
    if not (math.isfinite(outlier_threshold) and outlier_threshold > 0):
        raise InputError(f"the outlier threshold must be a positive number of sigmas, "
                         f"got {outlier_threshold!r}")
    names = [*gyro_names, *accel_names]
    kinds = ["gyro"] * len(gyro_names) + ["accelerometer"] * len(accel_names)
    if len(names) != len(channels) or not channels:
        raise InputError(f"give one name per channel: {len(channels)} channels, names {names}")
    if len(set(names)) != len(names):
        raise InputError(f"give one distinct name per channel, got {names}")
    n = len(channels[0])  # type: ignore[arg-type]
    if any(len(c) != n for c in channels):  # type: ignore[arg-type]
        raise InputError("the channels have different lengths")
    if t is not None and len(t) != n:  # type: ignore[arg-type]
        raise InputError(f"{len(t)} time stamps for {n} samples; give one stamp per sample")  # type: ignore[arg-type]
    tick = progress or (lambda stage, done, total: None)
    tick("time stamps", 0, 1)
    timing = stream_time_stamps(t, n=n, rate_hz=rate_hz, gaps=gaps)
    tick("time stamps", 1, 1)
    s0, s1 = timing.segment
    if s1 - s0 < MIN_SAMPLES:
        raise DataError(f"the segment analysed has {s1 - s0} samples (from sample {s0}); the "
                        f"noise analysis needs at least {MIN_SAMPLES}: record longer")
    first_bad: tuple[int, int] | None = None  # (sample, channel): the first row, then column
    lows, highs = [math.inf] * len(channels), [-math.inf] * len(channels)
    for j, c in enumerate(channels):
        for a, v in _blocks(c, s0, s1):
            bad = np.flatnonzero(~np.isfinite(v))
            if bad.size:
                at = (a + int(bad[0]), j)
                first_bad = at if first_bad is None else min(first_bad, at)
                break
            lows[j], highs[j] = min(lows[j], float(v.min())), max(highs[j], float(v.max()))
    if first_bad is not None:
        raise DataError(f"channel {names[first_bad[1]]} has a missing or infinite value at "
                        f"sample {first_bad[0]}; remove the row or analyse a clean segment")
    for j in range(len(channels)):
        if lows[j] == highs[j]:  # no noise: nothing to fit (all deviations 0)
            raise DataError(f"channel {names[j]} is constant ({lows[j]:g} "
                            f"{_SI_RATE[kinds[j]]} in every sample): there is no noise to "
                            "analyse; check the recording, or leave the channel out with "
                            "--gyro-columns / --accel-columns")
    messages = timing_messages(timing, time_unit)
    rate = timing.rate_hz
    window = max(3, int(OUTLIER_WINDOW) | 1)
    views, counts = [], []
    for j, src in enumerate(channels):  # outliers of every channel first, as in memory
        view = ChannelView(src, s0, s1)
        m = len(view)
        tick(names[j], 0, 4)

        def residuals(view: ChannelView = view, m: int = m) -> Iterator[NDArray]:
            for a in range(0, m, BLOCK):
                y, med = view.medians(a, min(m, a + BLOCK), window)
                yield y - med

        center = exact_median(residuals, m)

        def deviations_from_center(
            c: float = center, r: Callable[[], Iterator[NDArray]] = residuals,
        ) -> Iterator[NDArray]:
            return (np.abs(v - c) for v in r())

        sigma = MAD_TO_SIGMA * exact_median(deviations_from_center, m)
        if sigma == 0.0:
            total = sum(float(np.sum(np.abs(v))) for v in residuals())
            sigma = math.sqrt(math.pi / 2.0) * total / m
        tick(names[j], 1, 4)
        count, first = 0, -1
        if sigma > 0.0:
            for a, v in zip(range(0, m, BLOCK), residuals(), strict=True):
                hit = np.flatnonzero(np.abs(v) > outlier_threshold * sigma)
                if hit.size and first < 0:
                    first = a + int(hit[0])
                count += int(hit.size)
        if count and outliers == "refuse":
            raise DataError(
                f"channel {names[j]}: {count} outlier(s) beyond {outlier_threshold:g} robust "
                f"sigmas ({outlier_threshold * sigma:.3g} {_SI_RATE[kinds[j]]}) of the running "
                f"median, the first at sample {s0 + first} (t = {first / rate:.6g} s into the "
                "segment); give --outliers clip to clip them, or --outliers keep to keep them")
        if count and outliers == "clip":
            view = ChannelView(src, s0, s1, clip=(outlier_threshold * sigma, window))
        if count:
            messages.append(f"{names[j]}: {count} outlier(s) beyond {outlier_threshold:g} "
                            f"robust sigmas, {'clipped' if outliers == 'clip' else 'kept'}")
        if detrend:
            c0, c1 = _line(view, rate)
            view = ChannelView(src, s0, s1, clip=view.clip, line=(c0, c1, rate))
        views.append(view)
        counts.append(count)
    result_channels = []
    for j, (view, count) in enumerate(zip(views, counts, strict=True)):
        tick(names[j], 2, 4)
        dev = deviations(view, rate, ("oadev",), "octave", "rate", stream=True)["oadev"]
        own: list[str] = []
        with warnings.catch_warnings(record=True) as caught, _phase_file(view, rate) as phase:
            warnings.simplefilter("always")
            model = identify_noise(dev, instrument=kinds[j], phase=phase)
        for w in caught:
            text = f"{names[j]}: {w.message}"
            if text not in own:
                own.append(text)
        tick(names[j], 3, 4)
        f, p = psd_welch_stream(view, rate)
        tick(names[j], 4, 4)
        result_channels.append(ChannelNoise(
            name=names[j], kind=kinds[j], unit=_SI_RATE[kinds[j]], oadev=dev, psd_freq_hz=f,
            psd=p, model=model, density=_kalibr_term(kinds[j], "N", model),
            random_walk=_kalibr_term(kinds[j], "K", model), outliers=count,
            messages=tuple(own)))
        messages.extend(m_ for m_ in own if m_ not in messages)
    return ImuNoiseResult(channels=tuple(result_channels), timing=timing, detrended=detrend,
                          outlier_policy=outliers, outlier_threshold=outlier_threshold,
                          messages=tuple(messages))
