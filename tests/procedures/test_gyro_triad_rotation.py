"""360-degree rotation test of a gyro triad (seed 003): closed forms, exact recovery,
identifiability and bad input, Monte Carlo of the stated uncertainties."""

import warnings

import numpy as np
import pytest

import inertest
from inertest.earth import OMEGA_IE, Site
from inertest.errors import DataError, IdentifiabilityError, InertestWarning, PlanError
from inertest.estimation.noise_models import MODELS
from inertest.models.rate_gyro import triad_from_truth
from inertest.models.triad import TriadCalibration
from inertest.plan import Instrument, Plan
from inertest.procedures import gyro_triad_rotation as gtr
from noise_generators import flicker

LAT_DEG = 34.246
L = np.radians(LAT_DEG)
TRUTH = dict(K_x=7200.0, K_y=7195.5, K_z=7203.2, M_xy=169.685, M_xz=-96.963, M_yx=58.178,
             M_yz=232.711, M_zx=-145.444, M_zy=38.785, B_x=0.5, B_y=-0.3, B_z=1.1)  # M in urad
ARCSEC = np.pi / 180 / 3600
DEG_H = ARCSEC  # 1 deg/h = 1 arcsec/s
URAD = 1e-6


def make_plan(unit="count", **params):
    spec = gtr.GyroTriadRotationSpec.from_mapping(params)
    return Plan(Site.at(LAT_DEG), Instrument(kind="gyro-triad", output_unit=unit), spec)


def test_seed003_counts_of_a_turn_about_the_vertical_axis():
    """z up, constant rate, no misalignment: N_z = K_z (+-2 pi + W sinL T) + K_z B_z T, and the
    horizontal gyros count the Earth rate only while at rest (it averages out over the turn)."""
    plan = make_plan(rate_deg_s=12.0, rotation_window_s=40.0,
                     rotations=[{"attitude": "ENU", "axis": "z"}], static_attitudes=[])
    truth = {"K_x": 7200.0, "K_y": 7190.0, "K_z": 7210.0, "B_x": 0.2, "B_y": 0.4, "B_z": 0.9}
    data = inertest.simulate(plan, truth)
    k = np.array([7200.0, 7190.0, 7210.0]) * 180 / np.pi  # count/rad
    T, t_rot = 40.0, 30.0
    for row, d in enumerate((1, -1)):
        nz = k[2] * (d * 2 * np.pi + OMEGA_IE * np.sin(L) * T + 0.9 * DEG_H * T)
        ny = k[1] * (OMEGA_IE * np.cos(L) * (T - t_rot) + 0.4 * DEG_H * T)
        nx = k[0] * 0.2 * DEG_H * T
        np.testing.assert_allclose(
            [data["counts_x"][row], data["counts_y"][row], data["counts_z"][row]],
            [nx, ny, nz], rtol=1e-12, atol=1e-8)


def test_exact_recovery_and_closed_form_scale():
    plan = make_plan(rate_deg_s=20.0, rotation_window_s=22.0)
    res = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=0.5)
    for name, value in TRUTH.items():
        e = res.coefficients[name]
        tol = {"count/deg": 1e-9, "urad": 5e-6, "deg/h": 1e-8}[e.unit]
        assert e.value == pytest.approx(value, abs=tol), name
    # Closed form (N_j(+) - N_j(-))/(4 pi): the Earth rate cancels between the directions.
    for name, value in res.closed_form_scale.items():
        assert value == pytest.approx(TRUTH[name], rel=1e-12)


def test_exact_recovery_with_acceleration_and_rate_output():
    truth = {**TRUTH, "K_x": 1.0003, "K_y": 0.9998, "K_z": 1.0001}
    plan = make_plan(unit="deg/s", rate_deg_s=30.0, accel_deg_s2=5.0)
    res = inertest.fit(plan, inertest.simulate(plan, truth), sigma=1e-6)
    assert res.coefficients["K_x"].unit == "1"
    for name, value in truth.items():
        assert res.coefficients[name].value == pytest.approx(value, abs=1e-7), name


def test_calibration_block_inverts_the_output_model():
    plan = make_plan()
    res = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=0.5)
    A, b = triad_from_truth(TRUTH, "count")
    w = np.random.default_rng(0).normal(scale=0.5, size=(10, 3))  # rad/s
    raw = w @ A.T + b  # count/s
    gyro = res.calibration.gyroscope
    assert gyro.raw_unit == "count/s" and gyro.unit == "rad/s"
    np.testing.assert_allclose(gyro.matrix @ (raw[0] - gyro.offset), w[0], rtol=1e-9)
    back = TriadCalibration.from_dict(res.to_dict()["result"]["calibration"]["gyroscope"])
    np.testing.assert_allclose(back.apply(raw), w, rtol=1e-9, atol=1e-12)


