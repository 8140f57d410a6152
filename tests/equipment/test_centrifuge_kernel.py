"""The compiled centrifuge chain against two independent formulations (issue 18).

* the vectorised numpy chain it replaced (kept here as the reference, unchanged), over sizes that
  cross the kernel's block boundary, every machine error on, each kind of non-synchronisation,
  both senses of the arm and the Earth-rate terms on and off: equal to ~1e-13 relative;
* a per-sample loop that composes each link with ``scipy.spatial.transform.Rotation`` products
  and propagates rate and acceleration with numpy 3-vectors (seed 004, eqs. 1-8).
"""

import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from inertest.earth import earth_rate_enu
from inertest.equipment import centrifuge as cf

R, G, LAT = 2.5, 9.8066, np.radians(45.0)
KW = {"radius_m": R, "gravity_m_s2": G, "latitude_rad": LAT}
BIG = cf.CentrifugeErrors(
    radius_poly_m=(1e-3, 2e-4), misalignment_y_poly_rad=(2e-3, 1e-3),
    misalignment_z_poly_rad=(-3e-3, 5e-4), parallelism_x_rad=0.02, parallelism_y_rad=-0.03,
    wobble_x_rad=0.04, wobble_y_rad=0.025, wobble_x_phase_rad=0.3, wobble_y_phase_rad=-1.1,
    eccentricity_x_m=0.05, eccentricity_y_m=-0.07,
)
PHASE = cf.PhaseTracking(amplitude_rad=0.1, frequency_hz=1.7, phase_rad=0.4)


def _cross(a, b):
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def _turn(c, k, angle):
    i, j = (k + 1) % 3, (k + 2) % 3
    co, si = np.cos(angle), np.sin(angle)
    ci, cj = c[:, i].copy(), c[:, j]
    c[:, i] = co * ci + si * cj
    c[:, j] = -si * ci + co * cj


def numpy_chain(t, w, position, *, radius_m, gravity_m_s2, latitude_rad, platform_heading_rad=0.0,
                errors=None, dgamma=None, earth_rotation_in_acceleration=True):
    """The vectorised numpy chain of inertest <= 0.x (component-major (3, n) arrays)."""
    tt = np.asarray(t, dtype=float)
    err = errors if errors is not None else cf.CentrifugeErrors()
    n = tt.size
    zeros = np.zeros(n)
    dg, dg1, dg2 = (zeros, zeros, zeros) if dgamma is None else dgamma.evaluate(tt)
    alpha = w * tt
    beta, beta1, beta2 = -alpha + dg, -w + dg1, dg2

    def wobble(amp, ph):
        c, s = np.cos(beta + ph), np.sin(beta + ph)
        return amp * c, -amp * s * beta1, -amp * c * beta1**2 - amp * s * beta2

    def poly(cs):
        return float(sum(c * w ** (k + 1) for k, c in enumerate(cs)))

    chain = [
        ("rot", "z", (alpha, np.full(n, w), zeros)),
        ("trans", np.array([radius_m + poly(err.radius_poly_m), 0.0, 0.0]), None),
        ("rot", "y", poly(err.misalignment_y_poly_rad)),
        ("rot", "z", poly(err.misalignment_z_poly_rad)),
        ("rot", "x", err.parallelism_x_rad),
        ("rot", "y", err.parallelism_y_rad),
        ("rot", "z", (beta, beta1, beta2)),
        ("rot", "x", wobble(err.wobble_x_rad, err.wobble_x_phase_rad) if err.wobble_x_rad else 0),
        ("rot", "y", wobble(err.wobble_y_rad, err.wobble_y_phase_rad) if err.wobble_y_rad else 0),
        ("trans", np.array([err.eccentricity_x_m, err.eccentricity_y_m, 0.0]), None),
    ]
    c = np.zeros((3, 3, n))
    c[0, 0] = c[1, 1] = c[2, 2] = 1.0
    p, v, a = np.zeros((3, n)), np.zeros((3, n)), np.zeros((3, n))
    wr, wd = np.zeros((3, n)), np.zeros((3, n))
    for kind, what, motion in chain:
        if kind == "trans":
            if not np.any(what):
                continue
            r = np.einsum("ijn,j->in", c, what)
            wxr = _cross(wr, r)
            p += r
            v += wxr
            a += _cross(wd, r) + _cross(wr, wxr)
            continue
        k = "xyz".index(what)
        if not isinstance(motion, tuple):
            if motion:
                _turn(c, k, float(motion))
            continue
        q, q1, q2 = motion
        e = c[:, k].copy()
        dw = e * q1
        wd += e * q2 + _cross(wr, dw)
        wr += dw
        _turn(c, k, q)
    c = np.einsum("ijn,jk->ikn", c, cf.position_axes(position).T)
    c_pe = cf.platform_to_enu(platform_heading_rad)
    earth_p = c_pe.T @ earth_rate_enu(latitude_rad)
    acc = a.copy()
    if earth_rotation_in_acceleration:
        e3 = np.broadcast_to(earth_p[:, None], p.shape)
        acc += 2.0 * _cross(e3, v) + _cross(e3, _cross(e3, p))
    acc[2] += gravity_m_s2
    w_in = wr + earth_p[:, None]
    return {"attitude_p": c.transpose(2, 0, 1), "attitude": np.einsum("ij,jkn->nik", c_pe, c),
            "omega_ios": np.einsum("jin,jn->ni", c, w_in),
            "f_ios": np.einsum("jin,jn->ni", c, acc), "position_p": p.T, "velocity_p": v.T,
            "acceleration_p": a.T, "omega_rel_p": wr.T}


