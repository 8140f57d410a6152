"""The streamed whole-IMU noise analysis against the in-memory one; its exact medians; and its
memory, which does not grow with the record (a bag streamed from disk)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from inertest.errors import DataError
from inertest.io.raw_samples import SampleFile
from inertest.noise import imu_stream
from inertest.noise.imu import analyse_imu_noise
from inertest.noise.imu_stream import analyse_imu_noise_stream, exact_median


def _passes(x: np.ndarray, block: int):
    return lambda: (x[i:i + block] for i in range(0, x.size, block))


@pytest.mark.parametrize("n", [1, 2, 7, 1000, 4097])
def test_exact_median_is_numpys_median(n, monkeypatch):
    rng = np.random.default_rng(n)
    monkeypatch.setattr(imu_stream, "_SORT_CAP", 16)  # force several histogram levels
    monkeypatch.setattr(imu_stream, "_BINS", 8)
    cases = [rng.normal(size=n), np.round(rng.normal(size=n) * 3) / 3,  # heavy ties
             np.r_[rng.normal(size=n - 1), 1e300][:n],  # one huge outlier: a wide range
             np.full(n, 2.5), rng.integers(0, 3, n).astype(float)]
    for x in cases:
        assert exact_median(_passes(x, 97), x.size) == np.median(x)


def _record(n: int, seed: int, *, outliers: bool = False, gaps: bool = False):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.002 + 3.0
    if gaps:
        t[n // 3:] += 0.05  # one gap; the longest clean segment is the last two thirds
    g = rng.normal(0, 0.01, (n, 3)) + np.cumsum(rng.normal(0, 2e-5, (n, 3)), axis=0)
    a = rng.normal(0, 0.02, (n, 3)) + [0, 0, 9.81]
    if outliers:
        g[rng.integers(0, n, 25), 0] += 3.0
        a[rng.integers(0, n, 5), 2] -= 1.0
    return t, g, a


def _files(tmp_path, t, g, a):
    files = []
    for k, col in enumerate([t, *g.T, *a.T]):
        p = tmp_path / f"c{k}.f64"
        np.ascontiguousarray(col).tofile(p)
        files.append(SampleFile(p, np.dtype("<f8"), 0, col.size))
    return files[0], files[1:]


@pytest.mark.parametrize("options", [{}, {"outliers": "clip"}, {"detrend": True},
                                     {"gaps": "longest", "outliers": "clip", "detrend": True}])
def test_streamed_equals_in_memory_to_rounding(options, tmp_path, monkeypatch):
    monkeypatch.setattr(imu_stream, "BLOCK", 3000)  # many blocks, windows across their edges
    n = 20_000
    t, g, a = _record(n, 1, outliers=True, gaps="gaps" in options)
    names = dict(gyro_names=("gx", "gy", "gz"), accel_names=("ax", "ay", "az"))
    ref = analyse_imu_noise(t, g, a, **names, **options)
    ts, chans = _files(tmp_path, t, g, a)
    got = analyse_imu_noise_stream(ts, chans, **names, **options)
    assert got.timing.segment == ref.timing.segment
    assert got.timing.gaps == ref.timing.gaps and got.timing.n_samples == n
    assert got.timing.interval_s == ref.timing.interval_s  # the exact median interval
    assert got.timing.jitter_s == pytest.approx(ref.timing.jitter_s, rel=1e-9, abs=1e-18)
    assert got.messages == ref.messages  # the same outlier counts, gaps, fit verdicts
    for c, r in zip(got.channels, ref.channels, strict=True):
        assert c.outliers == r.outliers and c.messages == r.messages
        np.testing.assert_allclose(c.oadev.dev, r.oadev.dev, rtol=1e-11)
        np.testing.assert_allclose(c.psd, r.psd, rtol=1e-11)
        assert c.density.status == r.density.status
        assert c.density.value == pytest.approx(r.density.value, rel=1e-9)
        assert c.random_walk.value == pytest.approx(r.random_walk.value, rel=1e-9)


def test_streamed_errors_are_the_in_memory_ones(tmp_path):
    t, g, a = _record(3000, 2, outliers=True)
    ts, chans = _files(tmp_path, t, g, a)
    kw = dict(gyro_names=("gx", "gy", "gz"), accel_names=("ax", "ay", "az"))
    for options in ({"outliers": "refuse"},):
        with pytest.raises(DataError) as ref:
            analyse_imu_noise(t, g, a, **kw, **options)
        with pytest.raises(DataError) as got:
            analyse_imu_noise_stream(ts, chans, **kw, **options)
        assert str(got.value) == str(ref.value)
    t2, *_ = _record(3000, 2, gaps=True)
    ts2, _ = _files(tmp_path / "..", t2, g, a)
    with pytest.raises(DataError) as ref:
        analyse_imu_noise(t2, g, a, **kw)
    with pytest.raises(DataError) as got:
        analyse_imu_noise_stream(ts2, chans, **kw)
    assert str(got.value) == str(ref.value)


@pytest.mark.slow
def test_a_streamed_bag_keeps_its_memory_whatever_its_length(tmp_path, monkeypatch):
    """Bags of 2^17 and 2^19 Imu messages (4x longer), one gyro and one accelerometer channel,
    through ``open_imu`` (decoded once into temporary files) and the streamed analysis, in
    blocks of 2^14 samples: the peak of traced memory stays under 24 MB (the bag's seven
    columns are 29 MB at 2^19; the in-memory analysis of all six channels peaks at 60 MB) and
    grows by less than 6 MB from the short bag to the long one (the five-term fit's
    covariance basis, about 3 MB per octave of taus and the same in memory, is cached per
    grid before the traced run). (At the default blocks of 2^20 samples the bound is about
    0.2 GB plus that fit, whatever the length: ``benchmarks/bench_rosbag.py`` measures 1e8
    messages.)"""
    pytest.importorskip("rosbags")
    from inertest.io.recordings import ros_containers
    from inertest.io.recordings.imu import SpilledImu, open_imu
    from inertest.noise import deviations
    from recording_factory import fast_ros1_bag

    for module, name, value in ((imu_stream, "BLOCK", 1 << 14), (deviations, "CHUNK", 1 << 14),
                                (ros_containers, "BATCH_MESSAGES", 1 << 12),
                                (imu_stream, "PSD_MAX_LOG2", 12), (imu_stream, "PSD_GROUP", 2)):
        monkeypatch.setattr(module, name, value)
    peaks = {}
    two = {"gyro_columns": "angular_velocity.x", "accel_columns": "linear_acceleration.z"}
    for n in (1 << 17, 1 << 19):
        bag = fast_ros1_bag(tmp_path / f"{n}.bag", n, rate_hz=1000.0, chunk=1 << 12)
        # imports, numba and scipy caches, and the five-term fit's covariance basis of this
        # length's taus (cached per grid: 3 MB an octave, as in memory), before tracing
        with open_imu(bag, stream_from=0, **two) as rec:
            analyse_imu_noise_stream(rec.t, rec.channels, gyro_names=rec.gyro_names,
                                     accel_names=rec.accel_names)
        tracemalloc.start()
        with open_imu(bag, stream_from=0, **two) as rec:
            assert isinstance(rec, SpilledImu) and rec.n == n
            res = analyse_imu_noise_stream(rec.t, rec.channels, gyro_names=rec.gyro_names,
                                           accel_names=rec.accel_names)
        peaks[n] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        bag.unlink()
        assert res.timing.n_samples == n
        np.testing.assert_allclose([c.density.value for c in res.sensor("gyro")],
                                   0.01 / np.sqrt(1000.0), rtol=0.05)
    small, large = peaks[1 << 17], peaks[1 << 19]
    assert large < 24e6, peaks
    assert large - small < 6e6, peaks


def test_streamed_gaps_are_missing_samples_as_in_memory():
    """Issue 28 made a gap a missing sample (jitter is none); the streamed path, reading the
    stamps in blocks, finds the same gaps, counts and segment as the record in memory."""
    from inertest.noise.imu import check_time_stamps
    from inertest.noise.imu_stream import stream_time_stamps

    rng = np.random.default_rng(3)
    n = 60000
    for missing in (False, True):
        t = np.arange(n) * 0.01 + rng.uniform(-0.3, 0.3, n) * 0.01  # jitter, +-0.3 interval
        if missing:  # some gaps close to the block edges of 4096 stamps
            for k in (4095, 4097, 8192 + 20, 30000, 51000):
                t[k:] += 0.01 * rng.integers(1, 4)
        mem = check_time_stamps(t, gaps="longest")
        streamed = stream_time_stamps(t, n=n, gaps="longest", block=4096)
        assert [(g.index, g.missing) for g in streamed.gaps] == [
            (g.index, g.missing) for g in mem.gaps]
        assert len(mem.gaps) == (5 if missing else 0)
        assert streamed.segment == mem.segment
        assert streamed.jitter_s == pytest.approx(mem.jitter_s, rel=1e-9)
