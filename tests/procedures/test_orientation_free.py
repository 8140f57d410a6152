"""Orientation-free calibration (Tedaldi, Pretto, Menegatti, ICRA 2014): physical checks on the
real imu_tk Xsens recording, an independent simulation, Monte Carlo std, identifiability."""

from __future__ import annotations

import dataclasses
import json
import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import inertest
from inertest.cli import main
from inertest.errors import IdentifiabilityError, PlanError
from inertest.io.plan_file import load_plan
from inertest.procedures import orientation_free as of
from inertest.procedures.orientation_free import fit_accelerometer

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "orientation_free"
G = 9.806
DEG = np.pi / 180


# --- real data: imu_tk's hand-held Xsens MTi recording ---------------------------------------


@pytest.fixture(scope="module")
def xsens_data():
    real = ROOT.parent / "shared" / "realdata" / "imu_tk"
    if not real.is_dir():
        pytest.skip("../shared/realdata/imu_tk not present")
    acc = np.loadtxt(real / "xsens_acc.txt")
    gyr = np.loadtxt(real / "xsens_gyro.txt")
    data = {"t_s": acc[:, 0]}
    data.update({f"acc_{a}": acc[:, k + 1] for k, a in enumerate("xyz")})
    data.update({f"gyr_{a}": gyr[:, k + 1] for k, a in enumerate("xyz")})
    return data


@pytest.fixture(scope="module")
def xsens(xsens_data):
    return inertest.fit(load_plan(EXAMPLES / "plan_xsens.toml"), xsens_data)


def test_real_static_intervals_have_abs_a_equal_g(xsens):
    """|a| - g over the ~38 static attitudes: 103 mg rms with the nominal offset and one common
    scale, 0.10 mg rms after calibration (Tedaldi report the same order for their Xsens)."""
    assert 36 <= len(xsens.intervals) <= 42  # the README of the data: about 38 attitudes
    s = xsens.summary()["gravity_norm_rms"]
    assert s["after"] < 0.3 and s["before"] > 50.0 and s["after"] < s["before"] / 200
    assert np.max(np.abs(xsens.gravity_error_m_s2)) < 0.5e-3 * G
    first = xsens.intervals[0]
    assert first.start_s < 1.0 and first.duration_s > 45.0  # the initial still period


def test_real_gyro_carries_gravity_into_the_next_attitude(xsens):
    """Angle between the gravity direction carried by the integrated gyro over each motion and
    the next static interval's: 41 deg rms with the nominal scale, 0.52 deg after."""
    s = xsens.summary()["gravity_transport_rms"]
    assert s["after"] < 1.0 and s["before"] > 20.0 and s["after"] < s["before"] / 20
    assert np.max(xsens.transport_angle_deg) < 1.5
    assert xsens.transport_angle_deg.size == len(xsens.intervals) - 1


def test_real_auto_threshold_keeps_the_lowest_residual_and_the_checks(xsens, xsens_data):
    """threshold_factor = "auto" (Tedaldi Sec. IV): k = 2..10 tried, the lowest accelerometer
    residual kept (k = 3 here, 40 intervals); |a| = g and the carried gravity are no worse
    than with the plan's k = 6 (0.10 mg, 0.52 deg rms)."""
    plan = load_plan(EXAMPLES / "plan_xsens.toml")
    auto = dataclasses.replace(plan, procedure=dataclasses.replace(plan.procedure,
                                                                   threshold_factor="auto"))
    res = inertest.fit(auto, xsens_data)
    cands = res.threshold_search
    assert [c.threshold_factor for c in cands] == list(of.AUTO_THRESHOLD_FACTORS)
    rms = np.array([c.residual_rms_m_s2 for c in cands])
    chosen = cands[int(np.nanargmin(rms))]
    assert res.detection.threshold_factor == chosen.threshold_factor
    assert len(res.intervals) == chosen.intervals >= 36
    s_auto, s_fix = res.summary(), xsens.summary()
    for check in ("gravity_norm_rms", "gravity_transport_rms"):
        assert s_auto[check]["after"] <= s_fix[check]["after"], check
    det = res.details()["detector"]
    assert det["threshold_choice"] == "auto" and len(det["candidates"]) == 9