def test_rotations_about_one_axis_only_name_what_is_missing():
    plan = make_plan(rotations=[{"attitude": "UEN", "axis": "x"}])
    data = inertest.simulate(plan, TRUTH)
    with pytest.raises(IdentifiabilityError) as exc:
        inertest.fit(plan, data, sigma=1.0)
    msg = str(exc.value)
    assert "no rotation about y: K_y, M_xy, M_zy" in msg and "M_yx, M_yz (need K_y)" in msg
    assert 'attitude "NUE", y up' in msg


def test_one_direction_without_static_windows():
    plan = make_plan(directions=[1], static_attitudes=[])
    with pytest.raises(IdentifiabilityError, match="rotations about x run in one direction only"
                       ".*add rotations about x with direction -1, or static positions"):
        inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1.0)
    # With static windows one direction suffices.
    plan = make_plan(directions=[1])
    res = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1.0)
    assert res.coefficients["K_z"].value == pytest.approx(TRUTH["K_z"], rel=1e-12)


def test_mislabelled_axis_and_direction():
    plan = make_plan()
    data = inertest.simulate(plan, TRUTH)
    bad = {k: v.copy() for k, v in data.items()}
    bad["axis"][0] = "y"
    with pytest.raises(DataError, match='data row 1 .* labelled a rotation about y, but gyro x '
                                        "counted the turn"):
        inertest.fit(plan, bad, sigma=1.0)
    bad = {k: v.copy() for k, v in data.items()}
    bad["direction"][1] = 1.0
    with pytest.raises(DataError, match="data row 2 .*fix the direction column"):
        inertest.fit(plan, bad, sigma=1.0)
    bad = {k: v.copy() for k, v in data.items()}
    bad["attitude"][3] = "ENE"
    with pytest.raises(DataError, match="data row 4: .*not an orthogonal triad"):
        inertest.fit(plan, bad, sigma=1.0)


def test_too_few_windows_and_bad_plan():
    plan = make_plan(static_attitudes=[], directions=[1, -1],
                     rotations=[{"attitude": "UEN", "axis": "x"}, {"attitude": "NUE", "axis": "y"}])
    with pytest.raises(IdentifiabilityError, match="no rotation about z"):
        inertest.fit(plan, inertest.simulate(plan, TRUTH))
    with pytest.raises(PlanError, match="shorter than one turn"):
        make_plan(rate_deg_s=10.0, rotation_window_s=30.0)
    with pytest.raises(PlanError, match='noise_model = "pink" is not one of auto, white'):
        make_plan(noise_model="pink")
    with pytest.raises(PlanError, match="unknown name"):
        inertest.simulate(make_plan(), {"K_w": 1.0})
    with pytest.raises(PlanError, match="needs the scale factors K_x, K_y, K_z in count/deg"):
        inertest.simulate(make_plan(), {"B_x": 1.0})


@pytest.mark.slow
@pytest.mark.parametrize("model, noise", [("constant", 30.0), ("sqrt-window", 4.0)])
def test_monte_carlo_stated_uncertainties(model, noise):
    plan = make_plan(rate_deg_s=20.0, accel_deg_s2=10.0, window_noise=model, repeats=2)
    rng = np.random.default_rng(5)
    n = 300
    est = np.empty((n, 12))
    std = np.empty((n, 12))
    for r in range(n):
        with warnings.catch_warnings():  # the model checks' false alarms at alpha = 1e-3
            warnings.simplefilter("ignore", InertestWarning)
            res = inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=noise, rng=rng))
        est[r] = [res.coefficients[k].value for k in gtr.NAMES]
        std[r] = [res.coefficients[k].std for k in gtr.NAMES]
    ratio = std.mean(axis=0) / est.std(axis=0, ddof=1)
    np.testing.assert_allclose(ratio, 1.0, atol=0.2)
    bias = est.mean(axis=0) - [TRUTH[k] for k in gtr.NAMES]
    assert np.all(np.abs(bias) < 4 * est.std(axis=0, ddof=1) / np.sqrt(n))


