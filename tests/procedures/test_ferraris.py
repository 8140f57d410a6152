"""Ferraris calibration (faces + hand-made turns): exact recovery, imucal on real data, the
vertical-face bias under tilts, identifiability and bad input, Monte Carlo of the stated std."""

import warnings
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.special import j1

import inertest
from inertest.api import load_data, load_plan
from inertest.earth import Site
from inertest.errors import DataError, IdentifiabilityError, InertestWarning, PlanError
from inertest.io.plan_file import load_truth
from inertest.plan import Instrument, Plan
from inertest.procedures import ferraris
from noise_generators import flicker

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "ferraris"
REAL = ROOT.parent / "shared" / "realdata" / "imucal" / "annotated_session.csv"
G0 = 9.80665
MG = 1e-3 * G0


def make_plan(**params):
    p = {"sample_rate_hz": 200.0, **params}
    return Plan(Site.at(49.6, 9.81), Instrument(kind="imu", output_unit="count"),
                ferraris.FerrarisSpec.from_mapping(p))


def truth(**over):
    t = load_truth(EXAMPLES / "truth.toml")
    t.update(over)
    return t


def quiet_truth(**over):
    return truth(**{"face_tilt_deg": 0.0, "acc_noise": 0.0, "gyr_noise": 0.0, **over})


@pytest.mark.parametrize("with_g", [False, True])
def test_exact_recovery_without_noise(with_g):
    extra = {"Gg_xx": 40.0, "Gg_yz": -25.0, "Gg_zx": 60.0, "Gg_yy": 10.0} if with_g else {}
    t = quiet_truth(**extra)
    plan = make_plan(g_sensitivity=with_g, rotation_deg=-360.0, earth_rate=False)
    r = inertest.fit(plan, inertest.simulate(plan, t))
    for name, e in r.coefficients.items():
        assert e.value == pytest.approx(t.get(name, 0.0), rel=1e-9, abs=1e-7), name
    np.testing.assert_allclose(r.face_gravity_error_m_s2, 0.0, atol=1e-10)
    np.testing.assert_allclose(r.turn_angle_deg, -360.0 * np.eye(3), atol=1e-9)


def test_vertical_earth_rate_over_the_turns_is_removed():
    """Earth rate in the simulated world (49.6 deg). Ignoring it, each gyro scale factor is off by
    the closed form W sin L T / theta (T = 4 s turn + 2 x 1 s rest: +53 ppm); removing the
    vertical part leaves the horizontal rate over the rests, < W cos L x 2 s / theta = 15 ppm."""
    t = quiet_truth()
    world = make_plan()
    data = inertest.simulate(world, t)
    with_earth = inertest.fit(world, data)
    without = inertest.fit(make_plan(earth_rate=False), data)
    lat = np.radians(49.6)
    w_ie = 7.2921151467e-5
    expected = w_ie * np.sin(lat) * 6.0 / (2 * np.pi)
    bound = w_ie * np.cos(lat) * 2.0 / (2 * np.pi)
    for a in "xyz":
        k = t[f"Kg_{a}"]
        assert abs(with_earth.coefficients[f"Kg_{a}"].value / k - 1) < bound
        assert abs(without.coefficients[f"Kg_{a}"].value / k - 1 - expected) < bound
    assert expected > 3 * bound


def test_calibration_inverts_the_simulated_sensor():
    """apply() of the calibration block returns the true specific force and rate (closed form:
    calibrated = (K (I + M))^-1 (raw - b)), sample by sample."""
    plan = make_plan(g_sensitivity=True, earth_rate=False)
    t = quiet_truth(Gg_xy=30.0)
    data = inertest.simulate(plan, t)
    cal = inertest.fit(plan, data).calibration
    acc = np.column_stack([data[c] for c in ferraris.ACC_COLUMNS])
    gyr = np.column_stack([data[c] for c in ferraris.GYR_COLUMNS])
    a = cal.accelerometer.apply(acc)
    w = cal.gyroscope.apply(gyr, a)
    face = data["part"] == "y_a"
    np.testing.assert_allclose(a[face], [[0.0, -9.81, 0.0]] * int(face.sum()), atol=1e-9)
    turn = data["part"] == "z_rot"
    np.testing.assert_allclose(np.degrees(w[turn].sum(axis=0) / 200.0), [0, 0, 360], atol=1e-9)


