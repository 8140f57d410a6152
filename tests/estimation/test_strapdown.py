"""Static-base navigation and its sensitivities and noise covariance (estimation.strapdown).

References: closed forms (a unit at rest: zero; a constant accelerometer error: a straight
line; a gyro error: the quadratic of a tilt), brute force (the noise covariance as the explicit
sum over every sample's response, ``L Sigma L^T``), finite differences of the nonlinear
navigation.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from inertest.earth import earth_rate_enu
from inertest.estimation import strapdown as nav

LAT = np.radians(34.0)
G = 9.7964
DT = 0.1
M = 10


def _rest(n: int, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact rates and specific forces of a unit at rest in attitude C for n samples.

    At rest the body turns with the Earth: the exact increment of each sample is the rotation
    of the local frame over it, and the specific force is constant in the local frame.
    """
    w = np.tile(C.T @ earth_rate_enu(LAT), (n, 1))
    f = np.tile(C.T @ np.array([0.0, 0.0, G]), (n, 1))
    return w, f


def test_quaternion_product_is_rotation_composition():
    rng = np.random.default_rng(0)
    p, q = Rotation.random(50, random_state=rng), Rotation.random(50, random_state=rng)
    got = nav.quaternion_product(p.as_quat().T, q.as_quat().T).T
    assert np.allclose(Rotation.from_quat(got).as_matrix(), (p * q).as_matrix(), atol=1e-14)
    inc = Rotation.random(37, random_state=rng)
    scan = nav.cumulative_rotation(inc)
    ref = inc[0]
    for k in range(1, 37):
        ref = ref * inc[k]
    assert np.allclose(scan[-1].as_matrix(), ref.as_matrix(), atol=1e-13)


def test_a_unit_at_rest_navigates_to_zero_velocity():
    C = Rotation.from_euler("ZXY", [30, 10, -20], degrees=True).as_matrix()
    w, f = _rest(3000, C)
    nv = nav.navigate(w, f, DT, C, latitude_rad=LAT, gravity_m_s2=G, block=M)
    # body and local frame turn together with the Earth: the attitude stays C to its rounding
    # (1e-12 rad after 3000 compositions), the velocity zero to g times that (300 s)
    assert np.max(np.abs(nv.u)) < 1e-8


def test_a_constant_accelerometer_error_is_a_straight_line_and_a_gyro_error_a_parabola():
    C = Rotation.from_euler("ZXY", [0, 0, 0], degrees=True).as_matrix()
    w, f = _rest(2000, C)
    df = np.array([1e-4, -2e-4, 3e-4])
    nv = nav.navigate(w, f + df, DT, C, latitude_rad=LAT, gravity_m_s2=G, block=M)
    t = (np.arange(nv.n_blocks) + 1) * M * DT
    np.testing.assert_allclose(nv.u, np.outer(t, C @ df), rtol=1e-6, atol=1e-12)
    # a gyro error d about east tilts the frame by phi = -d t: u_N = g phi_E t / 2... exactly
    # u' = f_n x phi, phi = -(d t) e_E (the Earth coupling is 1e-5 of it over 200 s)
    d = 1e-7
    nv = nav.navigate(w + np.array([d, 0, 0]), f, DT, C, latitude_rad=LAT, gravity_m_s2=G,
                      block=M)
    np.testing.assert_allclose(nv.u[:, 1], -G * d * t**2 / 2, rtol=2e-3)


def _turning_record():
    """A unit turning 90 deg about y then x at rest between (exact increments, a few samples)."""
    t = np.arange(400) * DT
    C0 = Rotation.from_euler("ZXY", [20, 5, -10], degrees=True)
    rate = np.zeros((400, 3))
    rate[100:150, 1] = np.pi / 2 / 5.0
    rate[250:300, 0] = np.pi / 2 / 5.0
    att = [C0]
    for k in range(399):
        att.append(att[-1] * Rotation.from_rotvec(rate[k] * DT))
    del t
    C = np.array([a.as_matrix() for a in att])
    w = rate + np.einsum("nji,j->ni", C, earth_rate_enu(LAT))
    f = np.einsum("nji,j->ni", C, np.array([0.0, 0.0, G]))
    return C0.as_matrix(), w, f


