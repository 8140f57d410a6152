"""Navigation-mode iterative calibration (seed 003, sec. 1.3): attitude integration, the
first-order heading error of a turn, convergence to the truth, identifiability, Monte Carlo."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from inertest.equipment import rate_table as table
from inertest.errors import DataError, IdentifiabilityError
from inertest.models import triad
from inertest.procedures import navigation_calibration as nc

LAT = np.radians(34.246)
ARCSEC = np.pi / 180 / 3600
K = np.array([7200.0, 7195.5, 7203.2]) * 180 / np.pi  # count/rad
M = np.array([[0, 35, -20], [12, 0, 48], [-30, 8, 0]]) * ARCSEC
A_TRUE = np.diag(K) @ (np.eye(3) + M)
B_TRUE = np.array([0.5, -0.3, 1.1]) * ARCSEC  # deg/h -> rad/s
b_TRUE = A_TRUE @ B_TRUE
TURNS = [("x+", "UEN", 0, 1), ("x-", "UEN", 0, -1), ("y+", "NUE", 1, 1), ("y-", "NUE", 1, -1),
         ("z+", "ENU", 2, 1), ("z-", "ENU", 2, -1)]


def segments(profile, *, rate_hz=100.0, noise=0.0, rng=None, turns=TURNS, A=A_TRUE, b=b_TRUE):
    return nc.simulate_segments(
        [(lab, table.triad_attitude(att), ax, d) for lab, att, ax, d in turns], profile,
        forward=A, offset=b, latitude_rad=LAT, sample_rate_hz=rate_hz, noise=noise, rng=rng)


def test_prefix_scan_equals_sequential_product():
    rots = Rotation.from_rotvec(np.random.default_rng(1).normal(scale=0.3, size=(37, 3)))
    scan = nc.cumulative_rotation(rots)
    acc = rots[0]
    for k in range(1, 37):
        acc = acc * rots[k]
        assert (scan[k] * acc.inv()).magnitude() < 1e-13


def test_true_calibration_reproduces_the_table_attitude():
    prof = table.RotationProfile(np.radians(20.0), np.radians(10.0))
    for rec in segments(prof, turns=TURNS[3:5]):
        inc = (rec.counts - np.outer(rec.dt, b_TRUE)) @ np.linalg.inv(A_TRUE).T
        nav = nc.integrate_attitude(rec, inc, LAT)
        err = (nav * rec.table_attitude().inv()).magnitude()
        assert err.max() < 0.01 * ARCSEC


def test_seed003_heading_error_after_a_turn_is_the_scale_factor_error():
    """z up, K_z overestimated by eps: the computed turn falls short by 2 pi eps (first order),
    about the up axis, in the turn's direction; tilt errors of misalignment cancel over the turn."""
    eps = 500e-6
    prof = table.RotationProfile(np.radians(30.0))
    recs = segments(prof)
    A0 = A_TRUE.copy()
    A0[2] *= 1 + eps
    res = nc.iterate_calibration(recs, A0, b_TRUE, latitude_rad=LAT, max_iterations=1)
    end = res.history[0].end_error_arcsec * ARCSEC
    for seg, (_, _, axis, d) in enumerate(TURNS):
        if axis == 2:
            assert end[seg, 2] == pytest.approx(-d * 2 * np.pi * eps / (1 + eps), rel=1e-3)
            assert np.hypot(end[seg, 0], end[seg, 1]) < 1e-3 * abs(end[seg, 2])


def test_converges_to_the_truth_from_a_wrong_calibration():
    prof = table.RotationProfile(np.radians(20.0), np.radians(10.0))
    recs = segments(prof)
    A0 = np.diag(K * (1 + np.array([2e-3, -1e-3, 1.5e-3])))  # 0.1-0.2 % off, no misalignment
    res = nc.iterate_calibration(recs, A0, np.zeros(3), latitude_rad=LAT)
    assert res.converged and len(res.history) <= 5
    k, m, bias = nc.decompose(A_TRUE, b_TRUE)
    np.testing.assert_allclose(res.scale, k, rtol=1e-10)
    np.testing.assert_allclose(res.misalignment_rad, m, atol=1e-3 * ARCSEC)
    np.testing.assert_allclose(res.bias_rad_s, bias, atol=1e-4 * ARCSEC)
    rms = [h.attitude_error_rms_arcsec for h in res.history]
    assert rms[0] > 100 and all(b < a / 50 for a, b in zip(rms, rms[1:], strict=False))
    assert np.abs(res.history[0].scale_correction_ppm).max() == pytest.approx(2000, rel=1e-2)


