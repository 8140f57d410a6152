"""ROS bags (issue 30): reading speed against rosbags' own deserialiser; a long bag streamed.

Each target is one line ending in PASS or MISS, measured in this run:

1. Reading the six IMU channels and the stamps of sensor_msgs/Imu messages, per container (ROS 1
   bag, ROS 2 SQLite3, ROS 2 MCAP): inertest (:class:`inertest.io.recordings.Recording`, the
   numpy chunk walkers) against rosbags' ``AnyReader.messages`` + ``deserialize`` per message,
   on the same bag (written by rosbags' own writer, 100 000 messages). Target: >= 5x rosbags'
   messages per second; the arrays are checked equal first. CPU times (``time.process_time``),
   best of several runs: the machine is shared.
2. ``inertest noise`` on a ROS 1 bag of ``--messages`` Imu messages at 1 kHz (default 1e7; 1e8
   with ``--large``, 27.8 h; lz4 chunks, written with numpy by ``tests/recording_factory.py``),
   in a child process: wall time, messages per second, and the peak resident memory
   (``VmHWM``), which must stay under :data:`PEAK_MB` whatever the length (the record is
   decoded once into temporary files and analysed in blocks). 1e8 messages need about 7 GB of
   disk for the bag and 5.6 GB for the decoded channels.

Run: ``python benchmarks/bench_rosbag.py [--large] [--messages N] [--keep DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

#: Peak resident memory allowed for ``inertest noise`` on a streamed bag, any length [MB].
PEAK_MB = 1000.0
TARGET = 5.0
_COLS = [f"angular_velocity.{a}" for a in "xyz"] + [f"linear_acceleration.{a}" for a in "xyz"]


def _verdict(ok: bool) -> str:
    return "PASS" if ok else "MISS"


def _rosbags(path: Path) -> tuple[float, np.ndarray]:
    """rosbags' own path: every message deserialised, its fields copied into arrays."""
    from rosbags.highlevel import AnyReader

    t0 = time.process_time()
    with AnyReader([path]) as r:
        conns = [c for c in r.connections if c.topic == "/imu"]
        rows = []
        for conn, _, raw in r.messages(connections=conns):
            m = r.deserialize(raw, conn.msgtype)
            w, a = m.angular_velocity, m.linear_acceleration
            rows.append((m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec,
                         w.x, w.y, w.z, a.x, a.y, a.z))
    out = np.array(rows, dtype=np.float64)
    return time.process_time() - t0, out


def _ours(path: Path) -> tuple[float, np.ndarray]:
    from inertest.io.recordings import open_recording

    t0 = time.process_time()
    rec = open_recording(path, topic="/imu")
    parts = []
    for b in rec.batches(_COLS):
        stamp = b["header.stamp.sec"] * 1_000_000_000 + b["header.stamp.nanosec"]
        parts.append(np.column_stack([stamp, *(b[c] for c in _COLS)]))
    out = np.concatenate(parts).astype(np.float64)
    return time.process_time() - t0, out


def reading_speed(folder: Path, n: int = 100_000) -> None:
    from recording_factory import T0_NS, write_imu_bag

    rng = np.random.default_rng(1)
    stamps = T0_NS + np.arange(n, dtype=np.int64) * 1_000_000
    gyro, accel = rng.normal(0, 0.01, (n, 3)), rng.normal(0, 0.05, (n, 3))
    for kind, name in (("ros1", "imu.bag"), ("sqlite3", "imu_sqlite"), ("mcap", "imu_mcap")):
        path = folder / name
        if not path.exists():
            write_imu_bag(path, kind, stamps, gyro, accel)
        t_lib, ref = min((_rosbags(path) for _ in range(2)), key=lambda x: x[0])
        t_us, got = min((_ours(path) for _ in range(3)), key=lambda x: x[0])
        assert np.array_equal(ref, got), f"{kind}: inertest and rosbags disagree"
        ratio = t_lib / t_us
        print(f"{kind:8s} {n} Imu messages: rosbags {n / t_lib:10.0f} msg/s, inertest "
              f"{n / t_us:10.0f} msg/s: {ratio:5.1f}x (target >= {TARGET:g}x) "
              f"{_verdict(ratio >= TARGET)} (arrays equal)", flush=True)


def _child(path: str) -> None:
    import io
    from contextlib import redirect_stdout

    from inertest.cli import main

    t0 = time.perf_counter()
    buf = io.StringIO()
    with redirect_stdout(buf):
        status = main(["noise", path, "--topic", "/imu", "--json"])
    dt = time.perf_counter() - t0
    peak = 0
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            peak = int(line.split()[1])
    doc = json.loads(buf.getvalue()) if status == 0 else {}
    chans = doc.get("result", {}).get("channels", {})
    print(json.dumps({"status": status, "time": dt, "peak_kib": peak,
                      "n": doc.get("result", {}).get("timing", {}).get("n_samples"),
                      "density": {k: v["kalibr"]["noise_density"]["value"]
                                  for k, v in chans.items()}}))


def streamed(folder: Path, n: int) -> None:
    from recording_factory import fast_ros1_bag

    path = folder / f"long_{n}.bag"
    if not path.exists():
        t0 = time.perf_counter()
        fast_ros1_bag(path, n, rate_hz=1000.0, compression="lz4", chunk=1 << 16)
        print(f"wrote {path.name}: {n} messages, {path.stat().st_size / 1e9:.2f} GB "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, __file__, "--child", str(path)], env=env,
                         capture_output=True, text=True, check=False)
    lines = out.stdout.strip().splitlines()
    if out.returncode != 0 or not lines:
        print(f"streamed bag: the child failed: {out.stderr.strip()[-500:]}")
        return
    r = json.loads(lines[-1])
    peak_mb = r["peak_kib"] / 1024
    dens = ", ".join(f"{k} {v:.4g}" for k, v in r["density"].items())
    print(f"inertest noise on {n} messages ({n / 1000 / 3600:.1f} h at 1 kHz): "
          f"{r['time']:.0f} s ({n / r['time']:.0f} msg/s end to end), peak resident memory "
          f"{peak_mb:.0f} MB (bound {PEAK_MB:g} MB, any length) "
          f"{_verdict(r['status'] == 0 and r['n'] == n and peak_mb < PEAK_MB)}", flush=True)
    print(f"  noise densities (white 0.01 rad/s and 0.05 m/s^2 at 1 kHz: 3.16e-4, 1.58e-3): "
          f"{dens}", flush=True)


def main(argv: list[str]) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--large", action="store_true")
    ap.add_argument("--messages", type=float, default=None)
    ap.add_argument("--keep", type=Path, default=None, help="Folder to keep the bags in.")
    ap.add_argument("--child", default=None)
    args = ap.parse_args(argv)
    if args.child:
        _child(args.child)
        return
    n = int(args.messages or (1e8 if args.large or os.environ.get("INERTEST_BENCH_LARGE")
                              else 1e7))
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
        reading_speed(args.keep)
        streamed(args.keep, n)
        return
    with tempfile.TemporaryDirectory(prefix="bench-rosbag-") as tmp:
        reading_speed(Path(tmp))
        streamed(Path(tmp), n)


if __name__ == "__main__":
    main(sys.argv[1:])
