"""IEEE 952 five-term noise identification: recovery, honesty about unresolved terms, MC."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.stats import chi2

from inertest.errors import DataError
from inertest.noise.deviations import mdev, oadev
from inertest.noise.identification import (
    NoiseFitWarning,
    allan_covariance_basis,
    basis,
    identify_noise,
    simulate_noise,
)
from inertest.units import ARCSEC_TO_RAD, HOUR_TO_S
from inertest.units import (
    DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S as K_UNIT,
)
from inertest.units import (
    DEG_PER_H_TO_RAD_PER_S as B_UNIT,
)
from inertest.units import (
    DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S as N_UNIT,
)

R_UNIT = B_UNIT / HOUR_TO_S  # deg/h^2 -> rad/s^2


def test_basis_is_ieee952_annex_c():
    # sigma^2 = 3Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2 at tau = 2 s
    a = basis(np.array([2.0]))[0]
    np.testing.assert_allclose(a, [3 / 4, 1 / 2, 2 * math.log(2) / math.pi, 2 / 3, 2.0])


@pytest.mark.parametrize(("term", "kw", "at"), [
    ("N", {"n_rw": 1e-3}, lambda t: 1e-3 / np.sqrt(t)),
    ("K", {"k": 1e-4}, lambda t: 1e-4 * np.sqrt(t / 3)),
    ("Q", {"q": 1e-3}, lambda t: math.sqrt(3) * 1e-3 / t),
    ("B", {"b": 1e-3}, lambda t: 1e-3 * math.sqrt(2 * math.log(2) / math.pi) + 0 * t),
])
def test_simulated_terms_have_the_annex_c_allan_variance(term, kw, at):
    y = simulate_noise(2**18, 10.0, rng=3, **kw)
    r = oadev(y, 10.0, [0.4, 1.6, 6.4, 25.6])
    np.testing.assert_allclose(r.dev, at(r.taus), rtol=0.1)


def test_recovers_n_b_k_within_stated_uncertainty():
    truth = {"N": 0.01, "B": 1.0, "K": 5.0}  # deg/sqrt(h), deg/h, deg/h/sqrt(h)
    y = simulate_noise(2**20, 20.0, n_rw=truth["N"] * N_UNIT, b=truth["B"] * B_UNIT,
                       k=truth["K"] * K_UNIT, rng=21)
    model = identify_noise(oadev(y, 20.0), instrument="gyro")
    for name, value in truth.items():
        t = model.terms[name]
        assert t.resolved, (name, t.note)
        # 2 % floor: the simulated flicker is band-limited at Nyquist, so its Allan variance
        # at tau = tau0 falls ~10 % below (2 ln2/pi) B^2 and shifts N by ~0.5 % (N's
        # statistical std here is 0.1 %); B itself was not verified by Monte Carlo.
        tol = max(3.0 * t.std_eng, 0.02 * value)
        assert abs(t.value_eng - value) < tol, (name, t.value_eng, t.std_eng)
    assert model.terms["N"].unit == "deg/sqrt(h)"
    assert model.terms["B"].unit == "deg/h"
    assert model.terms["K"].unit == "deg/h/sqrt(h)"
    # Terms not in the data are not reported as numbers, only bounded.
    for name in ("Q", "R"):
        assert not model.terms[name].resolved
        assert model.terms[name].value is None and model.terms[name].upper_bound_eng > 0


def test_white_noise_only_gives_bounds_for_the_rest():
    y = simulate_noise(50_000, 100.0, n_rw=2e-4, rng=5)
    model = identify_noise(oadev(y, 100.0), instrument="accelerometer")
    assert model.terms["N"].resolved and model.terms["N"].unit == "m/s/sqrt(h)"
    assert model.terms["N"].value == pytest.approx(2e-4, rel=0.02)
    assert [k for k, t in model.terms.items() if t.resolved] == ["N"]
    assert model.terms["B"].unit == "ug"
    d = model.to_dict()
    assert d["terms"]["K"]["value"] is None and d["terms"]["K"]["upper_bound"] > 0


def test_rejects_other_statistics():
    y = simulate_noise(5000, 10.0, n_rw=1e-3, rng=1)
    with pytest.raises(DataError, match="use oadev"):
        identify_noise(mdev(y, 10.0))


def test_dense_grid_is_thinned_to_octaves():
    y = simulate_noise(100_000, 10.0, n_rw=1e-3, rng=9)
    dense = oadev(y, 10.0, np.r_[np.arange(1, 65), 2 ** np.arange(7, 13)] / 10.0)
    model = identify_noise(dense, instrument=None)
    assert model.taus.size < dense.taus.size
    assert np.all(model.taus[1:] / model.taus[:-1] >= 1.9)
    n = model.terms["N"]
    assert n.resolved and abs(n.value - 1e-3) < 3 * n.std
    assert n.unit == "sqrt(s)"  # dimensionless input: no "u" placeholder


def test_isserlis_allan_covariance_equals_direct_sum():
    """Covariance of overlapping AVARs across taus vs a direct sum over all term pairs.

    Independent route: the full phase generalised-covariance matrix G(a - b) of each noise
    (white phase, white rate, flicker rate, rate random walk), second-difference matrices
    D_m, C = D_m G D_n^T, Cov(S_m, S_n) = 2 sum(C_t C_u) / (4 m^2 n^2 tau0^4 M_m M_n)
    (Isserlis) and the ramp cross term sum(C) / (M_m M_n).
    """
    nx, tau0 = 400, 0.1
    ms = np.array([1, 2, 4, 8, 16, 32, 64, 128])
    ns = nx - 2 * ms
    g, h = allan_covariance_basis(ms, ns, tau0)
    k = np.abs(np.arange(nx)[:, None] - np.arange(nx)[None, :]).astype(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        gam = [(k == 0).astype(float), -0.5 * tau0 * k,
               np.where(k > 0, tau0**2 * k**2 * np.log(k) / (2 * math.pi), 0.0),
               tau0**3 * k**3 / 12]

    def dmat(m):
        d = np.zeros((nx - 2 * m, nx))
        r = np.arange(nx - 2 * m)
        d[r, r], d[r, r + m], d[r, r + 2 * m] = 1.0, -2.0, 1.0
        return d

    ds = [dmat(m) for m in ms]
    for i in range(ms.size):
        for j in range(ms.size):
            c = [ds[i] @ gm @ ds[j].T for gm in gam]
            norm = 4.0 * (ms[i] * ms[j]) ** 2 * tau0**4 * ns[i] * ns[j]
            for t in range(4):
                assert h[t, i, j] == pytest.approx(np.sum(c[t]) / (ns[i] * ns[j]),
                                                   rel=0.03 if t == 2 else 1e-3)
                for u in range(4):
                    ref = 2.0 * np.sum(c[t] * c[u]) / norm
                    size = math.sqrt(g[t, t, i, i] * g[u, u, j, j])
                    assert abs(g[t, u, i, j] - ref) < 2e-3 * size, (t, u, i, j)


_SCENARIOS = {
    # name: (simulate_noise keywords, true terms), 1e5 samples at 10 Hz
    "N+K": ({"n_rw": 0.1 * N_UNIT, "k": 10.0 * K_UNIT}, {"N": 0.1 * N_UNIT, "K": 10.0 * K_UNIT}),
    "N+R": ({"n_rw": 0.1 * N_UNIT, "r": 6.0 * R_UNIT}, {"N": 0.1 * N_UNIT, "R": 6.0 * R_UNIT}),
    "Q+N": ({"q": 5.0 * ARCSEC_TO_RAD, "n_rw": 0.1 * N_UNIT},
            {"Q": 5.0 * ARCSEC_TO_RAD, "N": 0.1 * N_UNIT}),
}


@pytest.mark.slow
@pytest.mark.parametrize("scenario", list(_SCENARIOS))
def test_monte_carlo_stated_std_matches_scatter(scenario):
    """Reported std vs the scatter of the estimates over 100 independent records.

    With 100 records the scatter is known to ~7 %, so the band 0.8 .. 1.25 is about 3 sigma;
    the mean must lie within 3 standard errors of the truth. Before the generalised least
    squares (bootstrap, 60 records): scatter/std N+K 1.14, 1.32 with K 18 % low; N+R 1.21,
    1.25 with R 11 % low; Q+N 0.98, 1.16. After: 1.06, 1.00; 0.94, 1.00; 1.02, 1.12, no bias.
    """
    sim, truth = _SCENARIOS[scenario]
    g = np.random.default_rng(11)
    vals, stds = [], []
    for _ in range(100):
        y = simulate_noise(100_000, 10.0, rng=g, **sim)
        with warnings.catch_warnings():  # the model check flags ~1 % of records (its level)
            warnings.simplefilter("ignore", NoiseFitWarning)
            m = identify_noise(oadev(y, 10.0), instrument=None)
        if all(m.terms[k].resolved for k in truth):
            vals.append([m.terms[k].value for k in truth])
            stds.append([m.terms[k].std for k in truth])
    vals, stds = np.asarray(vals), np.asarray(stds)
    assert len(vals) >= 95
    scatter = vals.std(axis=0, ddof=1)
    ratio = scatter / stds.mean(axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio
    bias = vals.mean(axis=0) - np.asarray(list(truth.values()))
    assert np.all(np.abs(bias) < 3.0 * scatter / math.sqrt(len(vals))), bias / scatter


def _lasergyro_z(realdata_dir):
    """PSINS laser-gyro record, z gyro: increments of 0.1 arcsec per 10 ms -> rad/s."""
    x = np.loadtxt(realdata_dir / "psins" / "lasergyro.imu", comments="%")[3:]
    arcsec = math.pi / 180.0 / 3600.0
    return x[:, 2] * 0.1 * arcsec / 0.01


@pytest.mark.slow
def test_psins_lasergyro_model_that_does_not_fit_resolves_nothing(realdata_dir):
    """Dithered ring-laser gyro on a vehicle: a dither hump near 0.1 s and a tau^-1 tail.

    The five-term model cannot follow it; the fit must say so instead of reporting terms.
    """
    res = oadev(_lasergyro_z(realdata_dir), 100.0)
    with pytest.warns(UserWarning, match="does not fit"):
        model = identify_noise(res, instrument="gyro")
    assert not model.fits and model.chi2_per_dof > 100
    assert model.max_misfit > 2.0
    assert not any(t.resolved for t in model.terms.values())
    assert model.checks and "does not fit" in model.checks[0]
    # The fit caps B at the flat floor: 0.664 B never above a measured deviation's upper limit
    b_floor = np.min(res.dev_hi) / math.sqrt(2 * math.log(2) / math.pi)
    assert math.sqrt(model.coefficients_sq[2]) <= b_floor * (1 + 1e-9)
    # The reported bound (issue 19): 0.664 B under every point's one-sided upper limit, jointly
    # 95 % (chi-squared with the EDF, Bonferroni over the measured taus), whatever the fit says
    ok = res.n >= 1
    edf = np.maximum(res.edf[ok], 1.0)
    hi = res.dev[ok] * np.sqrt(edf / chi2.ppf(0.05 / ok.sum(), edf))
    factor = {"Q": math.sqrt(3) / res.taus[ok], "N": 1 / np.sqrt(res.taus[ok]),
              "B": math.sqrt(2 * math.log(2) / math.pi), "K": np.sqrt(res.taus[ok] / 3),
              "R": res.taus[ok] / math.sqrt(2)}
    for name, f in factor.items():
        t = model.terms[name]
        assert t.upper_bound == pytest.approx(float(np.min(hi / f)), rel=1e-12)
        assert t.to_dict()["bound_definition"].startswith("tangent-line bound")
    assert model.to_dict()["fits"] is False


def test_bias_instability_never_above_the_floor():
    """Flicker floor plus white noise: fitted B within the bound 0.664 B <= min dev_hi."""
    y = simulate_noise(200_000, 10.0, n_rw=1e-4, b=2e-4, rng=4)
    res = oadev(y, 10.0)
    model = identify_noise(res, instrument=None)
    assert model.fits, model.verdict
    floor = np.min(res.dev_hi) / math.sqrt(2 * math.log(2) / math.pi)
    assert math.sqrt(model.coefficients_sq[2]) <= floor * (1 + 1e-9)
    assert model.terms["B"].resolved
    assert model.terms["B"].value == pytest.approx(2e-4, rel=0.15)


def test_short_and_coarse_records_never_crash_the_fit():
    """Issue 28: records of 4-25 samples ended in LinAlgError (more terms active than
    averaging times), a zero deviation (coarse counts) in a ValueError. Now every record of
    2-40 samples, white, random walk, quantized or tiny on an offset, gives a model: fitted
    terms with finite std, or upper bounds only."""
    g = np.random.default_rng(0)
    for n in range(2, 41):
        for y in (g.standard_normal(n), np.cumsum(g.standard_normal(n)),
                  np.round(3.0 * g.standard_normal(n)), 5.0 + 1e-9 * g.standard_normal(n)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", NoiseFitWarning)
                model = identify_noise(oadev(y, 1.0), instrument=None)
            for t in model.terms.values():
                assert math.isfinite(t.upper_bound) and t.upper_bound >= 0
                assert not t.resolved or math.isfinite(t.std)
            if n < 4:
                assert not model.fits and "too short" in model.verdict
                assert model.to_dict()["chi2_per_dof"] is None