def test_without_bias_estimation_the_bias_is_kept():
    prof = table.RotationProfile(np.radians(20.0))
    recs = segments(prof)
    A0 = A_TRUE @ np.diag([1.001, 1.0, 0.999])
    res = nc.iterate_calibration(recs, A0, b_TRUE, latitude_rad=LAT, estimate_bias=False)
    np.testing.assert_array_equal(res.offset, b_TRUE)
    np.testing.assert_allclose(res.forward, A_TRUE, atol=1e-9 * K.max())  # 1e-9 rad
    assert np.all(np.isnan(res.bias_std_rad_s))


def test_turns_about_one_axis_cannot_correct_the_others():
    prof = table.RotationProfile(np.radians(20.0))
    recs = segments(prof, turns=TURNS[4:], rate_hz=20.0)
    with pytest.raises(IdentifiabilityError, match="no navigation-mode rotation about x.*add a "
                                                   "360-degree rotation about x"):
        nc.iterate_calibration(recs, A_TRUE, b_TRUE, latitude_rad=LAT)


def test_attitudes_only_at_rest_cannot_give_the_misalignments():
    prof = table.RotationProfile(np.radians(20.0))  # 18 s turns, 5 s rest either side
    recs = segments(prof, rate_hz=20.0)
    with pytest.raises(IdentifiabilityError, match="no attitude comparison during the turns about "
                                                   "x: the misalignments M_yx, M_zx cannot be"):
        nc.iterate_calibration(recs, A_TRUE, b_TRUE, latitude_rad=LAT, check_interval_s=30.0)


def test_converges_from_a_coarse_start():
    """5 % scale-factor and 1 deg misalignment errors: Gauss-Newton still reaches the truth."""
    prof = table.RotationProfile(np.radians(20.0), np.radians(10.0))
    recs = segments(prof, rate_hz=20.0)
    M0 = np.radians(1.0) * np.array([[0, 1, -1], [1, 0, 1], [-1, 1, 0]])
    A0 = A_TRUE @ (np.diag([1.05, 0.95, 1.025]) + M0)
    res = nc.iterate_calibration(recs, A0, np.zeros(3), latitude_rad=LAT, max_iterations=20)
    assert res.converged
    k, m, _ = nc.decompose(A_TRUE, b_TRUE)
    np.testing.assert_allclose(res.scale, k, rtol=1e-10)
    np.testing.assert_allclose(res.misalignment_rad, m, atol=1e-3 * ARCSEC)


def test_mislabelled_segments():
    prof = table.RotationProfile(np.radians(20.0))
    recs = segments(prof, rate_hz=10.0)
    bad = list(recs)
    r = recs[0]
    bad[0] = nc.RotationRecord(r.label, r.C_nb0, 1, r.direction, r.time_s, r.table_angle_rad,
                               r.counts)
    with pytest.raises(DataError, match=r'segment "x\+": the table turned \+360.0 deg about y, '
                                        r"but the gyros .* turned \(\+360.\d, -0.0, \+0.0\)"):
        nc.iterate_calibration(bad, A_TRUE, b_TRUE, latitude_rad=LAT)
    bad[0] = nc.RotationRecord(r.label, r.C_nb0, 0, -1, r.time_s, r.table_angle_rad, r.counts)
    with pytest.raises(DataError, match="check the axis and direction labels"):
        nc.iterate_calibration(bad, A_TRUE, b_TRUE, latitude_rad=LAT)