@pytest.mark.slow
def test_real_imucal_session_agrees_with_imucal_ferraris(realdata_dir):
    """Real MEMS IMU (imucal's annotated Ferraris session, 204.8 Hz): six static faces and one
    hand-made turn about each axis. Peer tool: imucal's FerrarisCalibration, whose gyro matrix
    K_g R_g is the integrated turn / 360 deg after removing the static bias and g-sensitivity;
    ours is A = K (I + M) from the same windows (no g-sensitivity; Earth rate with assumed
    headings, ~0.004 deg/s). Scale factors agree to 1e-4; the cross terms to within the stated
    uncertainty (imucal's g-sensitivity correction is of that size)."""
    pd = pytest.importorskip("pandas")
    imucal = pytest.importorskip("imucal")
    raw = pd.read_csv(realdata_dir / "imucal" / "annotated_session.csv")
    fs = 204.8
    regions = imucal.ferraris_regions_from_df(raw.set_index("part"))
    peer = imucal.FerrarisCalibration(expected_angle=360).compute(
        regions, fs, from_acc_unit="a.u.", from_gyr_unit="a.u.")
    peer_forward = peer.K_g @ peer.R_g  # LSB per deg/s
    # x_p: x up; x_a: x down; headings unknown, so any right-handed letters with that axis up.
    attitude = {"x_p": "UEN", "x_a": "DWN", "y_p": "NUE", "y_a": "SDE", "z_p": "ENU",
                "z_a": "WND", "x_rot": "UEN", "y_rot": "NUE", "z_rot": "ENU"}
    rows = []
    for part, g in raw.groupby("part", sort=False):
        turn = part.endswith("rot")
        rows.append((part, attitude[part], part[0] if turn else "static", 1.0 if turn else 0.0,
                     len(g) / fs, *(g[f"gyr_{a}"].sum() / fs for a in "xyz")))
    names = ["part", "attitude", "axis", "direction", "duration_s", "counts_x", "counts_y",
             "counts_z"]
    data = {n: np.array([r[i] for r in rows]) for i, n in enumerate(names)}
    spec = gtr.GyroTriadRotationSpec.from_mapping({"rate_deg_s": 120.0, "rotation_window_s": 5.0})
    plan = Plan(Site.at(49.6), Instrument(kind="imu", output_unit="count"), spec)
    res = inertest.fit(plan, data)  # raw LSB read as count/s, so K is in LSB per deg/s
    ours = res.forward * np.pi / 180
    np.testing.assert_allclose(np.diag(ours), np.diag(peer_forward), rtol=1e-4)
    for i in range(3):
        for j in range(3):
            if i != j:
                std = res.coefficients[f"M_{'xyz'[i]}{'xyz'[j]}"].std * URAD * ours[i, i]
                assert abs(ours[i, j] - peer_forward[i, j]) < 3 * std
    np.testing.assert_allclose(res.offset, peer.b_g, atol=0.1)  # LSB; Earth rate 0.07 LSB


def test_convention_misalignment_scale_bias_by_hand():
    """Counts written by hand, N = K (I + M) Theta + K (I + M) B T (numpy, not the model), for a
    pulse triad of 7200 count/deg with only M_xy = 100 urad (gyro x sees rate about y) and a
    positive B_x: the fit reports M_xy = 100 urad, M_yx = 0, K = 7200 count/deg, B_x = +0.5 deg/h.
    Theta (table turn plus Earth rate) is the equipment kinematics, not the triad model."""
    plan = make_plan(rate_deg_s=20.0, rotation_window_s=22.0)
    rows = gtr.plan_rows(plan.procedure)
    theta = gtr.body_angles(rows["attitude"], rows["axis"], rows["direction"],
                            rows["duration_s"], gtr.GyroTriadRotation().motion(plan))
    A = 7200.0 * 180 / np.pi * (np.eye(3) + np.array([[0, 100e-6, 0], [0, 0, 0], [0, 0, 0]]))
    b = A @ np.array([0.5 * DEG_H, 0.0, 0.0])
    counts = theta @ A.T + np.outer(rows["duration_s"], b)
    data = {**rows, **{f"counts_{a}": counts[:, i] for i, a in enumerate("xyz")}}
    c = inertest.fit(plan, data, sigma=0.5).coefficients
    assert c["M_xy"].value == pytest.approx(100.0, abs=1e-6) and c["M_xy"].unit == "urad"
    assert abs(c["M_yx"].value) < 1e-6
    assert c["K_z"].value == pytest.approx(7200.0, rel=1e-12) and c["K_z"].unit == "count/deg"
    assert c["B_x"].value == pytest.approx(0.5, rel=1e-9) and c["B_x"].unit == "deg/h"