def _close(got, ref, rel=1e-13):
    """Equal to ``rel`` of the array's scale (components can pass through zero)."""
    scale = max(np.abs(ref).max(), 1e-300)
    np.testing.assert_allclose(got, ref, rtol=0, atol=rel * scale)


def _measured():
    tm = np.linspace(-0.1, 12.0, 5001)
    return cf.MeasuredDgamma(tm, 0.05 * np.sin(1.3 * tm) + 0.01 * tm)


@pytest.mark.parametrize("dgamma", [None, PHASE, cf.RateTracking(3e-3, 0.02), "measured"])
@pytest.mark.parametrize("omega", [8.85, -4.43])
@pytest.mark.parametrize("earth", [True, False])
def test_kernel_equals_the_numpy_chain_across_blocks(dgamma, omega, earth):
    dgamma = _measured() if dgamma == "measured" else dgamma
    n = cf.BLOCK + 1234  # two blocks, the second partial
    t = np.linspace(0.0, 11.0, n)
    for pos, heading, errors in ((2, 0.7, BIG), (9, 0.0, None)):
        kw = dict(KW, platform_heading_rad=heading, errors=errors, dgamma=dgamma,
                  earth_rotation_in_acceleration=earth)
        m = cf.centrifuge_motion(t, omega, pos, **kw)
        ref = numpy_chain(t, omega, pos, **kw)
        for name, value in ref.items():
            _close(getattr(m, name), value)
        f, w, att = cf.instrument_inputs(t, omega, pos, **kw)
        np.testing.assert_array_equal(f, m.f_ios)
        np.testing.assert_array_equal(w, m.omega_ios)
        np.testing.assert_array_equal(att, m.attitude)


def _rotation_chain(ts, w, pos, errors, dgamma, heading):
    """One sample, link by link: scipy Rotation products, rates and accelerations as vectors."""
    e = errors
    dg, dg1, dg2 = (float(x[0]) for x in dgamma.evaluate(np.array([ts])))
    beta, b1, b2 = -w * ts + dg, -w + dg1, dg2

    def poly(cs):
        return sum(c * w ** (k + 1) for k, c in enumerate(cs))

    def wob(amp, ph):
        c, s = np.cos(beta + ph), np.sin(beta + ph)
        return amp * c, -amp * s * b1, -amp * (c * b1**2 + s * b2)

    axis = np.eye(3)
    links = [("r", 2, (w * ts, w, 0.0)), ("t", [R + poly(e.radius_poly_m), 0.0, 0.0]),
             ("r", 1, (poly(e.misalignment_y_poly_rad), 0.0, 0.0)),
             ("r", 2, (poly(e.misalignment_z_poly_rad), 0.0, 0.0)),
             ("r", 0, (e.parallelism_x_rad, 0.0, 0.0)), ("r", 1, (e.parallelism_y_rad, 0.0, 0.0)),
             ("r", 2, (beta, b1, b2)), ("r", 0, wob(e.wobble_x_rad, e.wobble_x_phase_rad)),
             ("r", 1, wob(e.wobble_y_rad, e.wobble_y_phase_rad)),
             ("t", [e.eccentricity_x_m, e.eccentricity_y_m, 0.0])]
    rot = Rotation.identity()
    p, v, a, om, omd = (np.zeros(3) for _ in range(5))
    for link in links:
        if link[0] == "t":
            r = rot.apply(link[1])
            p, v = p + r, v + np.cross(om, r)
            a = a + np.cross(omd, r) + np.cross(om, np.cross(om, r))
            continue
        k, (q, q1, q2) = link[1], link[2]
        ax = rot.apply(axis[k])
        omd = omd + ax * q2 + np.cross(om, ax * q1)
        om = om + ax * q1
        rot = rot * Rotation.from_rotvec(axis[k] * q)
    rot = rot * Rotation.from_rotvec([0.0, cf.fixture_angle_rad(pos), 0.0])
    rot = rot * Rotation.from_matrix(cf.mounting_axes(pos).T)
    # x_P at azimuth `heading` clockwise from north, z_P up: P is ENU turned by 90 deg - heading
    c_pe = Rotation.from_euler("z", np.pi / 2 - heading)
    earth = c_pe.inv().apply(earth_rate_enu(LAT))
    f = a + 2 * np.cross(earth, v) + np.cross(earth, np.cross(earth, p)) + [0.0, 0.0, G]
    return rot.inv().apply(f), rot.inv().apply(om + earth), (c_pe * rot).as_matrix()


@pytest.mark.parametrize("position", [1, 5, 8])
def test_kernel_equals_scipy_rotation_products_sample_by_sample(position):
    t = np.linspace(0.0, 7.0, 23)
    w, heading = -8.85, 0.4
    f, om, att = cf.instrument_inputs(t, w, position, platform_heading_rad=heading, errors=BIG,
                                      dgamma=PHASE, **KW)
    for k, ts in enumerate(t):
        f_ref, w_ref, c_ref = _rotation_chain(ts, w, position, BIG, PHASE, heading)
        np.testing.assert_allclose(f[k], f_ref, rtol=0, atol=1e-12 * R * w**2)
        np.testing.assert_allclose(om[k], w_ref, rtol=0, atol=1e-13 * abs(w))
        np.testing.assert_allclose(att[k], c_ref, rtol=0, atol=1e-14)


def test_empty_times_give_empty_outputs():
    f, w, att = cf.instrument_inputs(np.empty(0), 4.43, 3, **KW)
    assert f.shape == w.shape == (0, 3) and att.shape == (0, 3, 3)


def test_importing_the_centrifuge_does_not_load_numba():
    code = ("import sys, inertest.equipment.centrifuge, "
            "inertest.procedures.centrifuge_nine_position; sys.exit('numba' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