def test_auto_threshold_from_the_plan_file(tmp_path):
    """"auto" is read from TOML; another text is refused naming the parameter; a simulated
    session finds all its attitudes with the chosen factor."""
    plan = _plan(tmp_path)
    text = (tmp_path / "plan.toml").read_text().replace("window_s = 0.5",
                                                        'window_s = 0.5\nthreshold_factor = "auto"')
    (tmp_path / "auto.toml").write_text(text)
    auto = load_plan(tmp_path / "auto.toml")
    assert auto.procedure.threshold_factor == "auto" and plan.procedure.threshold_factor == 6.0
    (tmp_path / "bad.toml").write_text(text.replace('"auto"', '"best"'))
    with pytest.raises(PlanError, match="threshold_factor"):
        load_plan(tmp_path / "bad.toml")
    rng = np.random.default_rng(12)
    att = Rotation.concatenate([Rotation.identity(), Rotation.random(20, random_state=rng)])
    res = inertest.fit(auto, _session(rng, _truth_matrices(rng), attitudes=att))
    assert len(res.intervals) == 21 and len(res.threshold_search) == 9


def test_real_result_follows_the_triad_conventions(xsens):
    c = xsens.coefficients
    # gauge "z" of Tedaldi/imu_tk: three accelerometer misalignments are conventions, absent
    assert {"Ma_yx", "Ma_zx", "Ma_zy"}.isdisjoint(c) and {"Ma_xy", "Ma_xz", "Ma_yz"} <= set(c)
    assert all(f"Mg_{p}" in c for p in ("xy", "xz", "yx", "yz", "zx", "zy"))
    assert c["Ka_x"].unit == "count/(m/s^2)" and c["Kg_x"].unit == "count/(deg/s)"
    assert c["Ma_xy"].unit == "urad" and c["Ba_x"].unit == "mg" and c["Bg_x"].unit == "deg/h"
    # offset-binary 16-bit output: raw offset ~ 32768 counts (input-referred B = S^-1 b)
    b_raw = xsens.calibration.accelerometer.offset
    assert np.all(np.abs(b_raw - 32768) < 0.25 * G * 414)  # within 0.25 g of mid-scale
    assert any("only up to a rotation" in s for s in xsens.identification.not_separable)


# --- independent simulation (written here, not the module's simulate) -------------------------


def _truth_matrices(rng, reference_axis="z"):
    """Accelerometer S (gauge) and b, gyro S and b [count per SI], near a MEMS IMU."""
    K_a = np.array([208.8, 209.2, 208.3])
    M_a = rng.normal(0.0, 5e-3, (3, 3))
    np.fill_diagonal(M_a, 0.0)
    M_a = np.triu(M_a) if reference_axis == "z" else np.tril(M_a)
    S_a = np.diag(K_a) @ (np.eye(3) + M_a)
    b_a = rng.normal(0.0, 20.0, 3)
    K_g = np.array([16.4, 16.38, 16.45]) / DEG  # count per rad/s
    M_g = rng.normal(0.0, 5e-3, (3, 3))
    np.fill_diagonal(M_g, 0.0)
    S_g = np.diag(K_g) @ (np.eye(3) + M_g)
    b_g = rng.normal(0.0, 30.0, 3)
    return S_a, b_a, S_g, b_g