def test_sensitivity_is_the_derivative_of_the_navigation():
    C0, w, f = _turning_record()
    base = nav.navigate(w, f, DT, C0, latitude_rad=LAT, gravity_m_s2=G, block=M)
    # errors of a sensor (a bias and a scale-factor error of each axis), not white noise:
    # the coning term of the attitude turns sample-to-sample jitter by (dtheta / 12), 0.3 %
    # in these turns, while for a smooth error its two halves cancel
    # (small enough that the second order, g phi^2 / 2 in the vertical, stays below 1e-5)
    dw = np.array([2e-8, -1e-8, 3e-8]) + w * np.array([3e-6, -2e-6, 1e-6])
    df = np.array([1e-4, -2e-4, 5e-5]) + f * np.array([-2e-5, 1e-5, 3e-5])
    # the error inputs of one "parameter" with these per-sample errors
    gs = nav.block_moments(base, dw, weighted=False)  # (nb, 3 series, 3, 3)
    gw = nav.block_moments(base, dw, weighted=True)
    ac = nav.block_moments(base, df, weighted=False)
    e = np.eye(3)
    to = lambda moments: np.einsum("bkij,kj->bi", moments, e)[:, :, None]  # noqa: E731
    lin = nav.propagate(base, nav.ErrorInputs(to(gs), to(gw), to(ac)))[:, :, 0]
    moved = nav.navigate(w + dw, f + df, DT, C0, latitude_rad=LAT, gravity_m_s2=G, block=M)
    # first order: its discretisation of a sample's own rotation differs from the navigation's
    # by O(dtheta) of the gyro terms (1e-3 at this record's 1.8 deg per sample, 1e-4 at
    # 100 Hz and 20 deg/s), which only slows Gauss-Newton's last digits
    np.testing.assert_allclose(lin, moved.u - base.u, rtol=0,
                               atol=2e-3 * np.max(np.abs(lin)))


def _brute_force_responses(nv, blocks, C_nb):
    """Response of u at each observation to a unit error on each channel at each sample."""
    n = C_nb.shape[0]
    o = (np.asarray(blocks) + 1) * nv.block - 1
    F = np.array([[0, -G, 0], [G, 0, 0], [0, 0, 0.0]])
    L = np.zeros((6, 3 * o.size, n))
    for i in range(n):
        for a, oa in enumerate(o):
            if i > oa:
                continue
            for ch in range(3):
                L[ch, 3 * a:3 * a + 3, i] = -F @ C_nb[i][:, ch] * DT * DT * (oa - i + 0.5)
                L[3 + ch, 3 * a:3 * a + 3, i] = C_nb[i][:, ch] * DT
    return L


def test_white_and_random_walk_covariance_against_brute_force():
    C0, w, f = _turning_record()
    nv = nav.navigate(w, f, DT, C0, latitude_rad=LAT, gravity_m_s2=G, block=M)
    blocks = np.array([3, 7, 9, 20, 33, 39])
    L = _brute_force_responses(nv, blocks, nv.C_nb)
    var = np.array([1e-10, 2e-10, 3e-10, 1e-6, 2e-6, 3e-6])
    brute = sum(var[c] * L[c] @ L[c].T for c in range(6))
    np.testing.assert_allclose(nav.white_covariance(nv, blocks, var), brute, rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(brute)))
    # a random walk of each bias over blocks: the block responses are the sample responses
    # summed over each block, and the walk's covariance min(i, j) + 1 steps of K^2 h
    resp = nav.block_responses(nv, blocks)
    nb = nv.n_blocks
    summed = L[:, :, :nb * M].reshape(6, L.shape[1], nb, M).sum(axis=3)
    np.testing.assert_allclose(resp, summed, rtol=1e-9, atol=1e-12 * np.max(np.abs(summed)))
    K = np.array([1e-7, 0, 2e-7, 1e-5, 0, 0])
    h = M * DT
    idx = np.arange(nb)
    W = (np.minimum.outer(idx, idx) + 1) * h
    brute = sum(K[c] ** 2 * resp[c] @ W @ resp[c].T for c in range(6))
    got = nav.correlated_covariance(resp, "random-walk", K, block_s=h)
    np.testing.assert_allclose(got, brute, rtol=1e-9, atol=1e-12 * np.max(np.abs(brute)))


def test_flicker_level_is_the_bias_instability_of_ieee_952():
    """A block-mean flicker process of bias instability B has variance (B^2 / pi) ln(s nb)
    (one-sided PSD B^2 / (pi f) from 1 / (2 s T) to the block Nyquist frequency)."""
    C0, w, f = _turning_record()
    nv = nav.navigate(w, f, DT, C0, latitude_rad=LAT, gravity_m_s2=G, block=M)
    nb = nv.n_blocks
    one = np.zeros((6, 1, nb))
    one[3, 0, 5] = 1.0  # one observation that is the accelerometer x's mean over block 5
    B = 1e-5
    got = nav.correlated_covariance(one, "flicker", np.r_[0, 0, 0, B, 0, 0], block_s=1.0,
                                    bias_time_scale=2.0)
    assert got[0, 0] == pytest.approx(B**2 / np.pi * np.log(2.0 * nb), rel=1e-12)
    with pytest.raises(ValueError, match="random-walk or flicker"):
        nav.correlated_covariance(one, "white", np.ones(6), block_s=1.0)