@pytest.mark.parametrize(("params", "msg"), [
    ({"rate_deg_s": True}, r"rate_deg_s must be a number \[deg/s\], got True"),
    ({"accel_deg_s2": -1.0}, "accel_deg_s2 must be positive"),
    ({"repeats": 1.5}, "repeats must be a whole number"),
    ({"directions": [2]}, "directions must be a list of 1 and/or -1"),
    ({"rate_degs": 5.0}, 'unknown key.*rate_degs .*did you mean "rate_deg_s"'),
])
def test_plan_fields_refuse_wrong_types_and_misspelt_keys(params, msg):
    with pytest.raises(PlanError, match=msg):
        gtr.GyroTriadRotationSpec.from_mapping(params)


def _window_noise(case, duration_s, rng, reps, sw=20.0):
    """Count noise of back-to-back windows, integrated from a rate-noise series sampled each
    second (written here, independent of the fit's kernels): white rate noise sw [count/s per
    1-s sample] (angle random walk sw count/sqrt(s)), plus per-window rate offsets of the size
    of a mean window's white noise, a rate random walk (0.5 count/s per sqrt(s)), or
    FFT-shaped 1/f noise of 10 count/s rms. Shape (reps, 3, windows)."""
    edges = np.r_[0, np.cumsum(duration_s)].astype(int)
    n = edges[-1]
    rate = rng.normal(0.0, sw, (reps, 3, n))
    if case == "position-offsets":
        off = rng.normal(0.0, sw / np.sqrt(np.mean(duration_s)), (reps, 3, duration_s.size))
        rate += np.repeat(off, np.diff(edges), axis=2)
    elif case == "random-walk":
        rate += np.cumsum(rng.normal(0.0, 0.5, (reps, 3, n)), axis=2)
    elif case == "flicker":
        rate += 10.0 * flicker(rng, (reps, 3, n), per_row=False)
    cum = np.concatenate([np.zeros((reps, 3, 1)), np.cumsum(rate, axis=2)], axis=2)
    return cum[..., edges[1:]] - cum[..., edges[:-1]]


@pytest.mark.slow
@pytest.mark.parametrize("case", ["white", "position-offsets", "random-walk", "flicker"])
def test_monte_carlo_noise_model_matrix(case):
    """Issue 15: under white (angle random walk), white + per-window rate offsets, white + a
    rate random walk over the session and white + flicker, the std reported with the matching
    noise model agrees with the scatter of 150 sessions (36 windows) within 0.8-1.25 for each
    group (K, M, B), and the result names the model. Before (weighted least squares, the
    white model, on the same sessions): K/M 1.9-2.3 and B 0.13-0.15 under the random walk,
    K/M 1.45-1.7 and B 0.52-0.57 under flicker, 0.95-1.18 under offsets."""
    _assert_std_matches_scatter(case, noise_model=case)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["white", "position-offsets", "random-walk", "flicker"])
def test_monte_carlo_auto_noise_model_is_honest_under_each_noise(case):
    """``noise_model = "auto"`` on the sessions of the matrix above: reported std / scatter
    within 0.8-1.25 for each group (K, M, B) whichever the drift. The bias under flicker was
    0.78 with the choice by AIC and a spread cut at 2 of the AIC summed over the gyros (a
    random walk, whose bias estimate is poor under flicker, chosen on a third of the sessions
    with flicker left out of the spread); 0.85 with the cut at 2 per gyro
    (identify.common_noise_model)."""
    _assert_std_matches_scatter(case, noise_model="auto")


def _assert_std_matches_scatter(case, *, noise_model):
    """150 sessions (36 windows) with the window noise ``case``, fitted with ``noise_model``:
    reported std / scatter within 0.8-1.25 for each group (K, M, B); a named model is used."""
    plan = make_plan(rate_deg_s=20.0, rotation_window_s=20.0, static_window_s=40.0, repeats=3,
                     window_noise="sqrt-window")
    base = inertest.simulate(plan, TRUTH)
    reps = 150
    noise = _window_noise(case, base["duration_s"], np.random.default_rng(11), reps)
    est, std = np.empty((reps, 12)), np.empty((reps, 12))
    for r in range(reps):
        data = {**base, **{f"counts_{a}": base[f"counts_{a}"] + noise[r, i]
                           for i, a in enumerate("xyz")}}
        with warnings.catch_warnings():  # the model checks' false alarms at alpha = 1e-3
            warnings.simplefilter("ignore", InertestWarning)
            res = inertest.fit(plan, data, noise_model=noise_model)
        if noise_model != "auto":
            assert res.identification.noise_model == noise_model
        est[r] = [res.coefficients[k].value for k in gtr.NAMES]
        std[r] = [res.coefficients[k].std for k in gtr.NAMES]
    ratio = np.sqrt(np.mean(std**2, axis=0)) / est.std(axis=0, ddof=1)
    for group in (slice(0, 3), slice(3, 9), slice(9, 12)):
        assert 0.8 < np.mean(ratio[group]) < 1.25, (group, ratio[group])