def _session(rng, model, *, attitudes, fs=100.0, init_s=20.0, still_s=3.0, acc_noise=2.0,
             gyr_noise=1.0, seed_noise=None):
    """Hand-held session: each move is two sin^2-profile turns about random body axes (so
    the rate axis changes during a move); attitudes C_nb given (Rotation, first = start)."""
    S_a, b_a, S_g, b_g = model
    up = np.array([0.0, 0.0, G])
    n_turn = int(0.8 * fs)
    f, w = [np.tile(attitudes[0].inv().apply(up), (int(init_s * fs), 1))], [
        np.zeros((int(init_s * fs), 3))]
    tau = (np.arange(n_turn) + 0.5) / n_turn
    frac = tau - np.sin(2 * np.pi * tau) / (2 * np.pi)
    rate = (1 - np.cos(2 * np.pi * tau)) * fs / n_turn
    for k in range(len(attitudes) - 1):
        via = attitudes[k] * Rotation.from_rotvec(rng.normal(0.0, 0.6, 3))
        C = attitudes[k]
        for target in (via, attitudes[k + 1]):
            phi = (C.inv() * target).as_rotvec()
            f.append((C * Rotation.from_rotvec(np.outer(frac, phi))).inv().apply(up))
            w.append(np.outer(rate, phi))
            C = target
        n = int(still_s * fs)
        f.append(np.tile(attitudes[k + 1].inv().apply(up), (n, 1)))
        w.append(np.zeros((n, 3)))
    f, w = np.vstack(f), np.vstack(w)
    gen = np.random.default_rng(seed_noise if seed_noise is not None else rng)
    acc = f @ S_a.T + b_a + gen.normal(0.0, acc_noise, f.shape)
    gyr = w @ S_g.T + b_g + gen.normal(0.0, gyr_noise, w.shape)
    data = {"t_s": np.arange(len(f)) / fs}
    data.update({f"acc_{a}": acc[:, k] for k, a in enumerate("xyz")})
    data.update({f"gyr_{a}": gyr[:, k] for k, a in enumerate("xyz")})
    return data


def _plan(tmp_path, reference_axis="z"):
    p = tmp_path / "plan.toml"
    p.write_text(f"""
[site]
latitude_deg = 45.0
gravity = {G}
[instrument]
kind = "imu"
serial = "sim"
output_unit = "count"
[procedure]
kind = "orientation-free"
sample_rate_hz = 100.0
init_duration_s = 20.0
window_s = 0.5
reference_axis = "{reference_axis}"
gyr_scale_guess = 16.0
""")
    return load_plan(p)


def _engineering(model):
    """Truth in the result's names and units (via the triad model, as the fit reports)."""
    from inertest.models import triad
    S_a, b_a, S_g, b_g = model
    sa = triad.scale_unit("count", "accelerometer")
    sg = triad.scale_unit("count", "gyroscope")
    va = triad.engineering(triad.stack_parameters(S_a, b_a), "accelerometer", sa)
    vg = triad.engineering(triad.stack_parameters(S_g, b_g), "gyroscope", sg)
    names = triad.parameter_names()
    out = {f"{n[0]}a{n[1:]}": v for n, v in zip(names, va, strict=True)}
    out.update({f"{n[0]}g{n[1:]}": v for n, v in zip(names, vg, strict=True)})
    return out


@pytest.mark.parametrize("reference_axis", ["z", "x"])
def test_simulated_session_within_uncertainty(tmp_path, reference_axis):
    rng = np.random.default_rng(11)
    model = _truth_matrices(rng, reference_axis)
    att = Rotation.concatenate([Rotation.identity(), Rotation.random(36, random_state=rng)])
    res = inertest.fit(_plan(tmp_path, reference_axis), _session(rng, model, attitudes=att))
    truth = _engineering(model)
    assert len(res.intervals) == 37
    z = {k: (e.value - truth[k]) / e.std for k, e in res.coefficients.items()}
    assert max(abs(v) for v in z.values()) < 4.5, z
    assert len(res.coefficients) == 21
    assert res.summary()["gravity_norm_rms"]["after"] < 0.2


def _acc_only_mc(rng, model, n_att, reps):
    """Accelerometer fit on interval means of random attitudes: estimates and reported std."""
    from inertest.models import triad
    S_a, b_a, _, _ = model
    sa = triad.scale_unit("count", "accelerometer")
    est, std = [], []
    att = Rotation.random(n_att, random_state=rng)
    u = att.inv().apply([0.0, 0.0, G])
    for _ in range(reps):
        means = u @ S_a.T + b_a + rng.normal(0.0, 0.3, u.shape)
        p, cov, _, _ = fit_accelerometer(means, G, "z")
        v, c = triad.propagate(p, cov, "accelerometer", sa)
        est.append(v)
        std.append(np.sqrt(np.diag(c)))
    return np.array(est), np.array(std)


