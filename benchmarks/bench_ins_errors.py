"""INS error propagation (issue 4): 24 h at a 1 s step, seven states, every source separately.

inertest: :func:`inertest.ins.propagation.source_responses` (12 sources + combined, exact
matrix exponentials applied by doubling). Peer, on the same work in the same run: scipy's
general ODE integrator ``solve_ivp(method="DOP853", rtol=1e-10, atol=tiny)`` on the same 13
cases stacked into one 91-state system, sampled at the same 86401 times. Prints both times,
their ratio, the largest difference (relative to each state's largest value), and the error
of each at the last sample against a 40-digit matrix exponential (mpmath).

Run: ``python benchmarks/bench_ins_errors.py [HOURS] [STEP_S]`` (default 24 h, 1 s).
"""

from __future__ import annotations

import math
import sys
import time

import mpmath
import numpy as np
from scipy.integrate import solve_ivp

from inertest.ins.error_model import InsSite, input_matrix, system_matrix
from inertest.ins.propagation import source_responses
from inertest.ins.scenario import InsScenario, seed_scenario


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    hours = float(argv[0]) if argv else 24.0
    step = float(argv[1]) if len(argv) > 1 else 1.0
    seed = seed_scenario()
    sc = InsScenario(site=InsSite(math.radians(39.0)), x0=seed.x0, u=seed.u,
                     duration_s=hours * 3600, step_s=step, name="seed 002 sources, Coriolis on")

    best = math.inf
    for _ in range(3):  # best of three: the machine is shared
        t0 = time.perf_counter()
        resp = source_responses(sc)
        best = min(best, time.perf_counter() - t0)
    t = resp.t
    ours = np.concatenate([resp.per_source, resp.combined[None]])  # (13, n, 7)

    # Same 13 cases for the peer: x0 and u of each case as columns.
    cases = ours.shape[0]
    x0s = np.zeros((7, cases))
    us = np.zeros((5, cases))
    for j in range(5):
        us[j, j] = sc.u[j]
    for i in range(7):
        x0s[i, 5 + i] = sc.x0[i]
    x0s[:, -1], us[:, -1] = sc.x0, sc.u
    a = system_matrix(sc.site)
    bu = input_matrix() @ us

    def rhs(_t, y):
        return (a @ y.reshape(7, cases) + bu).ravel()

    scale = np.maximum(np.abs(ours).max(axis=(0, 1)), 1e-30)  # per state
    atol = np.repeat(1e-14 * scale, cases)  # "tiny": 1e-14 of each state's range
    t_peer = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        sol = solve_ivp(rhs, (t[0], t[-1]), x0s.ravel(), method="DOP853", t_eval=t,
                        rtol=1e-10, atol=atol)
        t_peer = min(t_peer, time.perf_counter() - t0)
    peer = sol.y.reshape(7, cases, t.size).transpose(1, 2, 0)
    # The peer again, asked for the accuracy the exact solution has (rtol near its floor).
    t0 = time.perf_counter()
    sol13 = solve_ivp(rhs, (t[0], t[-1]), x0s.ravel(), method="DOP853", t_eval=t, rtol=1e-13,
                      atol=atol * 1e-3)
    t_peer13 = time.perf_counter() - t0
    peer13 = sol13.y.reshape(7, cases, t.size).transpose(1, 2, 0)
    diff = np.abs(peer - ours).max(axis=(0, 1)) / scale

    # Who is right: both against a 40-digit matrix exponential at the last sample.
    mpmath.mp.dps = 40
    aug = mpmath.matrix(12, 12)
    for (i, j), v in np.ndenumerate(np.block([[a, input_matrix()], [np.zeros((5, 12))]])):
        aug[i, j] = v
    e = mpmath.expm(aug * mpmath.mpf(t[-1]))
    z = np.vstack([x0s, us])
    ref = np.array([[float(sum(e[i, k] * z[k, c] for k in range(12))) for i in range(7)]
                    for c in range(cases)])
    err_ours = (np.abs(ours[:, -1] - ref) / scale).max()
    err_peer = (np.abs(peer[:, -1] - ref) / scale).max()
    err_peer13 = (np.abs(peer13[:, -1] - ref) / scale).max()

    print(f"grid: {t.size:,} samples ({hours:g} h at {step:g} s), 7 states, {cases} cases "
          "(12 sources separately + combined)")
    print(f"inertest exact (expm + doubling): {best * 1e3:8.1f} ms   (best of 3)")
    print(f"scipy solve_ivp DOP853 rtol 1e-10: {t_peer * 1e3:8.1f} ms   (best of 3, "
          f"{sol.nfev:,} RHS calls)")
    print(f"ratio solve_ivp / inertest: {t_peer / best:.1f}")
    print(f"scipy solve_ivp DOP853 rtol 1e-13: {t_peer13 * 1e3:8.1f} ms   ({sol13.nfev:,} RHS "
          f"calls), ratio {t_peer13 / best:.1f}")
    print(f"error at t = {t[-1]:g} s vs 40-digit expm (of each state's range): "
          f"inertest {err_ours:.1e}, solve_ivp rtol 1e-10 {err_peer:.1e}, "
          f"rtol 1e-13 {err_peer13:.1e}")
    print("max |difference| / state range: "
          + ", ".join(f"{n} {d:.1e}" for n, d in zip(
              ("dVE", "dVN", "dL", "dlambda", "phiE", "phiN", "phiU"), diff, strict=True)))


if __name__ == "__main__":
    main()