def test_vertical_face_bias_beats_the_plain_mean_under_face_tilts():
    """Faces tilted by ~1 deg: the bias from the vertical faces only is off by a second-order
    amount (< g (1 - cos 3 deg) = 1.3 mg even for a 3-sigma tilt), the plain mean of all six
    faces by first-order amounts (g sin 1 deg = 17 mg per tilted face, / 6 x 4 faces)."""
    plan = make_plan()
    t = quiet_truth(face_tilt_deg=1.0)
    _, b_true, _, _, _ = ferraris._model_from_truth(t, plan.procedure)  # raw bias [count]
    count_per_mg = np.array([t["Ka_x"], t["Ka_y"], t["Ka_z"]]) * MG  # Ka in count/(m/s^2)
    err_vertical, err_plain = [], []
    for seed in range(20):
        r = inertest.fit(plan, inertest.simulate(plan, t, rng=seed))
        err_vertical.append((r.calibration.accelerometer.offset - b_true) / count_per_mg)
        err_plain.append((r.stats.acc_mean.mean(axis=0) - b_true) / count_per_mg)
    ev = np.abs(err_vertical).max()
    ep = np.sqrt(np.mean(np.square(err_plain)))
    assert ev < 1.3  # mg
    assert ep > 3.0  # mg: first order, ~ g sin(1 deg) sqrt(4)/6 = 5.8 mg rms
    assert ep > 5 * ev


def test_tilt_scatter_is_estimated_and_widens_the_misalignment_std():
    plan = make_plan()
    level = inertest.fit(plan, inertest.simulate(plan, truth(face_tilt_deg=0.0), rng=3))
    tilted = inertest.fit(plan, inertest.simulate(plan, truth(face_tilt_deg=0.5), rng=3))
    assert tilted.tilt_scatter_deg == pytest.approx(0.5, rel=0.8)
    assert level.tilt_scatter_deg < 0.05
    # misalignment std >= tau / sqrt(2) [urad]
    tau_urad = np.radians(tilted.tilt_scatter_deg) * 1e6
    assert tilted.coefficients["Ma_xy"].std >= 0.9 * tau_urad / np.sqrt(2)
    assert level.coefficients["Ma_xy"].std < 0.2 * tilted.coefficients["Ma_xy"].std