@pytest.mark.slow
def test_monte_carlo_reported_std_matches_scatter():
    """Reported std / MC scatter in 0.8-1.25 (median over each triad's quantities)."""
    rng = np.random.default_rng(5)
    model = _truth_matrices(rng)
    est, std = _acc_only_mc(rng, model, 30, 400)
    keep = [0, 1, 2, 3, 4, 6, 9, 10, 11]  # K, Ma_xy, Ma_xz, Ma_yz, B (gauge "z")
    ratio = np.median(std[:, keep], axis=0) / est[:, keep].std(axis=0, ddof=1)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


def _whole_procedure_mc(chunk, reps=100):
    """``fit`` on ``reps`` independent short sessions (same IMU and attitudes, new noise and
    new intermediate turns each time; ``chunk`` seeds them): values, reported stds,
    covariances, names."""
    rng = np.random.default_rng(5)
    model = _truth_matrices(rng)
    plan = load_plan(EXAMPLES / "plan.toml")
    att = Rotation.concatenate([Rotation.identity(), Rotation.random(20, random_state=rng)])
    rng = np.random.default_rng([5, chunk])
    vals, stds, covs = [], [], []
    for _ in range(reps):
        r = inertest.fit(plan, _session(rng, model, attitudes=att, init_s=20.0, still_s=2.0))
        vals.append([e.value for e in r.coefficients.values()])
        stds.append([e.std for e in r.coefficients.values()])
        covs.append(r.identification.covariance)
    return np.array(vals), np.array(stds), np.array(covs), list(r.coefficients)


@pytest.fixture(scope="module")
def whole_mc():
    """200 sessions in two processes (about 10 s CPU each)."""
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(2, mp_context=ctx) as pool:
        parts = list(pool.map(_whole_procedure_mc, (0, 1)))
    return (*(np.concatenate([p[i] for p in parts]) for i in range(3)), parts[0][3])


@pytest.mark.slow
def test_monte_carlo_gyro_std_matches_scatter(whole_mc):
    """The whole procedure (gyro included): for every coefficient of both triads, reported
    std / MC scatter in 0.8-1.25 (200 sessions; sampling error of a ratio ~5 %).

    The gyro std includes the shared accelerometer-calibration error of the gravity
    directions, the initial-period bias and the angle random walk of each motion (before:
    median ratio 0.77). The reported std is the root mean square over the sessions: the
    random intermediate turns change the design, and in a few sessions a slow last turn is
    taken for the start of the static interval, so those sessions' residuals (and stds) are
    several times larger; the scatter of such a mixture is the RMS of its stds, not the
    median."""
    vals, stds, _, names = whole_mc
    ratio = np.sqrt(np.mean(stds**2, axis=0)) / vals.std(axis=0, ddof=1)
    bad = {n: round(float(q), 2) for n, q in zip(names, ratio, strict=True)
           if not 0.8 < q < 1.25}
    assert not bad, dict(zip(names, np.round(ratio, 2), strict=True))
    assert sum(n[1] == "g" for n in names) == 12


@pytest.mark.slow
def test_monte_carlo_acc_gyro_cross_covariance(whole_mc):
    """The reported accelerometer-gyro correlations (up to |rho| ~ 0.7) agree with the MC
    ones: Fisher z of each of the 108 pairs within 4 sampling sigmas and their mean square
    near 1 (a zero cross block gives a mean square near 10 here)."""
    vals, _, covs, names = whole_mc
    ia = [i for i, n in enumerate(names) if n[1] == "a"]
    ig = [i for i, n in enumerate(names) if n[1] == "g"]
    cov_rep = np.median(covs, axis=0)
    sd_rep = np.sqrt(np.diag(cov_rep))
    rho_rep = (cov_rep / np.outer(sd_rep, sd_rep))[np.ix_(ia, ig)]
    rho_mc = np.corrcoef(vals, rowvar=False)[np.ix_(ia, ig)]
    z = (np.arctanh(rho_mc) - np.arctanh(rho_rep)) * np.sqrt(len(vals) - 3)
    assert np.max(np.abs(z)) < 4.0 and np.mean(z**2) < 1.6, np.round(z, 1)
    assert np.max(np.abs(rho_rep)) > 0.5
    assert np.mean(np.arctanh(rho_mc) ** 2) * (len(vals) - 3) > 4.0  # the block matters


