"""Allan deviation (issue 3): speed against allantools, and bounded memory on a long file.

1. Speed: octave-tau overlapping ADEV of ``--n-speed`` white-noise rate samples (default 1e7),
   :func:`inertest.noise.oadev` against ``allantools.oadev`` on the same data in the same
   process, best of three each. Prints both times, the ratio and the largest relative difference.
2. Memory: ``--n`` float32 samples (default 2e7; up to 2e8 and more) written in pieces to a raw
   ``.f32`` file in a temporary folder, then analysed by a child process through
   :func:`inertest.io.raw_samples.read_samples` (chunked reads). Prints its peak resident memory
   (``VmHWM``), the file size, the time, and, when the record fits (``--n`` <= 3e7), the
   largest relative difference against the in-memory computation.

Run: ``python benchmarks/bench_allan.py [--n-speed N] [--n N]``.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _best(fn, repeat: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _speed(n: int) -> None:
    import allantools

    from inertest.noise import oadev

    y = np.random.default_rng(1).standard_normal(n)
    oadev(y[:1000], 100.0)  # compile / load the numba cache outside the timing
    t_ours, ours = _best(lambda: oadev(y, 100.0, "octave"))
    t_peer, peer = _best(lambda: allantools.oadev(y, rate=100.0, data_type="freq",
                                                  taus="octave"))
    k = min(ours.dev.size, len(peer[1]))
    diff = float(np.max(np.abs(ours.dev[:k] / peer[1][:k] - 1.0)))
    print(f"octave OADEV, {n:.0e} samples, {ours.taus.size} taus (incl. EDF and intervals):")
    print(f"  inertest   {t_ours:8.3f} s")
    print(f"  allantools {t_peer:8.3f} s")
    print(f"  speed-up   {t_peer / t_ours:8.1f} x   (largest relative difference {diff:.1e})")


def _peak_kib() -> int:
    """Peak resident memory of this process [KiB] (VmHWM: reset by exec, unlike ru_maxrss)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def _child(path: str, n: int, compare: bool) -> None:
    from inertest.io.raw_samples import read_samples
    from inertest.noise import oadev

    oadev(np.ones(1000), 100.0)  # load numba's cache before the baseline
    base = _peak_kib()
    t0 = time.perf_counter()
    data = read_samples(path)
    res = oadev(data, 100.0, "octave")
    dt = time.perf_counter() - t0
    peak = _peak_kib()
    out = {"time": dt, "peak_kib": peak, "base_kib": base, "taus": res.taus.size}
    if compare:
        mem = oadev(np.fromfile(path, dtype="<f4").astype(np.float64), 100.0, "octave",
                    stream=False)
        out["diff"] = float(np.max(np.abs(res.dev / mem.dev - 1.0)))
    print(json.dumps(out))


def _memory(n: int) -> None:
    g = np.random.default_rng(2)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.f32"
        with path.open("wb") as fh:
            for i in range(0, n, 1 << 22):
                k = min(1 << 22, n - i)
                (1e-3 + 1e-5 * g.standard_normal(k)).astype("<f4").tofile(fh)
        compare = n <= 30_000_000
        run = subprocess.run(
            [sys.executable, __file__, "--child", str(path), "--n", str(n)]
            + (["--compare"] if compare else []),
            capture_output=True, text=True, check=True,
        )
        r = json.loads(run.stdout.strip().splitlines()[-1])
        size_mb = path.stat().st_size / 2**20
    print(f"streaming OADEV of a {size_mb:.0f} MiB float32 file ({n:.0e} samples, "
          f"{r['taus']} taus):")
    print(f"  time {r['time']:.1f} s, peak resident memory {r['peak_kib'] / 1024:.0f} MiB "
          f"(interpreter + libraries before: {r['base_kib'] / 1024:.0f} MiB)")
    if "diff" in r:
        print(f"  largest relative difference streaming vs in memory: {r['diff']:.1e}")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n-speed", type=float, default=1e7)
    p.add_argument("--n", type=float, default=2e7)
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)
    p.add_argument("--compare", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(sys.argv[1:] if argv is None else argv)
    if a.child:
        _child(a.child, int(a.n), a.compare)
        return
    _speed(int(a.n_speed))
    _memory(int(a.n))


if __name__ == "__main__":
    main()
