"""In-run bias stability: the standards' definition over an averaging time, and a Monte Carlo.

Records from the independent generator of ``tests/static_noise.py`` (white + band-limited
flicker + rate random walk).
"""

from __future__ import annotations

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.errors import IdentifiabilityError, PlanError
from inertest.plan import Instrument, Plan
from inertest.procedures import in_run_stability as irs
from static_noise import DEG_H, DEG_H_SQRT_H, DEG_SQRT_H, at_rest

LAT = 34.25
W_UP = 7.2921151467e-5 * np.sin(np.radians(LAT)) / DEG_H


def plan_for(*, kind="rate-gyro", unit="deg/h", **params):
    spec = irs.InRunStabilitySpec.from_mapping({"sample_rate_hz": 1.0, **params})
    return Plan(Site.at(LAT), Instrument(kind=kind, serial="U1", output_unit=unit), spec)


def test_ieee952_bias_stability_is_the_std_of_the_100_s_window_biases():
    """IEEE Std 952-1997 / 528: bias stability over 100 s = 1 sigma of the 100 s averages of
    the rate output (Earth rate removed) over the record, non-overlapping windows."""
    rng = np.random.default_rng(1)
    y = 0.2 + W_UP + 0.05 * rng.normal(size=3650)       # 36 windows of 100 s, 50 s left over
    res = inertest.fit(plan_for(averaging_time_s=100.0), {"output": y})
    means = y[:3600].reshape(36, 100).mean(axis=1)
    assert res.coefficients["bias_stability"].value == pytest.approx(np.std(means, ddof=1),
                                                                     rel=1e-12)
    assert res.stability["windows"] == 36 and res.stability["averaging_time_s"] == 100.0
    assert res.coefficients["B"].value == pytest.approx(y.mean() - W_UP, abs=1e-12)
    # white noise: u(s) = sigma_w / sqrt(2 (M - 1)), sigma_w = 0.05 / sqrt(100)
    assert res.coefficients["bias_stability"].std == pytest.approx(
        0.005 / np.sqrt(2 * 35), rel=0.15)
    np.testing.assert_allclose(res.window_bias, means - W_UP, atol=1e-12)


def test_ieee1293_accelerometer_bias_stability_in_ug():
    """IEEE Std 1293-2018: an accelerometer's in-run bias stability, input axis horizontal
    (no gravity along it), in ug over 10 s windows."""
    plan = plan_for(kind="accelerometer", unit="ug", averaging_time_s=10.0, input_axis="E")
    y = 35.0 + 4.0 * np.random.default_rng(2).normal(size=1000)
    res = inertest.fit(plan, {"output": y})
    means = y.reshape(100, 10).mean(axis=1)
    assert res.coefficients["bias_stability"].unit == "ug"
    assert res.coefficients["bias_stability"].value == pytest.approx(np.std(means, ddof=1))
    assert res.coefficients["B"].value == pytest.approx(y.mean())


def test_an_unresolved_allan_term_is_not_determined_with_its_bound():
    y = 0.05 * np.random.default_rng(3).normal(size=2000)   # white only: no flicker floor
    res = inertest.fit(plan_for(), {"output": y})
    assert "bias_instability" not in res.coefficients
    assert "bias_instability" in res.identification.names
    assert any(s.startswith("bias_instability: not resolved") and "upper bound" in s
               for s in res.identification.not_separable)


def test_short_and_bad_records_are_refused():
    with pytest.raises(IdentifiabilityError, match="at least 3 are needed"):
        inertest.fit(plan_for(averaging_time_s=100.0), {"output": np.zeros(250)})
    with pytest.raises(PlanError, match="one continuous record"):
        inertest.fit(plan_for(), {"output": np.zeros(400),
                                  "run": np.repeat(["a", "b"], 200)})
    with pytest.raises(PlanError, match="shorter than one reading"):
        plan_for(averaging_time_s=0.1)


@pytest.mark.slow
def test_monte_carlo_bias_and_stability_std_match_their_scatter():
    """2-hour records of white + flicker + rate random walk (a FOG's: 0.005 deg/sqrt(h),
    0.03 deg/h, 0.003 deg/h/sqrt(h)): the reported std of B and of the 100 s bias stability
    match their scatter within 0.8-1.25, and B is centred on the truth."""
    rng = np.random.default_rng(5)
    reps, n = 120, 7200
    N, B, K = 0.005 * DEG_SQRT_H, 0.03 * DEG_H, 0.003 * DEG_H_SQRT_H
    noise = at_rest(rng, (reps, n), 1.0, N=N, B=B, K=K) / DEG_H
    plan = plan_for(averaging_time_s=100.0)
    got = {k: [] for k in ("B", "Bs", "s", "ss")}
    for r in range(reps):
        c = inertest.fit(plan, {"output": noise[r] + 0.3 + W_UP}).coefficients
        got["B"].append(c["B"].value)
        got["Bs"].append(c["B"].std)
        got["s"].append(c["bias_stability"].value)
        got["ss"].append(c["bias_stability"].std)
    g = {k: np.array(v) for k, v in got.items()}
    ratio_b = np.sqrt(np.mean(g["Bs"] ** 2)) / np.std(g["B"])
    ratio_s = np.sqrt(np.mean(g["ss"] ** 2)) / np.std(g["s"])
    print(f"in-run stability MC: B {ratio_b:.3f}, bias stability (100 s) {ratio_s:.3f}")
    assert 0.8 <= ratio_b <= 1.25 and 0.8 <= ratio_s <= 1.25
    assert abs(np.mean(g["B"]) - 0.3) < 3 * np.std(g["B"]) / np.sqrt(reps)
    # the flicker and the random walk make 100 s windows scatter more than white noise would
    white = 0.005 * 60 / np.sqrt(100)          # N / sqrt(tau) [deg/h]
    assert np.mean(g["s"]) > 1.3 * white
    # ... and their std is larger than the white-noise formula s / sqrt(2 (M - 1))
    assert np.mean(g["ss"]) > 1.3 * np.mean(g["s"]) / np.sqrt(2 * 71)
