"""Noise of a whole IMU: every gyro and accelerometer channel of one recording in one run.

:func:`analyse_imu_noise` takes the time stamps and the rates of up to three gyros [rad/s] and
three accelerometers [m/s^2] (SI, arrays in, no files) and returns a frozen
:class:`ImuNoiseResult`:

* **time-stamp checks** (:func:`check_time_stamps`): nominal interval, jitter (standard deviation
  of the intervals), gaps (an interval longer than :data:`GAP_FACTOR` nominal intervals) and
  duplicated or non-increasing stamps. The statistics assume equally spaced samples, so a record
  with gaps is refused (naming the first gap's time and length) unless the caller asks for the
  longest gap-free segment;
* **outliers** (:func:`find_outliers`): samples further than ``threshold`` robust standard
  deviations (1.4826 x the median absolute deviation) from a running median; counted, then
  refused, clipped to the threshold, or kept;
* optional removal of a straight line (least squares in time) from every channel;
* per channel: the overlapping Allan deviation with its confidence bounds (NIST SP 1065), the
  one-sided Welch power spectral density, and the five IEEE Std 952-1997 Annex C terms with their
  uncertainties and the fit verdict of :func:`inertest.noise.identification.identify_noise`;
* the continuous-time white-noise density and random walk of the Kalibr / OpenVINS IMU model
  (:class:`KalibrTerm`).

Conventions
-----------
PSD: one-sided, ``S1(f)`` in unit^2/Hz over ``0 <= f <= rate/2`` (``scipy.signal.welch``,
Hann window, ``scaling="density"``): the variance is the integral of ``S1`` over those
frequencies. IEEE Std 952-1997 Annex C writes the Allan variance as
``sigma^2(tau) = 4 int_0^inf S(f) sin^4(pi f tau) / (pi f tau)^2 df`` with the TWO-sided rate PSD
``S = S1 / 2``, so white rate noise of angle (velocity) random walk N has ``S = N^2``, i.e.
``S1 = 2 N^2`` and ``N = sqrt(S1 / 2)``; rate random walk K has ``S1(f) = 2 (K / 2 pi)^2 / f^2``.

Kalibr IMU noise model (Kalibr wiki "IMU Noise Model"): ``gyroscope_noise_density`` sigma_g
[rad/s/sqrt(Hz)] is the continuous-time white-noise density, the discrete standard deviation
being sigma_g / sqrt(dt); it equals the angle random walk N [rad/sqrt(s)] of IEEE 952 (the
deviation of the N/sqrt(tau) line at tau = 1 s). ``gyroscope_random_walk`` sigma_bg
[rad/s^2/sqrt(Hz)] drives the bias as a Wiener process; it equals the rate random walk K
[rad/s/sqrt(s)] (the K sqrt(tau/3) line at tau = 3 s). Likewise ``accelerometer_noise_density``
[m/s^2/sqrt(Hz)] = velocity random walk, ``accelerometer_random_walk`` [m/s^3/sqrt(Hz)] =
acceleration random walk. The bias instability B (the flat floor, 0.664 B) is NOT the random
walk; tools that write B there (imu_utils, allan_variance_ros) give filters a wrong bias model.

The Kalibr parameters are the IEEE 952 terms themselves, with no conversion factor:
rad/s^2/sqrt(Hz) = rad/s^2 x sqrt(s) = rad/s/sqrt(s) (K) and rad/s/sqrt(Hz) = rad/sqrt(s) (N).

A term the five-term fit resolves is exported with its standard uncertainty. A term it does not
resolve gets its upper bound instead, the one of the five-term block
(:func:`inertest.noise.identification.tangent_bounds`, ``NoiseTerm.upper_bound``): every noise
adds a non-negative Allan variance, so ``sigma(tau) >= N / sqrt(tau)`` and
``sigma(tau) >= K sqrt(tau / 3)`` at every tau, and ``N <= min sigma_hi(tau) sqrt(tau)``,
``K <= min sigma_hi(tau) sqrt(3 / tau)`` over all measured taus, ``sigma_hi`` the one-sided
upper confidence limits holding jointly with 95 % (the -1/2 and +1/2 slope lines tangent to
them from below). It is marked as a bound, with its definition.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import NoReturn

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import DataError, InputError
from inertest.noise.deviations import DeviationResult, deviations
from inertest.noise.identification import BOUND_DEFINITION, NoiseModel, identify_noise

#: An interval longer than this many nominal intervals is a candidate gap; it is a gap only
#: where samples are missing (:func:`missing_samples`), not where the stamps jitter.
GAP_FACTOR = 1.5
#: Stamps on either side of a candidate gap whose median position on the sample grid is
#: compared (:func:`missing_samples`).
GAP_WINDOW = 16
#: Plausible sample rates of an IMU [Hz]; outside, the time unit is probably wrong.
PLAUSIBLE_RATE_HZ = (1.0, 1e5)
#: Default outlier threshold [robust standard deviations from the running median].
OUTLIER_THRESHOLD = 10.0
#: Window of the running median the outliers are measured from [samples, odd].
OUTLIER_WINDOW = 51
#: 1 / Phi^-1(3/4): the median absolute deviation of a Gaussian times this is its sigma.
MAD_TO_SIGMA = 1.482602218505602
#: Fewest samples analysed (the Allan variance at a few octaves, the five-term fit).
MIN_SAMPLES = 64
#: Two-sided agreement of a claimed value with a resolved term: within this many standard
#: deviations (``TermComparison.consistency``).
AGREE_SIGMA = 2.0
#: One-sided test of a claimed maximum: a resolved term exceeds the claim when it is above it
#: by more than this many standard deviations (95 %, the level of the upper bounds).
CLAIM_SIGMA = 1.645
#: Relative rounding of a claim written with 10 significant digits (a Kalibr yaml of this tool):
#: a bound equal to the claim to that precision is at the claim.
_CLAIM_DIGITS = 1e-9
GAP_POLICIES = ("refuse", "longest")
OUTLIER_POLICIES = ("keep", "refuse", "clip")
KINDS = ("gyro", "accelerometer")
_KALIBR_UNITS = {
    ("gyro", "N"): "rad/s/sqrt(Hz)",
    ("gyro", "K"): "rad/s^2/sqrt(Hz)",
    ("accelerometer", "N"): "m/s^2/sqrt(Hz)",
    ("accelerometer", "K"): "m/s^3/sqrt(Hz)",
}
_SI_RATE = {"gyro": "rad/s", "accelerometer": "m/s^2"}


@dataclass(frozen=True)
class Gap:
    """One break in the time stamps: the interval before sample ``index``.

    ``time_s`` is the stamp before the break, relative to the first stamp [s]; ``length_s`` the
    interval [s] (zero or negative for duplicated or non-increasing stamps); ``missing`` the
    samples missing there (gaps).
    """

    index: int
    time_s: float
    length_s: float
    missing: int = 0

    def to_dict(self) -> dict[str, float | int]:
        """JSON-ready mapping."""
        out: dict[str, float | int] = {"index": self.index, "time_s": self.time_s,
                                       "length_s": self.length_s}
        if self.missing:
            out["missing_samples"] = self.missing
        return out


@dataclass(frozen=True)
class TimingReport:
    """Time-stamp checks of a recording and the segment analysed.

    Attributes
    ----------
    n_samples : int
        Samples in the recording.
    interval_s : float
        Nominal sample interval [s] (given rate, or the median positive interval).
    jitter_s : float
        Standard deviation of the intervals within the analysed segment [s].
    gaps : tuple of Gap
        Missing samples (:func:`missing_samples`): intervals where the stamps move on by one
        or more sample intervals more than one; jitter is not a gap.
    non_increasing : tuple of Gap
        Duplicated (zero) or backward (negative) intervals.
    segment : (int, int)
        ``[start, stop)`` of the samples analysed.
    from_stamps : bool
        False when the recording has no time stamps (equal spacing at the given rate assumed).
    """

    n_samples: int
    interval_s: float
    jitter_s: float
    gaps: tuple[Gap, ...]
    non_increasing: tuple[Gap, ...]
    segment: tuple[int, int]
    from_stamps: bool = True

    @property
    def rate_hz(self) -> float:
        """Nominal sample rate [Hz]."""
        return 1.0 / self.interval_s

    def to_dict(self) -> dict[str, object]:
        """JSON-ready mapping (units in the names)."""
        return {
            "n_samples": self.n_samples,
            "interval_s": self.interval_s,
            "rate_hz": self.rate_hz,
            "jitter_s": self.jitter_s,
            "gaps": [g.to_dict() for g in self.gaps],
            "non_increasing": [g.to_dict() for g in self.non_increasing],
            "segment": list(self.segment),
            "from_stamps": self.from_stamps,
        }


@dataclass(frozen=True)
class KalibrTerm:
    """One continuous-time parameter of the Kalibr IMU model for one channel.

    ``value`` [``unit``] is the fitted IEEE 952 term (``status == "fitted"``, ``std`` its
    standard uncertainty, ``tau_s`` 1 s for N and 3 s for K where its line reads it) or its
    upper bound (``status == "bound"``, ``std`` None: the true value is at most this; ``tau_s``
    where the bound's line touches the upper confidence limits). ``bound_95`` is the five-term
    block's ``upper_bound`` of the same term (:data:`BOUND_DEFINITION`: tangent line to the
    one-sided upper confidence limits over all measured taus, jointly 95 %; for a fitted term
    never below ``value + 1.645 std``), so ``value == bound_95`` for a bound. The Kalibr unit
    equals the IEEE 952 SI unit (module docstring): no conversion.
    """

    #: How ``bound_95`` is defined (written into the JSON beside it).
    BOUND_DEFINITION = BOUND_DEFINITION

    parameter: str  # "noise_density" or "random_walk"
    term: str  # "N" or "K"
    status: str
    value: float
    std: float | None
    tau_s: float
    bound_95: float
    unit: str

    def to_dict(self) -> dict[str, object]:
        """JSON-ready mapping."""
        return {"parameter": self.parameter, "term": self.term, "status": self.status,
                "value": self.value, "std": self.std, "tau_s": self.tau_s,
                "bound_95": self.bound_95, "bound_definition": self.BOUND_DEFINITION,
                "unit": self.unit}


@dataclass(frozen=True)
class ChannelNoise:
    """Noise analysis of one channel (SI: rad/s for gyros, m/s^2 for accelerometers)."""

    name: str
    kind: str
    unit: str
    oadev: DeviationResult
    psd_freq_hz: NDArray
    psd: NDArray  # one-sided [unit^2/Hz]
    model: NoiseModel
    density: KalibrTerm
    random_walk: KalibrTerm
    outliers: int
    messages: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, object]:
        """JSON-ready mapping."""
        return {
            "name": self.name, "kind": self.kind, "unit": self.unit,
            "oadev": self.oadev.to_dict(),
            "psd": {"freq_hz": self.psd_freq_hz.tolist(), "value": self.psd.tolist(),
                    "unit": f"({self.unit})^2/Hz", "sided": "one"},
            "noise_terms": self.model.to_dict(),
            "kalibr": {"noise_density": self.density.to_dict(),
                       "random_walk": self.random_walk.to_dict()},
            "outliers": self.outliers,
            "messages": list(self.messages),
        }


@dataclass(frozen=True)
class ImuNoiseResult:
    """Result of :func:`analyse_imu_noise`."""

    channels: tuple[ChannelNoise, ...]
    timing: TimingReport
    detrended: bool
    outlier_policy: str
    outlier_threshold: float
    messages: tuple[str, ...] = field(default=())

    @property
    def rate_hz(self) -> float:
        """Sample rate of the analysed segment [Hz]."""
        return self.timing.rate_hz

    @property
    def duration_s(self) -> float:
        """Length of the analysed segment [s]."""
        a, b = self.timing.segment
        return (b - a) * self.timing.interval_s

    def sensor(self, kind: str) -> tuple[ChannelNoise, ...]:
        """The channels of one kind (``"gyro"`` or ``"accelerometer"``)."""
        return tuple(c for c in self.channels if c.kind == kind)

    def kalibr(self, kind: str) -> dict[str, KalibrTerm] | None:
        """Kalibr parameters of one sensor: the largest over its axes (conservative), or None."""
        chans = self.sensor(kind)
        if not chans:
            return None
        return {p: max((getattr(c, attr) for c in chans), key=lambda t: t.value)
                for p, attr in (("noise_density", "density"), ("random_walk", "random_walk"))}

    def to_dict(self) -> dict[str, object]:
        """JSON-ready mapping."""
        return {
            "rate_hz": self.rate_hz,
            "duration_s": self.duration_s,
            "timing": self.timing.to_dict(),
            "detrended": self.detrended,
            "outliers": {"policy": self.outlier_policy, "threshold_sigma": self.outlier_threshold},
            "channels": {c.name: c.to_dict() for c in self.channels},
            "messages": list(self.messages),
        }


# ------------------------------------------------------------------------------ time stamps



def timing_messages(timing: TimingReport, time_unit: str | None) -> list[str]:
    """The notes on the time stamps: the segment kept, jitter, an implausible rate.

    The in-memory and the streamed analysis give the same notes.
    """
    s0, s1 = timing.segment
    messages: list[str] = []
    if timing.gaps or timing.non_increasing:
        messages.append(
            f"time stamps: {len(timing.gaps)} gap(s), {len(timing.non_increasing)} "
            f"duplicated/non-increasing; analysed the longest clean segment, samples {s0} to "
            f"{s1 - 1} ({(s1 - s0) * timing.interval_s:.6g} s)")
    if timing.jitter_s > 0.1 * timing.interval_s:
        messages.append(f"time-stamp jitter {timing.jitter_s:.3g} s is more than 10 % of the "
                        f"interval {timing.interval_s:.3g} s; the statistics assume equal "
                        "spacing")
    implausible = rate_plausibility(timing.rate_hz, time_unit) if timing.from_stamps else None
    if implausible:
        messages.append(implausible)
    return messages


def nominal_interval(median: float, rate_hz: float | None) -> float:
    """The sample interval [s]: ``1 / rate_hz`` if given, else the stamps' median interval.

    A given rate must agree with the stamps' median within 5 %.
    """
    if rate_hz is None:
        return median
    interval = 1.0 / rate_hz
    if abs(median / interval - 1.0) > 0.05:
        raise DataError(f"the time stamps say {1.0 / median:.6g} Hz (median interval "
                        f"{median:.6g} s) but the rate given is {rate_hz:g} Hz; fix --rate "
                        "or the time unit")
    return interval


def refuse_gaps(non_inc: Sequence[Gap], gap_list: Sequence[Gap], interval: float) -> NoReturn:
    """Stop on the first non-increasing stamp, else the first gap, naming the fix.

    The in-memory and the streamed analysis give the same message.
    """
    if non_inc:
        g = non_inc[0]
        what = "duplicated" if g.length_s == 0 else "non-increasing"
        raise DataError(
            f"{len(non_inc)} {what} time stamp(s), the first at t = {g.time_s:.6g} s "
            f"(sample {g.index}, interval {g.length_s:.3g} s); remove duplicated rows, or "
            "give --gaps longest to analyse the longest clean segment")
    g = gap_list[0]
    raise DataError(
        f"{len(gap_list)} gap(s) in the time stamps, the first at t = {g.time_s:.6g} s: "
        f"{g.length_s:.6g} s instead of {interval:.6g} s (sample {g.index}, {g.missing} "
        "sample(s) missing); the Allan "
        "deviation needs equal spacing: give --gaps longest to analyse the longest gap-free "
        "segment")

def check_time_stamps(
    t: ArrayLike | None, *, n: int | None = None, rate_hz: float | None = None,
    gaps: str = "refuse",
) -> TimingReport:
    """Check the time stamps of a recording and choose the segment to analyse.

    Parameters
    ----------
    t : (n,) array [s] or None
        Time stamps; None: equally spaced at ``rate_hz`` (``n`` samples).
    n : int, optional
        Number of samples when ``t`` is None.
    rate_hz : float, optional
        Nominal sample rate [Hz]; default the median positive interval of ``t``.
    gaps : {"refuse", "longest"}
        With gaps or non-increasing stamps: raise :class:`DataError` naming the first one, or
        analyse the longest segment free of them.
    """
    if gaps not in GAP_POLICIES:
        raise InputError(f"unknown gap policy {gaps!r}; use one of {', '.join(GAP_POLICIES)}")
    if rate_hz is not None and not (math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"the sample rate must be a positive number of Hz, got {rate_hz!r}")
    if t is None:
        if n is None or rate_hz is None:
            raise InputError("a recording without time stamps needs its sample rate; give it")
        return TimingReport(n, 1.0 / rate_hz, 0.0, (), (), (0, n), from_stamps=False)
    ts = np.asarray(t, dtype=float)
    if ts.ndim != 1 or ts.size < 2:
        raise DataError("the time stamps must be one column of at least 2 values")
    if not np.all(np.isfinite(ts)):
        i = int(np.flatnonzero(~np.isfinite(ts))[0])
        raise DataError(f"time stamp {i} is {ts[i]}; remove the row or fill in its time")
    dt = np.diff(ts)
    pos = dt[dt > 0]
    if pos.size == 0:
        raise DataError("the time stamps never increase; check the time column and its unit")
    median = float(np.median(pos))
    interval = nominal_interval(median, rate_hz)
    t0 = ts[0]
    bad = np.flatnonzero(dt <= 0)
    miss = missing_samples(ts, median)
    big = np.flatnonzero(miss > 0)
    non_inc = tuple(Gap(int(i) + 1, float(ts[i] - t0), float(dt[i])) for i in bad)
    gap_list = tuple(Gap(int(i) + 1, float(ts[i] - t0), float(dt[i]), int(miss[i]))
                     for i in big)
    cuts = np.union1d(bad, big) + 1
    edges = np.r_[0, cuts, ts.size]
    if cuts.size and gaps == "refuse":
        refuse_gaps(non_inc, gap_list, interval)
    k = int(np.argmax(np.diff(edges)))
    seg = (int(edges[k]), int(edges[k + 1]))
    inside = dt[seg[0]:seg[1] - 1]
    jitter = float(np.std(inside)) if inside.size > 1 else 0.0
    return TimingReport(int(ts.size), interval, jitter, gap_list, non_inc, seg)


def missing_samples(t: ArrayLike, interval: float) -> NDArray:
    """Samples missing in each interval of the time stamps ``t`` [s] (``len(t) - 1`` counts).

    Parameters
    ----------
    t : (n,) array [s]
        Time stamps, increasing apart from the stamps :func:`check_time_stamps` refuses.
    interval : float
        Sample interval [s] (the median positive interval of the stamps).

    Notes
    -----
    A missing sample moves every later stamp one interval along the sample grid; jitter moves
    single stamps and comes back. Each stamp's position on the grid, ``u_i = (t_i - t_0) /
    interval - i``, is flat between gaps and jumps by the number of samples missing at one.
    Where an interval exceeds :data:`GAP_FACTOR` intervals, the medians of ``u`` over up to
    :data:`GAP_WINDOW` stamps before and after it are compared: their difference, rounded, is
    the count (0: jitter); then again with windows that stop at the gaps so found. Stamps
    jittered by +-0.3 intervals have 1.4 % of their intervals above 1.5 intervals and no
    missing sample.
    """
    ts = np.asarray(t, dtype=float)
    dt = np.diff(ts)
    out = np.zeros(dt.size, dtype=np.int64)
    cand = np.flatnonzero(dt > GAP_FACTOR * interval)
    if cand.size:
        u = (ts - ts[0]) / interval - np.arange(ts.size)
        first = _level_jumps(u, cand, cand[:0])  # medians: a few shifted stamps do not count
        out[cand] = _level_jumps(u, cand, cand[first > 0])  # then not across a gap found
    return out


def _level_jumps(u: NDArray, cand: NDArray, bounds: NDArray) -> NDArray:
    """Rounded jumps of the median grid position ``u`` across each interval of ``cand``.

    The windows (up to :data:`GAP_WINDOW` stamps each side) stop at the intervals ``bounds``
    (sorted), so that no window spans another gap.
    """
    out = np.zeros(cand.size, dtype=np.int64)
    for k, c in enumerate(int(v) for v in cand):
        j = int(np.searchsorted(bounds, c))  # the first bound at or after c
        prev = int(bounds[j - 1]) if j > 0 else -1
        nj = j + 1 if j < bounds.size and bounds[j] == c else j
        nxt = int(bounds[nj]) if nj < bounds.size else u.size - 1
        lo, hi = max(prev + 1, c + 1 - GAP_WINDOW), min(nxt + 1, c + 1 + GAP_WINDOW)
        jump = float(np.median(u[c + 1 : hi]) - np.median(u[lo : c + 1]))
        out[k] = max(0, int(round(jump)))
    return out


def rate_plausibility(rate_hz: float, time_unit: str | None = None) -> str | None:
    """A warning when a sample rate from time stamps is not that of an IMU, else None.

    Outside :data:`PLAUSIBLE_RATE_HZ` (1 Hz - 100 kHz) the time stamps are probably in another
    unit than they were read in (``time_unit``: "s", "ms", "us" or "ns"): the message names the
    unit that gives the most ordinary rate (closest to 300 Hz on a log scale) among those
    inside the range.
    """
    lo, hi = PLAUSIBLE_RATE_HZ
    if lo <= rate_hz <= hi or not math.isfinite(rate_hz):
        return None
    text = (f"the time stamps give {rate_hz:.3g} Hz, outside the {lo:g} Hz - {hi:g} Hz of an "
            "IMU")
    scale = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
    if time_unit not in scale:
        return text + "; check the unit of the time column"
    options = [(abs(math.log(rate_hz * scale[time_unit] / v / 300.0)), u,
                rate_hz * scale[time_unit] / v) for u, v in scale.items()
               if u != time_unit and lo <= rate_hz * scale[time_unit] / v <= hi]
    if not options:
        return text + f" (stamps read in {time_unit}); check the unit of the time column"
    _, unit, rate = min(options)
    return (text + f": stamps in {unit} read as {time_unit}? Read in {unit} they give "
            f"{rate:.6g} Hz: give --time-unit {unit}")


# ------------------------------------------------------------------------------ outliers


def find_outliers(y: ArrayLike, *, threshold: float = OUTLIER_THRESHOLD,
                  window: int = OUTLIER_WINDOW) -> tuple[NDArray, NDArray, float]:
    """Samples further than ``threshold`` robust sigmas from the running median.

    Parameters
    ----------
    y : (n,) array
        One channel.
    threshold : float
        Threshold in robust standard deviations.
    window : int
        Running-median window [samples] (made odd).

    Returns
    -------
    mask : (n,) bool
        True at the outliers.
    median : (n,) array
        The running median.
    sigma : float
        Robust standard deviation of ``y - median``: 1.4826 x its median absolute deviation
        (mean absolute deviation x sqrt(pi/2) when that is zero, as for coarsely quantized data).
    """
    from scipy.ndimage import median_filter

    if not (math.isfinite(threshold) and threshold > 0):
        raise InputError(f"the outlier threshold must be a positive number of sigmas, "
                         f"got {threshold!r}")
    a = np.asarray(y, dtype=float)
    w = max(3, int(window) | 1)
    med = median_filter(a, size=w, mode="nearest")
    r = a - med
    sigma = MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r))))
    if sigma == 0.0:
        sigma = math.sqrt(math.pi / 2.0) * float(np.mean(np.abs(r)))
    if sigma == 0.0:
        return np.zeros(a.size, dtype=bool), med, 0.0
    return np.abs(r) > threshold * sigma, med, sigma


# ------------------------------------------------------------------------------ per channel


def psd_welch(y: ArrayLike, rate_hz: float) -> tuple[NDArray, NDArray]:
    """One-sided Welch PSD [unit^2/Hz] of a rate record (Hann window, half overlap).

    Segments of ``2**k`` samples, the longest giving at least 8 segments (at most 2**16), so the
    low end reaches about rate/(2**k) Hz with a usable variance. The zero frequency is dropped.
    White rate noise of random walk N has the level ``2 N^2`` (module docstring).
    """
    from scipy.signal import welch

    a = np.asarray(y, dtype=float)
    k = int(math.floor(math.log2(max(a.size / 8.0, 16.0))))
    nper = min(1 << min(k, 16), a.size)
    f, p = welch(a, fs=rate_hz, window="hann", nperseg=nper, detrend="constant",
                 scaling="density", return_onesided=True)
    return f[1:], p[1:]


def _kalibr_term(kind: str, term: str, model: NoiseModel) -> KalibrTerm:
    """The five-term block's term: fitted value with its std, or its upper bound.

    Kalibr's rad/s/sqrt(Hz) and rad/s^2/sqrt(Hz) are IEEE 952's rad/sqrt(s) and rad/s/sqrt(s)
    (m/s likewise): the SI numbers are taken as they are.
    """
    nt = model.terms[term]
    parameter = "noise_density" if term == "N" else "random_walk"
    unit = _KALIBR_UNITS[(kind, term)]
    if nt.resolved and nt.value is not None:
        tau = 1.0 if term == "N" else 3.0
        return KalibrTerm(parameter, term, "fitted", nt.value, nt.std, tau, nt.upper_bound, unit)
    return KalibrTerm(parameter, term, "bound", nt.upper_bound, None, nt.bound_tau,
                      nt.upper_bound, unit)


def _channel(name: str, kind: str, y: NDArray, rate_hz: float, outliers: int,
             messages: list[str]) -> ChannelNoise:
    dev = deviations(y, rate_hz, ("oadev",), "octave", "rate")["oadev"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = identify_noise(dev, instrument=kind, data=y)
    for w in caught:
        text = f"{name}: {w.message}"
        if text not in messages:
            messages.append(text)
    f, p = psd_welch(y, rate_hz)
    return ChannelNoise(name=name, kind=kind, unit=_SI_RATE[kind], oadev=dev, psd_freq_hz=f,
                        psd=p, model=model, density=_kalibr_term(kind, "N", model),
                        random_walk=_kalibr_term(kind, "K", model), outliers=outliers,
                        messages=tuple(messages))


def _as_matrix(a: ArrayLike | None, what: str, n: int | None) -> NDArray:
    if a is None:
        return np.empty((n or 0, 0))
    m = np.asarray(a, dtype=float)
    if m.ndim == 1:
        m = m[:, None]
    if m.ndim != 2 or m.shape[1] > 3:
        raise InputError(f"{what} must have shape (n, 1..3) [one column per axis], "
                         f"got {m.shape}")
    return m


def analyse_imu_noise(
    t: ArrayLike | None,
    gyro: ArrayLike | None = None,
    accel: ArrayLike | None = None,
    *,
    gyro_names: Sequence[str] = ("gyro_x", "gyro_y", "gyro_z"),
    accel_names: Sequence[str] = ("accel_x", "accel_y", "accel_z"),
    rate_hz: float | None = None,
    gaps: str = "refuse",
    outliers: str = "keep",
    outlier_threshold: float = OUTLIER_THRESHOLD,
    detrend: bool = False,
    time_unit: str | None = None,
) -> ImuNoiseResult:
    """Allan deviation, PSD, IEEE 952 terms and Kalibr parameters of every IMU channel.

    Parameters
    ----------
    t : (n,) array [s] or None
        Time stamps (any origin); None: equally spaced at ``rate_hz``.
    gyro : (n, k) array [rad/s], optional
        Angular rates, k = 1..3 axes.
    accel : (n, k) array [m/s^2], optional
        Specific forces, k = 1..3 axes.
    gyro_names, accel_names : sequence of str
        Channel names.
    rate_hz : float, optional
        Nominal sample rate [Hz]; required without time stamps, else checked against them.
    gaps : {"refuse", "longest"}
        See :func:`check_time_stamps`.
    outliers : {"keep", "refuse", "clip"}
        With outliers (:func:`find_outliers`): keep them (counted, with a message: real motion
        and quantization give heavy tails too), raise :class:`DataError` naming the count and
        the first one, or clip them to ``outlier_threshold`` robust sigmas from the running
        median.
    outlier_threshold : float
        [robust standard deviations].
    detrend : bool
        Remove a least-squares straight line in time from each channel first. This removes a
        rate ramp R and lowers the Allan deviation at the longest taus (where K shows).
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit the time stamps were read in: named in the warning when the rate they give is
        not an IMU's (:func:`rate_plausibility`).

    Returns
    -------
    ImuNoiseResult

    Notes
    -----
    IEEE Std 952-1997 Annex C (Allan variance, five terms), IEEE Std 1554-2005 (inertial
    sensor test practice: Allan variance and PSD), NIST SP 1065 (overlapping Allan deviation and
    its confidence intervals), Kalibr wiki "IMU Noise Model" (continuous-time parameters).
    """
    if outliers not in OUTLIER_POLICIES:
        raise InputError(f"unknown outlier policy {outliers!r}; use one of "
                         f"{', '.join(OUTLIER_POLICIES)}")
    n_t = None if t is None else int(np.asarray(t).shape[0])
    rows = [int(np.shape(x)[0]) for x in (gyro, accel) if x is not None and np.ndim(x) > 0]
    n_rows = rows[0] if rows else n_t
    g = _as_matrix(gyro, "gyro", n_rows)
    a = _as_matrix(accel, "accel", n_rows)
    if g.shape[1] + a.shape[1] == 0:
        raise InputError("no channel to analyse: give gyro and/or accelerometer columns")
    n = max(g.shape[0], a.shape[0])
    for m, what in ((g, "gyro"), (a, "accelerometer")):
        if m.shape[1] and m.shape[0] != n:
            raise InputError(f"the {what} columns have {m.shape[0]} rows, the others {n}")
    if n_t is not None and n_t != n:
        raise InputError(f"{n_t} time stamps for {n} samples; give one stamp per sample")
    names = [*gyro_names[: g.shape[1]], *accel_names[: a.shape[1]]]
    kinds = ["gyro"] * g.shape[1] + ["accelerometer"] * a.shape[1]
    if len(names) != len(kinds) or len(set(names)) != len(names):
        raise InputError(f"give one distinct name per channel, got {names}")
    data = np.hstack([g, a])
    timing = check_time_stamps(t, n=n, rate_hz=rate_hz, gaps=gaps)
    s0, s1 = timing.segment
    if s1 - s0 < MIN_SAMPLES:
        raise DataError(f"the segment analysed has {s1 - s0} samples (from sample {s0}); the "
                        f"noise analysis needs at least {MIN_SAMPLES}: record longer")
    data = data[s0:s1]
    bad = ~np.isfinite(data)
    if bad.any():
        r, c = (int(v[0]) for v in np.nonzero(bad))
        raise DataError(f"channel {names[c]} has a missing or infinite value at sample "
                        f"{s0 + r}; remove the row or analyse a clean segment")
    messages = timing_messages(timing, time_unit)
    rate = timing.rate_hz
    tt = np.arange(s1 - s0) / rate
    counts = []
    for j in range(data.shape[1]):
        mask, med, sigma = find_outliers(data[:, j], threshold=outlier_threshold)
        count = int(mask.sum())
        counts.append(count)
        if count and outliers == "refuse":
            i = int(np.flatnonzero(mask)[0])
            raise DataError(
                f"channel {names[j]}: {count} outlier(s) beyond {outlier_threshold:g} robust "
                f"sigmas ({outlier_threshold * sigma:.3g} {_SI_RATE[kinds[j]]}) of the running "
                f"median, the first at sample {s0 + i} (t = {i / rate:.6g} s into the segment); "
                "give --outliers clip to clip them, or --outliers keep to keep them")
        if count and outliers == "clip":
            lim = outlier_threshold * sigma
            data[:, j] = med + np.clip(data[:, j] - med, -lim, lim)
        if count:
            messages.append(f"{names[j]}: {count} outlier(s) beyond {outlier_threshold:g} "
                            f"robust sigmas, {'clipped' if outliers == 'clip' else 'kept'}")
        if detrend:
            coef = np.polyfit(tt, data[:, j], 1)
            data[:, j] = data[:, j] - np.polyval(coef, tt)
    channels = []
    for j in range(data.shape[1]):
        own: list[str] = []
        channels.append(_channel(names[j], kinds[j], data[:, j], rate, counts[j], own))
        messages.extend(m for m in own if m not in messages)
    return ImuNoiseResult(channels=tuple(channels), timing=timing, detrended=detrend,
                          outlier_policy=outliers, outlier_threshold=outlier_threshold,
                          messages=tuple(messages))


# ------------------------------------------------------------------------------ comparison


@dataclass(frozen=True)
class TermComparison:
    """A claimed Kalibr parameter (datasheet, another tool) against one measured channel.

    Two answers, as a lab reads a datasheet (:func:`compare_kalibr`):

    ``verdict``, one-sided, the claim read as a maximum: ``"meets the claim"`` (the channel is
    not worse than claimed beyond its uncertainty: fitted ``value - 1.645 std <= claimed``, or
    its 95 % upper bound at or below the claim), ``"exceeds the claim"`` (fitted and worse
    than claimed by more than 1.645 std, one-sided 95 %), or ``"not shown"`` (the term is
    not resolved and its 95 % upper bound lies above the claim: the record cannot tell).

    ``consistency``, two-sided, the claim read as a Kalibr yaml value (the largest over the
    sensor's axes): ``"consistent with"`` or ``"inconsistent with"``: a fitted channel above
    the claim by more than :data:`AGREE_SIGMA` std contradicts it; on the channel that can be
    largest (highest upper limit: ``value + 2 std``, or the bound) so does a claim above that
    limit, or a fitted channel more than 2 std above the claim.
    """

    channel: str
    parameter: str
    claimed: float
    measured: KalibrTerm
    verdict: str
    text: str
    consistency: str = ""

    def to_dict(self) -> dict[str, object]:
        """JSON-ready mapping."""
        return {"channel": self.channel, "parameter": self.parameter, "claimed": self.claimed,
                "measured": self.measured.to_dict(), "verdict": self.verdict,
                "consistency": self.consistency, "text": self.text}


def compare_kalibr(result: ImuNoiseResult,
                   claimed: Mapping[str, float | None]) -> tuple[TermComparison, ...]:
    """Compare claimed Kalibr parameters with every channel of the record.

    Parameters
    ----------
    result : ImuNoiseResult
    claimed : mapping
        ``{"gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
        "accelerometer_random_walk"}`` in the Kalibr units (SI per sqrt(Hz)); None or missing
        entries are skipped.

    Returns
    -------
    tuple of TermComparison
        One per claimed parameter and channel of its sensor: the one-sided verdict (does the
        channel meet the claim, read as a maximum: a datasheet) and the two-sided consistency
        (is the claim, read as the largest over the axes like a Kalibr yaml, what this record
        says). A record's own yaml, read back, is consistent on every row; a datasheet worse
        than the record meets it on every row.
    """
    out = []
    for key, value in claimed.items():
        if value is None:
            continue
        sensor, _, parameter = key.partition("_")
        kind = {"gyroscope": "gyro", "accelerometer": "accelerometer"}.get(sensor)
        if kind is None or parameter not in ("noise_density", "random_walk"):
            continue
        chans = result.sensor(kind)
        terms = [c.density if parameter == "noise_density" else c.random_walk for c in chans]
        fitted = [m.status == "fitted" and m.std is not None for m in terms]
        upper = [m.value + AGREE_SIGMA * (m.std or 0.0) if f else m.bound_95
                 for m, f in zip(terms, fitted, strict=True)]
        top = int(np.argmax(upper)) if upper else 0
        for i, (c, m) in enumerate(zip(chans, terms, strict=True)):
            out.append(_compare_one(c.name, key, float(value), m, fitted[i],
                                    top=(i == top), upper=upper[i]))
    return tuple(out)


def _compare_one(channel: str, key: str, value: float, m: KalibrTerm, fitted: bool, *,
                 top: bool, upper: float) -> TermComparison:
    """One row of :func:`compare_kalibr`."""
    z1 = CLAIM_SIGMA
    if fitted and m.std is not None:
        z = (m.value - value) / m.std if m.std > 0 else math.copysign(math.inf, m.value - value)
        verdict = "exceeds the claim" if z > z1 else "meets the claim"
        above = z > AGREE_SIGMA
        measured = f"measured {m.value:.4g} +/- {m.std:.2g} {m.unit} ({z:+.2g} sigma from it)"
    else:
        verdict = "meets the claim" if m.bound_95 <= value * (1.0 + _CLAIM_DIGITS) else "not shown"
        above = False
        measured = (f"not resolved, 95 % upper bound {m.bound_95:.4g} {m.unit} (tangent at "
                    f"tau = {m.tau_s:.4g} s)")
    consistent = not above and not (top and value > upper * (1.0 + _CLAIM_DIGITS))
    consistency = "consistent with" if consistent else "inconsistent with"
    why = {"meets the claim": ("not worse than claimed beyond its uncertainty" if fitted else
                               "its bound is at or below the claim"),
           "exceeds the claim": f"worse than claimed by more than {z1:g} sigma (one-sided 95 %)",
           "not shown": "its bound lies above the claim: the record cannot tell"}[verdict]
    if consistent:
        how = "consistent with it as the largest over the axes"
    elif above:
        how = f"inconsistent: more than {AGREE_SIGMA:g} sigma above it"
    else:
        how = (f"inconsistent: the claim is above {upper:.4g}, the most this record allows on "
               "any axis")
    text = f"claimed {value:.4g}, {measured}: {verdict} ({why}); {how}"
    return TermComparison(channel, key, value, m, verdict, text, consistency)