def _tilted_faces(plan, t, rng, tilt_rad):
    """A session of noise ``t`` whose faces are re-tilted here, independently of the library's
    simulation: each face's level specific force turned by two elementary rotations of
    N(0, tilt_rad) about its horizontal axes (exact, not small-angle)."""
    A_a, b_a, _, _, _ = ferraris._model_from_truth(t, plan.procedure)
    level = inertest.simulate(plan, {**t, "acc_noise": 0.0, "gyr_noise": 0.0})
    data = inertest.simulate(plan, t, rng=rng)
    acc0 = np.column_stack([level[c] for c in ferraris.ACC_COLUMNS])
    f0 = np.linalg.solve(A_a, (acc0 - b_a).T).T
    for label in ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a"):
        rows = data["part"] == label
        R = np.eye(3)
        for ax in {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[label[0]]:
            a = rng.normal(0.0, tilt_rad)
            E = np.eye(3)
            j, k = [(1, 2), (2, 0), (0, 1)][ax]  # the plane of a rotation about axis ax
            E[j, j] = E[k, k] = np.cos(a)
            E[j, k], E[k, j] = -np.sin(a), np.sin(a)
            R = E @ R
        acc = (f0[rows] @ R.T) @ A_a.T + b_a
        for i, c in enumerate(ferraris.ACC_COLUMNS):
            data[c][rows] += acc[:, i] - acc0[rows, i]
    return data


@pytest.mark.slow
def test_scale_factors_are_corrected_for_the_second_order_of_face_tilts():
    """Issue 15 review: faces tilted by 0.5 deg (1 sigma per horizontal axis) read g cos t on
    the vertical axis, so a pair spans 2 g (1 - tau^2): Ka came out low by 0.63-0.92 sigma
    (7.6e-5 relative). Corrected by the tilt scatter from the pair sums: bias < 0.2 sigma,
    reported std / scatter 0.8-1.25 over 400 sessions of an independent tilt simulation."""
    plan = load_plan(EXAMPLES / "plan.toml")
    t = {**truth(), "face_tilt_deg": 0.0}
    rng = np.random.default_rng(4242)
    names = ("Ka_x", "Ka_y", "Ka_z")
    est, std = [], []
    for _ in range(400):
        r = inertest.fit(plan, _tilted_faces(plan, t, rng, np.radians(0.5)))
        est.append([r.coefficients[n].value for n in names])
        std.append([r.coefficients[n].std for n in names])
    scatter = np.std(est, axis=0, ddof=1)
    bias = (np.mean(est, axis=0) - [t[n] for n in names]) / scatter
    ratio = np.mean(std, axis=0) / scatter
    assert np.all(np.abs(bias) < 0.2), bias
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


# --- real data: imucal's own annotated session ------------------------------------------------

needs_real = pytest.mark.skipif(not REAL.exists(), reason="shared/realdata not present")


@pytest.fixture(scope="module")
def real():
    plan = load_plan(EXAMPLES / "plan_imucal.toml")
    data = load_data(REAL)
    return plan, data, inertest.fit(plan, data)


@needs_real
def test_part_labels_normalised_and_split_give_the_same_calibration(real):
    # Every 7th row relabelled " X_P" style (blank, upper case): each part is then hundreds of
    # runs and the label matching, row grouping and sums go through the non-contiguous path;
    # the rows of each part are the same, so the calibration must be too.
    plan, data, ref = real
    messy = dict(data)
    labels = np.asarray(data["part"]).astype(object)
    labels[::7] = [" " + str(v).upper() + " " for v in labels[::7]]
    messy["part"] = labels.astype(str)
    got = inertest.fit(plan, messy)
    assert got.calibration.accelerometer.to_dict() == ref.calibration.accelerometer.to_dict()
    assert got.calibration.gyroscope.to_dict() == ref.calibration.gyroscope.to_dict()
    np.testing.assert_array_equal(got.identification.covariance, ref.identification.covariance)


@needs_real
def test_imucal_agrees_on_the_real_session(real):
    """imucal's FerrarisCalibration on the same input (its own test recording).

    Accelerometer: both use the face differences for the matrix and the vertical faces for the
    bias, so they agree to rounding. Gyroscope: imucal takes the gyro bias as the mean of all six
    faces, we from the vertical faces; the bias difference db integrates over a turn of T s to
    db T counts x s out of W_jj ~ 6000, so the matrices may differ by up to max|db| T / W_jj
    relative to the diagonal (we allow twice that)."""
    pd = pytest.importorskip("pandas")
    imucal = pytest.importorskip("imucal")
    plan, data, _ = real
    # imucal ignores the Earth rate: compare like with like
    r = inertest.fit(replace(plan, procedure=replace(plan.procedure, earth_rate=False,
                                                           tilt_correction=False)), data)
    df = pd.read_csv(REAL).set_index("part")
    info = imucal.FerrarisCalibration(grav=9.81, expected_angle=360.0).compute(
        imucal.ferraris_regions_from_df(df), 204.8, "a.u.", "a.u.")
    acc_m = np.linalg.inv(info.R_a) @ np.linalg.inv(info.K_a)
    np.testing.assert_allclose(r.calibration.accelerometer.matrix, acc_m, rtol=1e-12, atol=0)
    np.testing.assert_allclose(r.calibration.accelerometer.offset, info.b_a, atol=1e-9)
    np.testing.assert_allclose(r.calibration.gyroscope.g_sensitivity, info.K_ga, atol=1e-12)
    gyr_m = np.radians(np.linalg.inv(info.R_g) @ np.linalg.inv(info.K_g))  # rad/s per count
    db = np.abs(info.b_g - r.calibration.gyroscope.offset)
    assert db.max() < 0.2  # counts: both are static means of ~1000 samples of 3-count noise
    T = r.stats.n_turn.max() / 204.8
    W = np.abs(np.diag(r.stats.turn_gyr_integral)).min()
    tol = 2 * db.max() * T / W
    ours = r.calibration.gyroscope.matrix
    assert np.abs(ours - gyr_m).max() <= tol * np.abs(np.diag(ours)).max()


@needs_real
def test_real_session_calibrates_sensibly(real):
    """After calibration: every static face |a| = g within 1 mg (second order in the face tilt
    disagreement plus the noise of the mean), and the turns -- not used for the accelerometer --
    keep the median |a| within 2 mg of g (hand motion adds a little acceleration); each turn
    integrates to 360 deg (plus the vertical Earth rate) about its own axis through apply()."""
    plan, data, r = real
    assert np.abs(r.face_gravity_error_m_s2).max() < 1.0 * MG
    acc = np.column_stack([data[c] for c in ferraris.ACC_COLUMNS])
    gyr = np.column_stack([data[c] for c in ferraris.GYR_COLUMNS])
    a = r.calibration.accelerometer.apply(acc)
    w = r.calibration.gyroscope.apply(gyr, a)
    for j, part in enumerate(("x_rot", "y_rot", "z_rot")):
        s = data["part"] == part
        assert abs(np.median(np.linalg.norm(a[s], axis=1)) - 9.81) < 2.0 * MG
        ang = np.degrees(w[s].sum(axis=0) / 204.8)
        # the gyros also saw the vertical Earth rate during the turn (closed form)
        earth = np.degrees(7.2921151467e-5 * np.sin(np.radians(49.6)) * s.sum() / 204.8)
        up = a[s].mean(axis=0) / np.linalg.norm(a[s].mean(axis=0))
        np.testing.assert_allclose(ang, 360.0 * np.eye(3)[j] + earth * up, atol=1e-9)
    # a MEMS IMU: scale factors near the nominal 2048 count/g and 16.4 count/(deg/s)
    for a_ in "xyz":
        assert r.coefficients[f"Ka_{a_}"].value == pytest.approx(2048 / G0, rel=0.05)
        assert r.coefficients[f"Kg_{a_}"].value == pytest.approx(16.4, rel=0.05)
    assert r.coefficients["Ka_x"].unit == "count/(m/s^2)" and r.coefficients["Ma_xy"].unit == "urad"
    assert r.coefficients["Kg_x"].unit == "count/(deg/s)" and r.coefficients["Mg_xy"].unit == "urad"
    d = r.to_dict()
    assert d["result"]["triads"]["gyroscope"]["misalignment"]["M_xy"]["unit"] == "urad"
    assert d["result"]["triads"]["accelerometer"]["scale_factor"]["K_x"]["value"] == pytest.approx(
        r.coefficients["Ka_x"].value, rel=1e-12)


# --- identifiability and bad input ------------------------------------------------------------


def _sim(**plan_kw):
    plan = make_plan(**plan_kw)
    return plan, inertest.simulate(plan, quiet_truth())


def test_missing_face_names_the_coefficients_and_the_fix():
    plan, d = _sim()
    keep = d["part"] != "y_a"
    d = {k: v[keep] for k, v in d.items()}
    with pytest.raises(IdentifiabilityError, match=r"y_a.*Ka_y.*Ma_xy.*Ba_y.*record the y_a"):
        inertest.fit(plan, d)


def test_missing_turn_names_the_gyro_column():
    plan, d = _sim()
    keep = d["part"] != "z_rot"
    d = {k: v[keep] for k, v in d.items()}
    with pytest.raises(IdentifiabilityError, match=r"Kg_z, Mg_xz, Mg_yz.*z_rot"):
        inertest.fit(plan, d)


def test_face_not_turned_over_is_not_identifiable():
    plan, d = _sim()
    d = dict(d)
    part = d["part"].copy()
    part[part == "x_a"] = "ignored"
    # relabel half of x_p as x_a: the x axis never went down
    idx = np.flatnonzero(part == "x_p")
    part[idx[: idx.size // 2]] = "x_a"
    d["part"] = part
    with pytest.raises(IdentifiabilityError, match="x axis was not turned over"):
        inertest.fit(plan, d)


def test_swapped_faces_and_columns_and_turn_sign_are_caught():
    plan, d = _sim()
    swapped = dict(d)
    p = d["part"].copy()
    p[d["part"] == "z_p"], p[d["part"] == "z_a"] = "z_a", "z_p"
    swapped["part"] = p
    r = inertest.fit(plan, swapped)  # indistinguishable from a negated acc_z: K < 0, reported
    assert r.coefficients["Ka_z"].value < 0
    assert any("acc_z: negative scale factor" in m and "swapped" in m for m in r.messages)
    cols = dict(d, acc_y=d["acc_z"], acc_z=d["acc_y"])
    with pytest.raises(DataError, match="faces y_p/y_a change acc_z most"):
        inertest.fit(plan, cols)
    clockwise = inertest.simulate(make_plan(rotation_deg=-360.0), quiet_truth())
    with pytest.raises(DataError, match="set rotation_deg = -360"):
        inertest.fit(plan, clockwise)


def test_plan_errors():
    with pytest.raises(PlanError, match="sample_rate_hz"):
        ferraris.FerrarisSpec.from_mapping({})
    with pytest.raises(PlanError, match="rotation_deg"):
        ferraris.FerrarisSpec.from_mapping({"sample_rate_hz": 100.0, "rotation_deg": 1})
    with pytest.raises(PlanError, match="acc_unit"):
        ferraris.FerrarisSpec.from_mapping({"sample_rate_hz": 100.0, "acc_unit": "furlong"})
    with pytest.raises(PlanError, match="unknown name"):
        inertest.simulate(make_plan(), {"Ka_q": 1.0})
    with pytest.raises(PlanError, match="earth_rate must be true or false"):
        ferraris.FerrarisSpec.from_mapping({"sample_rate_hz": 100.0, "earth_rate": 1})
    with pytest.raises(PlanError, match="sample_rate_hz must be a number"):
        ferraris.FerrarisSpec.from_mapping({"sample_rate_hz": True})
    with pytest.raises(PlanError, match='unknown key.*sample_rate .*did you mean "sample_rate_hz"'):
        ferraris.FerrarisSpec.from_mapping({"sample_rate": 100.0})


# --- Monte Carlo of the stated uncertainties --------------------------------------------------


@pytest.mark.slow
def test_monte_carlo_std_matches_scatter():
    """Noise and random face tilts (0.3 deg): the reported std of each group of coefficients
    agrees with the scatter of the estimates over 300 sessions within 20 %."""
    plan = make_plan(g_sensitivity=True)
    t = truth(face_tilt_deg=0.3, acc_noise=30.0, gyr_noise=8.0)
    rng = np.random.default_rng(7)
    est, std = [], []
    for _ in range(300):
        r = inertest.fit(plan, inertest.simulate(plan, t, rng=rng))
        est.append([e.value for e in r.coefficients.values()])
        std.append([e.std for e in r.coefficients.values()])
    names = list(r.coefficients)
    est, std = np.array(est), np.array(std)
    scatter = est.std(axis=0, ddof=1)
    reported = np.sqrt(np.mean(std**2, axis=0))
    for prefix in ("Ka", "Ma", "Ba", "Kg", "Mg", "Bg", "Gg"):
        idx = [i for i, n in enumerate(names) if n.startswith(prefix)]
        ratio = np.mean(reported[idx] / scatter[idx])
        assert 0.8 < ratio < 1.2, (prefix, ratio)


def test_noise_given_twice_is_refused():
    with pytest.raises(PlanError, match="one place only"):
        inertest.simulate(make_plan(), truth(), noise=2.0)
    d = inertest.simulate(make_plan(), quiet_truth(**{"acc_noise": 0.0}) | {}, noise=0.0)
    assert np.ptp(d["acc_x"][d["part"] == "x_p"]) == 0.0


@needs_real
def test_second_real_session_in_si_units_with_clockwise_turns():
    """imucal's example session (another sensor, already in m/s^2 and deg/s, turns clockwise:
    rotation_deg = -360, sections from its list file). A +360 plan is refused with the fix; with
    -360 the accelerometer matches imucal to rounding and the gyro matrix within the bias-choice
    bound of the first real-data test."""
    pd = pytest.importorskip("pandas")
    imucal = pytest.importorskip("imucal")
    df, part, data = _example_session_table()
    params = {"sample_rate_hz": 102.4, "acc_unit": "m/s^2", "gyr_unit": "deg/s",
              "g_sensitivity": True}
    with pytest.raises(DataError, match="set rotation_deg = -360"):
        inertest.fit(make_plan(**params), data)
    r = inertest.fit(make_plan(**params, rotation_deg=-360.0, earth_rate=False,
                               tilt_correction=False), data)
    assert np.abs(r.face_gravity_error_m_s2).max() < 1.0 * MG
    df.index = pd.Index(part, name="part")
    info = imucal.FerrarisCalibration(grav=9.81, expected_angle=-360.0).compute(
        imucal.ferraris_regions_from_df(df[df.index != "between"]), 102.4, "m/s^2", "deg/s")
    np.testing.assert_allclose(r.calibration.accelerometer.matrix,
                               np.linalg.inv(info.R_a) @ np.linalg.inv(info.K_a), rtol=1e-12)
    gyr_m = np.radians(np.linalg.inv(info.R_g) @ np.linalg.inv(info.K_g))
    db = np.abs(info.b_g - r.calibration.gyroscope.offset).max()
    T = r.stats.n_turn.max() / 102.4
    W = np.abs(np.diag(r.stats.turn_gyr_integral)).min()
    ours = r.calibration.gyroscope.matrix
    assert np.abs(ours - gyr_m).max() <= 2 * db * T / W * np.abs(np.diag(ours)).max()


def test_convention_misalignment_scale_bias_by_hand():
    """A perfect IMU's session (m/s^2, rad/s: kinematics only), turned into counts by hand with
    raw = K (I + M) u + K (I + M) B (numpy, not the model): only Ma_xy = 1500 urad and
    Mg_xy = 2000 urad (sensor x sees input along/about y), Kg = 16.4 count/(deg/s) (a rate
    reading per sample), positive Ba_x and Bg_x. The fit reports exactly these and
    Ma_yx = Mg_yx = 0."""
    phys = make_plan(acc_unit="m/s^2", gyr_unit="rad/s", earth_rate=False)
    d = inertest.simulate(phys, {})
    f = np.column_stack([d[c] for c in ferraris.ACC_COLUMNS])
    w = np.column_stack([d[c] for c in ferraris.GYR_COLUMNS])
    Ma, Mg = np.zeros((3, 3)), np.zeros((3, 3))
    Ma[0, 1], Mg[0, 1] = 1500e-6, 2000e-6
    Sa = np.diag([208.8, 209.2, 208.4]) @ (np.eye(3) + Ma)  # count/(m/s^2)
    Sg = np.diag([16.4, 16.3, 16.5]) * 180 / np.pi @ (np.eye(3) + Mg)  # count/(rad/s)
    Ba = np.array([5.0 * MG, 0.0, 0.0])
    Bg = np.array([100.0 * np.pi / 180 / 3600, 0.0, 0.0])
    acc = f @ Sa.T + Sa @ Ba
    gyr = w @ Sg.T + Sg @ Bg
    data = {"part": d["part"], **{c: acc[:, i] for i, c in enumerate(ferraris.ACC_COLUMNS)},
            **{c: gyr[:, i] for i, c in enumerate(ferraris.GYR_COLUMNS)}}
    c = inertest.fit(make_plan(earth_rate=False), data).coefficients
    assert c["Ma_xy"].value == pytest.approx(1500.0, abs=1e-6) and abs(c["Ma_yx"].value) < 1e-6
    assert c["Mg_xy"].value == pytest.approx(2000.0, abs=1e-6) and abs(c["Mg_yx"].value) < 1e-6
    assert c["Mg_xy"].unit == "urad"
    assert c["Kg_z"].value == pytest.approx(16.5, rel=1e-10) and c["Kg_z"].unit == "count/(deg/s)"
    assert c["Ka_y"].value == pytest.approx(209.2, rel=1e-10) and c["Ka_y"].unit == "count/(m/s^2)"
    assert c["Ba_x"].value == pytest.approx(5.0, rel=1e-9) and c["Ba_x"].unit == "mg"
    assert c["Bg_x"].value == pytest.approx(100.0, rel=1e-9) and c["Bg_x"].unit == "deg/h"


@needs_real
@pytest.mark.parametrize("column", ["gyr_x", "acc_y"])
def test_imucal_agrees_on_the_real_session_with_a_negated_channel(column):
    """The real session with one channel negated (an axis mounted reversed): no refusal, a
    negative scale factor named in a message, and the calibration equals imucal's (which
    calibrates it with a negative scale factor) within the tolerances of the plain comparison."""
    pd = pytest.importorskip("pandas")
    imucal = pytest.importorskip("imucal")
    plan = load_plan(EXAMPLES / "plan_imucal.toml")
    plan = replace(plan, procedure=replace(plan.procedure, earth_rate=False,
                                           tilt_correction=False))
    data = dict(load_data(REAL))
    data[column] = -np.asarray(data[column], dtype=float)
    r = inertest.fit(plan, data)
    letter = "g" if column.startswith("gyr") else "a"
    assert r.coefficients[f"K{letter}_{column[-1]}"].value < 0
    assert any(f"{column}: negative scale factor" in m for m in r.messages)
    df = pd.read_csv(REAL).set_index("part")
    df[column] = -df[column]
    info = imucal.FerrarisCalibration(grav=9.81, expected_angle=360.0).compute(
        imucal.ferraris_regions_from_df(df), 204.8, "a.u.", "a.u.")
    acc_m = np.linalg.inv(info.R_a) @ np.linalg.inv(info.K_a)
    np.testing.assert_allclose(r.calibration.accelerometer.matrix, acc_m, rtol=1e-12, atol=0)
    np.testing.assert_allclose(r.calibration.accelerometer.offset, info.b_a, atol=1e-9)
    gyr_m = np.radians(np.linalg.inv(info.R_g) @ np.linalg.inv(info.K_g))
    db = np.abs(info.b_g - r.calibration.gyroscope.offset).max()
    T = r.stats.n_turn.max() / 204.8
    W = np.abs(np.diag(r.stats.turn_gyr_integral)).min()
    ours = r.calibration.gyroscope.matrix
    assert np.abs(ours - gyr_m).max() <= 2 * db * T / W * np.abs(np.diag(ours)).max()


@pytest.mark.parametrize(("turn_s", "rest_s", "rotation_deg"), [(4.0, 1.0, 360.0),
                                                                (10.0, 0.5, -360.0)])
def test_earth_rate_during_turns_leaves_the_stated_misalignment(turn_s, rest_s, rotation_deg):
    """A perfect IMU (K = 1, M = 0, b = 0), no noise, Earth rate on, at the example plan's site.
    The horizontal Earth rate W cos L (north; faces at heading 0) turns in the body by the turned
    angle phi(t); over the turn part it leaves the angle W cos L |int exp(-i phi) dt| across the
    turn axis. For a raised-cosine rate over T with rests t_r either side, by hand:
    int_0^T exp(-i phi) dt = T J_1(1) (Bessel, phi = 2 pi (s - sin(2 pi s)/(2 pi)), s = t/T),
    plus 2 t_r at phi = 0 mod 2 pi, so M = W cos L (2 t_r + J_1(1) T) / theta, in the element
    (north axis at the start, turn axis): z for the x turn, x for y, y for z."""
    plan = load_plan(EXAMPLES / "plan.toml")
    plan = replace(plan, procedure=replace(plan.procedure, turn_duration_s=turn_s,
                                           rest_s=rest_s, rotation_deg=rotation_deg))
    perfect = {f"K{s}_{a}": 1.0 for s in "ag" for a in "xyz"}
    c = inertest.fit(plan, inertest.simulate(plan, perfect)).coefficients
    w_ie = 7.2921151467e-5  # rad/s (WGS 84)
    t_eff = 2 * rest_s + j1(1.0) * turn_s
    expected_urad = w_ie * np.cos(np.radians(49.6)) * t_eff / np.radians(rotation_deg) * 1e6
    spurious = {n: c[n].value for n in ("Mg_zx", "Mg_xy", "Mg_yz")}
    for name, value in spurious.items():
        assert value == pytest.approx(expected_urad, rel=0.01), name
    others = [abs(c[n].value) for n in ("Mg_yx", "Mg_zy", "Mg_xz")]
    assert max(others) < 1e-3 * abs(expected_urad)
    largest = max(abs(c[n].value) for n in c if n.startswith("Mg_"))
    assert largest == pytest.approx(abs(expected_urad), rel=0.01)
    for a in "xyz":  # scale factors: unaffected to first order
        assert abs(c[f"Kg_{a}"].value - 1.0) < 1e-9


def _channel_noise(case, part, rng, reps, sigma):
    """Noise of each raw channel over the session's samples (written here, independent of the
    fit): white noise sigma per sample, plus an offset of size sigma per part (the IMU
    re-settles on each face and turn), a random walk of sigma/10 per sample, or FFT-shaped
    1/f noise of rms sigma from 1/(2 session) up. Shape (reps, 6, samples)."""
    n = part.size
    x = rng.normal(size=(reps, 6, n)) * sigma[:, None]
    if case == "position-offsets":
        pid = np.cumsum(np.r_[True, part[1:] != part[:-1]]) - 1
        x += (rng.normal(size=(reps, 6, pid.max() + 1)) * sigma[:, None])[..., pid]
    elif case == "random-walk":
        x += np.cumsum(rng.normal(size=(reps, 6, n)), axis=2) * sigma[:, None] / 10
    elif case == "flicker":
        x += flicker(rng, (reps, 6, n), per_row=False) * sigma[:, None]
    return x


@pytest.mark.slow
@pytest.mark.parametrize("case", ["white", "position-offsets", "random-walk", "flicker"])
def test_monte_carlo_noise_model_matrix(case):
    """Issue 15: under white noise, white + offsets per part equal to the sample noise, white +
    a random walk and white + flicker, the std reported with the matching noise model agrees
    with the scatter over 100 short sessions (50 Hz, 5-s faces) within 0.8-1.25 for each group
    of coefficients, and the result names the model. Before (the white model on the same
    sessions): 0.06-0.09 under offsets (Ma 1.33), 0.02-0.09 under the random walk (Ma 3.5),
    0.12-0.22 under flicker (Ma 2.1)."""
    plan = make_plan(sample_rate_hz=50.0, earth_rate=False, g_sensitivity=True,
                     noise_model=case)
    base = inertest.simulate(plan, quiet_truth())
    reps = 100
    cols = ferraris.ACC_COLUMNS + ferraris.GYR_COLUMNS
    noise = _channel_noise(case, base["part"], np.random.default_rng(3), reps,
                           np.array([6.0] * 3 + [3.0] * 3))
    est, std = [], []
    try:  # small matrices: BLAS threads only contend (10x slower on a loaded 2-core machine)
        from threadpoolctl import threadpool_limits
        one_thread = threadpool_limits(1)
    except ImportError:
        one_thread = nullcontext()
    with one_thread, warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)  # the checks' rare false alarms
        fits = [inertest.fit(plan, {**base, **{c: base[c] + noise[r, k]
                                               for k, c in enumerate(cols)}})
                for r in range(reps)]
    # The model checks hold their level under the matching noise model (alpha = 1e-3 each).
    assert sum(not r.identification.checks.fits for r in fits) <= 0.05 * reps
    for res in fits:
        assert res.identification.noise_model == case
        est.append([e.value for e in res.coefficients.values()])
        std.append([e.std for e in res.coefficients.values()])
    names = list(res.coefficients)
    ratio = np.sqrt(np.mean(np.square(std), axis=0)) / np.std(est, axis=0, ddof=1)
    for prefix in ("Ka", "Ma", "Ba", "Kg", "Mg", "Bg", "Gg"):
        r = np.mean([ratio[i] for i, n in enumerate(names) if n.startswith(prefix)])
        assert 0.8 < r < 1.25, (prefix, r)


def test_noise_model_and_components_in_the_result():
    plan = make_plan(noise_model="random-walk")
    r = inertest.fit(plan, inertest.simulate(plan, truth(face_tilt_deg=0.0), rng=2))
    d = r.to_dict()
    assert d["identification"]["noise"]["model"] == "random-walk"
    noise = d["result"]["noise"]
    assert noise["model"] == "random-walk"
    assert set(noise["gyroscope"]) == {"white", "random walk"}
    assert noise["gyroscope"]["white"]["unit"] == "count"
    # white truth: the fitted white level is the simulated one (3 count), the walk small
    assert noise["gyroscope"]["white"]["value"] == pytest.approx(3.0, rel=0.1)
    with pytest.raises(PlanError, match="noise_model"):
        ferraris.FerrarisSpec.from_mapping({"sample_rate_hz": 100.0, "noise_model": "pink"})


# --- model checks (issue 15): the session's redundancy against the noise model -------------


def _example_session_table():
    """imucal's second session: its frame, the part of each row (from the list file), the data."""
    import json

    pd = pytest.importorskip("pandas")
    folder = REAL.parent
    df = pd.read_csv(folder / "example_ferraris_session.csv")
    sections = json.loads((folder / "example_ferraris_session_list.json").read_text())
    part = np.full(len(df), "between", dtype=object)
    for name, s in sections.items():
        part[s["start"]:s["end"]] = name
    data = {c: df[c].to_numpy(float) for c in df.columns} | {"part": part.astype(str)}
    return df, part, data


def _example_session():
    _, _, data = _example_session_table()
    return make_plan(sample_rate_hz=102.4, acc_unit="m/s^2", gyr_unit="deg/s",
                     g_sensitivity=True, rotation_deg=-360.0), data


@needs_real
@pytest.mark.parametrize("model", ferraris.NOISE_MODELS)
def test_imucal_real_sessions_pass_the_model_checks(real, model):
    """Both real imucal sessions (hand-set faces tilted 0.2-0.4 deg, hand turns) are
    consistent with every noise model: the off-axis pair sums within the noise and the plan's
    1-deg face tilt, the turns' |a| within the hand-turn allowance of g; the checks are in the
    envelope's ``checks`` with their chi-square and dof."""
    for plan, data in ((real[0], real[1]), _example_session()):
        with warnings.catch_warnings():
            warnings.simplefilter("error", InertestWarning)  # no misfit warning
            r = inertest.fit(plan, data, noise_model=model)
        c = r.identification.checks
        assert c.fits and not c.outliers and c.p_value > 1e-3, c
        assert c.dof == (13 if model == "position-offsets" else 15)
        (block,) = r.to_dict()["checks"]
        assert block["verdict"] == "consistent" and block["goodness_of_fit"]["dof"] == c.dof


def _rows(d, part):
    return np.flatnonzero(d["part"] == part)


def test_model_checks_pass_on_simulated_sessions():
    """Noisy simulated sessions with face tilts of 0.5 deg (the example truth, below the plan's
    1 deg): consistent in 20 of 20 seeds (alpha 1e-3 per session)."""
    plan = make_plan()
    bad = 0
    for seed in range(20):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InertestWarning)
            r = inertest.fit(plan, inertest.simulate(plan, truth(), rng=seed))
        bad += not r.identification.checks.fits
    assert bad == 0


def test_mislabelled_face_is_an_outlier_and_warns():
    """The first third of the y_a rows were recorded before the IMU was turned onto y_a (it
    still lay on z_p): the labels pass the face-difference checks, but the y pair's off-axis
    sums disagree far beyond any face tilt (and the y bias it gives moves the acc_y sums of the
    other pairs); every outlier names the y faces or acc_y, and the fit warns."""
    plan = make_plan()
    d = inertest.simulate(plan, truth(), rng=1)
    ya, zp = _rows(d, "y_a"), _rows(d, "z_p")
    k = ya.size // 3
    for c in ferraris.ACC_COLUMNS + ferraris.GYR_COLUMNS:
        d[c][ya[:k]] = d[c][zp[:k]]
    with pytest.warns(InertestWarning, match='"white" noise does not fit the session'):
        r = inertest.fit(plan, d)
    c = r.identification.checks
    assert not c.fits and c.outliers
    assert all(o.label.startswith("y faces") or o.label.endswith("acc_y")
               for o in c.outliers), c.outliers


def test_corrupted_turn_is_an_outlier_and_warns():
    """The x_rot label runs 1 s into the next part: the IMU was already being turned over onto
    x_a (acceleration of the x_a face, no rotation). The turn's gyro integral barely changes,
    but the mean specific force over the turn is no longer g along one axis: the x_rot
    |a| - g check is far outside the hand-turn allowance."""
    plan = make_plan()
    d = inertest.simulate(plan, truth(), rng=4)
    xr, xa = _rows(d, "x_rot"), _rows(d, "x_a")
    k = int(plan.procedure.sample_rate_hz)
    for c in ferraris.ACC_COLUMNS + ferraris.GYR_COLUMNS:
        d[c][xr[-k:]] = d[c][xa[:k]]
    with pytest.warns(InertestWarning, match="x_rot"):
        r = inertest.fit(plan, d)
    labels = [o.label for o in r.identification.checks.outliers]
    assert "x_rot |a| - g" in labels


def test_face_tilt_beyond_the_plan_bound_is_flagged():
    """Faces set with 5-deg tilts against the plan's 1 deg: the accelerometer pair sums reject
    the session; with face_tilt_deg = 8 in the plan the same session is consistent."""
    d = inertest.simulate(make_plan(), truth(face_tilt_deg=5.0), rng=7)
    with pytest.warns(InertestWarning):
        r = inertest.fit(make_plan(), d)
    assert not r.identification.checks.fits
    with warnings.catch_warnings():
        warnings.simplefilter("error", InertestWarning)
        r = inertest.fit(make_plan(face_tilt_deg=8.0), d)
    assert r.identification.checks.fits