# --- identifiability --------------------------------------------------------------------------


def test_too_few_attitudes_named(tmp_path):
    rng = np.random.default_rng(3)
    att = Rotation.concatenate([Rotation.identity(), Rotation.random(6, random_state=rng)])
    with pytest.raises(IdentifiabilityError, match=r"found 7 static.*at least 9.*36-50"):
        inertest.fit(_plan(tmp_path), _session(rng, _truth_matrices(rng), attitudes=att))


def test_too_similar_attitudes_say_which_to_add(tmp_path):
    """Fifteen attitudes all within 25 deg of z up: z down (and x, y down) are missing."""
    rng = np.random.default_rng(4)
    tilts = Rotation.from_rotvec(np.column_stack([rng.uniform(-1, 1, (15, 2)) * 25 * DEG,
                                                  rng.uniform(-np.pi, np.pi, 15)]))
    att = Rotation.concatenate([Rotation.identity(), tilts])
    data = _session(rng, _truth_matrices(rng), attitudes=att)
    try:
        res = inertest.fit(_plan(tmp_path), data)
        text = " ".join(res.messages)
    except IdentifiabilityError as exc:
        text = str(exc)
    assert "no attitude with" in text and "z down" in text and "add attitudes with" in text


# --- the README example, from a clone alone ---------------------------------------------------


def test_readme_example_runs_on_the_shipped_recording(capsys):
    data = EXAMPLES / "xsens_mti.parquet"
    assert (EXAMPLES / "README.md").read_text().count("BSD") >= 1
    assert main(["fit", str(EXAMPLES / "plan_xsens.toml"), str(data), "--json",
                 "--no-store"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["kind"] == of.KIND
    checks = {c["name"]: c for c in doc["checks"]}
    assert checks["static |a| = g"]["verdict"] == "pass"
    assert checks["gyro carries gravity to the next attitude"]["verdict"] == "pass"
    assert len(doc["result"]["static_intervals"]) == 38
    assert "Ma_yx" not in doc["result"]["triads"]["accelerometer"]["misalignment"]
    cross = doc["result"]["acc_gyro_cross_covariance"]
    assert len(cross["rows"]) == 9 and len(cross["columns"]) == 12
    assert np.array(cross["value"]).shape == (9, 12) and np.any(np.array(cross["value"]) != 0)
    assert doc["result"]["noise_scales"]["gyro_motions"] > 1  # real data: beyond white noise


def test_review19_time_gap_refused_and_a_failed_gyro_check_is_said():
    """Review 19 (bad/of_gap.parquet): 5 s cut out of the shipped Xsens recording after
    t = 200 s was calibrated (exit 0) though the gyro check failed at 12.9 deg. With t_s the
    gap is refused, naming it; without t_s it cannot be seen, and the failed gyro check is in
    the checks and in the messages."""
    from inertest.errors import DataError
    from inertest.io.data_file import read_table

    table = read_table(EXAMPLES / "xsens_mti.parquet")
    keep = (table["t_s"] <= 200.0) | (table["t_s"] > 205.0)
    data = {k: np.asarray(v)[keep] for k, v in table.items()}
    plan = load_plan(EXAMPLES / "plan_xsens.toml")
    with pytest.raises(DataError, match=r"'t_s' has 1 gap\(s\) in time, the first of 5\.0"):
        inertest.fit(plan, data)
    del data["t_s"]
    res = inertest.fit(plan, data)
    (check,) = [c for c in res.to_dict()["checks"] if c["name"].startswith("gyro carries")]
    assert check["verdict"] == "fail"
    assert any(m.startswith("check failed: the calibrated gyro") for m in res.messages)