def test_window_kernels_are_the_noise_models_own():
    """The procedure takes its window kernels from the one noise-model definition (tested
    against closed forms in tests/estimation/test_noise_models.py)."""
    start, dur = np.array([0.0, 10.0, 35.0]), np.array([10.0, 20.0, 5.0])
    for m in ("position-offsets", "random-walk", "flicker"):
        np.testing.assert_array_equal(gtr.window_kernel(m, start, dur),
                                      MODELS[m].window_kernel(start, dur))


def test_noise_model_named_in_the_result_and_bad_start_times():
    plan = make_plan(repeats=2, window_noise="sqrt-window", noise_model="random-walk")
    data = inertest.simulate(plan, TRUTH, noise=4.0, rng=1)
    d = inertest.fit(plan, data).to_dict()
    assert d["identification"]["noise"]["model"] == "random-walk"
    units = d["result"]["noise_components"]
    assert units["white"]["unit"] == "count/sqrt(s)"
    assert units["random walk"]["unit"] == "count/s/sqrt(s)"
    bad = {**data, "start_s": data["start_s"].copy()}
    bad["start_s"][3] = bad["start_s"][2]
    with pytest.raises(DataError, match="start_s at data row 4 is before the end"):
        inertest.fit(plan, bad)
    with pytest.raises(PlanError, match="window_noise"):
        make_plan(window_noise="white")


def test_checks_a_static_window_with_a_wrong_attitude_label_is_an_outlier():
    """Issue 15 checks under the white model, noise level fitted: consistent on simulated data;
    one static window logged "DWN" (x down) but run in "UEN" (x up) is the one outlier, on gyro
    x, whose misfit is the vertical Earth rate counted the other way, K_x 2 W_ie sin L T (by hand
    below). With the level fitted a window's standardised residual cannot exceed about
    sqrt(dof): two windows' labels swapped (two opposite outliers) are not seen then; with the
    level given the chi-square and both windows show."""
    plan = make_plan(repeats=3)
    data = inertest.simulate(plan, TRUTH, noise=2.0, rng=3)
    r = inertest.fit(plan, data, noise_model="white")
    checks = r.to_dict()["checks"]
    assert checks[0]["verdict"] == "consistent" and checks[0]["unit"] == "window"
    k = int(np.flatnonzero(data["attitude"] == "UEN")[2])  # the first static UEN window
    assert data["axis"][k] == "static"
    bad = {c: np.array(v, copy=True) for c, v in data.items()}
    bad["attitude"][k] = "DWN"
    with pytest.warns(InertestWarning, match="does not fit.*gyro x, window 7"):
        r = inertest.fit(plan, bad, noise_model="white")
    c = r.identification.checks
    assert c.verdict == "model does not fit"
    assert [o.label for o in c.outliers] == [f"gyro x, window {k + 1} (UEN static)"]
    assert abs(c.outliers[0].z) > c.outlier_threshold
    # By hand: the rate along x is W_ie sin L with x up, -W_ie sin L with x down; the misfit of
    # gyro x in window k is K_x 2 W_ie sin L T [count], far above the 2-count noise.
    T = data["duration_s"][k]
    miss = TRUTH["K_x"] * np.degrees(2 * OMEGA_IE * np.sin(L)) * T
    assert abs(r.counts[k, 0] - r.fitted_counts[k, 0]) == pytest.approx(miss, rel=0.3)
    # Two static windows' labels swapped: seen with the noise level given.
    bad = {c: np.array(v, copy=True) for c, v in data.items()}
    bad["attitude"][k], bad["attitude"][k + 1] = data["attitude"][k + 1], data["attitude"][k]
    with pytest.warns(InertestWarning, match="chi-square"):
        r = inertest.fit(plan, bad, noise_model="white", sigma=2.0)
    c = r.identification.checks
    assert c.p_value < 1e-6
    assert {f"gyro x, window {k + 1} (UEN static)",
            f"gyro x, window {k + 2} (DWN static)"} <= {o.label for o in c.outliers}