def test_columns_round_trip_and_bad_columns():
    prof = table.RotationProfile(np.radians(45.0))
    recs = segments(prof, turns=TURNS[:2], rate_hz=10.0)
    cols = nc.records_to_columns(recs, ["UEN", "UEN"], raw_per_si=1.0)
    back = nc.records_from_columns(cols, raw_per_si=1.0)
    assert [r.label for r in back] == ["x+", "x-"]
    np.testing.assert_allclose(back[1].counts, recs[1].counts)
    np.testing.assert_allclose(back[0].table_angle_rad, recs[0].table_angle_rad, rtol=1e-14)
    cols["axis"][3] = "y"
    with pytest.raises(DataError, match='segment "x\\+": column axis changes'):
        nc.records_from_columns(cols, raw_per_si=1.0)
    del cols["time_s"]
    with pytest.raises(DataError, match="lacks column"):
        nc.records_from_columns(cols, raw_per_si=1.0)


@pytest.mark.slow
def test_monte_carlo_stated_uncertainties():
    """150 sessions (issue 28: 30 sessions had hinted at a std 9 % small, 2.4 sigma).

    Each estimate's error from the truth over its stated std: the RMS of these z-scores is
    1 +- 1/sqrt(2 n) = 5.8 % per quantity, so each lies in 0.8-1.2 (3.4 sigma) and their pool
    over the 12 quantities in 0.9-1.1; the +-1 sigma intervals cover the truth in 68 % of
    sessions (pooled, +-4 %). Run at 400 sessions on two seeds while writing this test: pooled
    RMS z 1.011 and 0.999, per quantity 0.92-1.06, coverage 0.679 and 0.692.
    """
    prof = table.RotationProfile(np.radians(45.0), np.radians(45.0))
    rng = np.random.default_rng(7)
    n = 150
    est = np.empty((n, 12))
    std = np.empty((n, 12))
    A0 = A_TRUE @ np.diag([1.0005, 1.0, 0.9995])
    for r in range(n):
        recs = segments(prof, rate_hz=10.0, noise=2.0, rng=rng)
        res = nc.iterate_calibration(recs, A0, b_TRUE, latitude_rad=LAT, check_interval_s=1.0)
        est[r] = np.concatenate([res.scale, res.misalignment_rad, res.bias_rad_s])
        std[r] = np.concatenate([res.scale_std, res.misalignment_std_rad, res.bias_std_rad_s])
    off = ~np.eye(3, dtype=bool)
    truth = np.concatenate([np.diag(A_TRUE), M[off], B_TRUE])  # M's off-diagonals row by row
    z = (est - truth) / std
    rms = np.sqrt((z**2).mean(axis=0))
    assert np.all((rms > 0.8) & (rms < 1.2)), rms
    assert 0.9 < np.sqrt((z**2).mean()) < 1.1
    assert 0.64 < (np.abs(z) < 1).mean() < 0.72


def test_convention_misalignment_scale_bias_by_hand():
    """The true triad written by hand, A = K (I + M) with only M_xy = 50 urad (gyro x sees rate
    about y) and b = A B with a positive B_x (numpy, not the model); starting from A0 = K (no
    misalignment), the refined result reports M_xy = 50 urad, M_yx = 0 and B_x = +0.5 deg/h, and
    K in count/deg."""
    prof = table.RotationProfile(np.radians(20.0), np.radians(10.0))
    k = 7200.0 * 180 / np.pi  # count/rad = 7200 count/deg
    A = k * (np.eye(3) + np.array([[0, 50e-6, 0], [0, 0, 0], [0, 0, 0]]))
    b = A @ np.array([0.5 * ARCSEC, 0.0, 0.0])
    recs = segments(prof, rate_hz=20.0, A=A, b=b)
    res = nc.iterate_calibration(recs, np.eye(3) * k, np.zeros(3), latitude_rad=LAT)
    m = dict(zip(triad.MISALIGNMENT_NAMES, res.misalignment_rad / 1e-6, strict=True))
    assert m["M_xy"] == pytest.approx(50.0, abs=1e-3) and abs(m["M_yx"]) < 1e-3  # urad
    assert res.scale[0] / (180 / np.pi) == pytest.approx(7200.0, rel=1e-10)  # count/deg
    assert res.bias_rad_s[0] == pytest.approx(0.5 * ARCSEC, abs=1e-4 * ARCSEC)
