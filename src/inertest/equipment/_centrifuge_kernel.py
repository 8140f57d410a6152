"""Fused numba kernel of the imperfect centrifuge's kinematic chain (seed 004, eqs. 1-8).

One pass over the samples: for each time the chain of :func:`inertest.equipment.centrifuge.
centrifuge_motion` is composed in 3x3 registers (no temporaries of length n), and the outputs are
written in place. The caller (:mod:`inertest.equipment.centrifuge`) feeds it blocks of samples,
so memory beyond the outputs stays O(block). This module imports numba: import it lazily, only
when kinematics are evaluated, so that the command line and the tests that do not evaluate them
start without compiling or loading numba.

Compiled with ``fastmath`` off (IEEE semantics, no reassociation) and cached on disk; the
results equal the numpy formulation of the same chain to rounding (~1e-15 relative, tested).
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: ``dgamma`` kinds understood by :func:`chain` (``dg_kind``).
DGAMMA_NONE, DGAMMA_PHASE, DGAMMA_RATE, DGAMMA_ARRAYS = 0, 1, 2, 3


@njit(cache=True, fastmath=False, nogil=True, inline="always")
def _mix(ci, cj, co, si):
    """Columns ``i, j`` of ``C R_k(angle)``, ``(i, j)`` the cyclic successors of k.

    ``c_i' = cos c_i + sin c_j``, ``c_j' = -sin c_i + cos c_j``.
    """
    return ((co * ci[0] + si * cj[0], co * ci[1] + si * cj[1], co * ci[2] + si * cj[2]),
            (-si * ci[0] + co * cj[0], -si * ci[1] + co * cj[1], -si * ci[2] + co * cj[2]))


@njit(cache=True, fastmath=False, nogil=True, inline="always")
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, fastmath=False, nogil=True, inline="always")
def _joint(e, q1, q2, wr, wd):
    """A joint about axis e (in P; the same before and after it turns) moving at q1, q2.

    ``w += e q1``, ``w' += e q2 + w x (e q1)``.
    """
    d = (e[0] * q1, e[1] * q1, e[2] * q1)
    x = _cross(wr, d)
    wd = (wd[0] + (e[0] * q2 + x[0]), wd[1] + (e[1] * q2 + x[1]), wd[2] + (e[2] * q2 + x[2]))
    return (wr[0] + d[0], wr[1] + d[1], wr[2] + d[2]), wd


@njit(cache=True, fastmath=False, nogil=True, inline="always")
def _offset(cx, cy, cz, o, wr, wd, p, v, a):
    """A body offset o: ``p += r``, ``v += w x r``, ``a += w' x r + w x (w x r)``, r = C o."""
    r = (cx[0] * o[0] + cy[0] * o[1] + cz[0] * o[2], cx[1] * o[0] + cy[1] * o[1] + cz[1] * o[2],
         cx[2] * o[0] + cy[2] * o[1] + cz[2] * o[2])
    u = _cross(wr, r)
    k = _cross(wd, r)
    m = _cross(wr, u)
    return ((p[0] + r[0], p[1] + r[1], p[2] + r[2]), (v[0] + u[0], v[1] + u[1], v[2] + u[2]),
            (a[0] + (k[0] + m[0]), a[1] + (k[1] + m[1]), a[2] + (k[2] + m[2])))


@njit(cache=True, fastmath=False, nogil=True)
def chain(t, w, radius, links, wobble, ecc, fixture, earth_p, c_pe, gravity, earth_in_acc,  # noqa: E501
          dg_kind, dg_par, dg, dg1, dg2,
          attitude, omega_ios, f_ios,
          full, attitude_p, position_p, velocity_p, acceleration_p, omega_rel_p):
    """Evaluate the chain at each time ``t[n]`` and write the outputs in place.

    Parameters
    ----------
    t : (n,) times [s]; ``w`` main-axis rate [rad/s]; ``radius`` arm radius with ``dR(w)`` [m].
    links : (4,) constant angles [rad]: ``dl_y(w)``, ``dl_z(w)``, ``dth_x1``, ``dth_y1``.
    wobble : (4,) ``ax, px, ay, py`` [rad]; ``ecc`` : (2,) ``lx, ly`` [m].
    fixture : (3, 3) fixture turn times mounting (columns I, O, S in the fixture frame).
    earth_p : (3,) Earth rate in P [rad/s]; ``c_pe`` : (3, 3) P -> ENU; ``gravity`` [m/s^2].
    dg_kind : 0 none, 1 ``a sin(2 pi f t + ph)`` with ``dg_par = (a, 2 pi f, ph)``, 2
        ``offset + rate t`` with ``dg_par = (rate, offset)``, 3 the arrays ``dg, dg1, dg2``.
    attitude (n, 3, 3), omega_ios (n, 3), f_ios (n, 3) : outputs (an ``attitude`` of no rows:
        not written, for the drift models, which need only the rate and the force); with
        ``full`` also attitude_p (n, 3, 3), position_p, velocity_p, acceleration_p,
        omega_rel_p (n, 3).
    """
    cl = np.cos(links)
    sl = np.sin(links)
    ax, px, ay, py = wobble[0], wobble[1], wobble[2], wobble[3]
    cpx, spx, cpy, spy = np.cos(px), np.sin(px), np.cos(py), np.sin(py)
    eo = (ecc[0], ecc[1], 0.0)
    has_ecc = ecc[0] != 0.0 or ecc[1] != 0.0
    W = (earth_p[0], earth_p[1], earth_p[2])
    ro = (radius, 0.0, 0.0)
    zero = (0.0, 0.0, 0.0)
    with_attitude = attitude.shape[0] > 0
    for n in range(t.size):
        tn = t[n]
        if dg_kind == 1:
            arg = dg_par[1] * tn + dg_par[2]
            amp = dg_par[0]
            s_dg = np.sin(arg)
            g0 = amp * s_dg
            g1 = amp * dg_par[1] * np.cos(arg)
            g2 = -amp * dg_par[1] * dg_par[1] * s_dg
        elif dg_kind == 2:
            g0 = dg_par[1] + dg_par[0] * tn
            g1 = dg_par[0]
            g2 = 0.0
        elif dg_kind == 3:
            g0 = dg[n]
            g1 = dg1[n]
            g2 = dg2[n]
        else:
            g0 = 0.0
            g1 = 0.0
            g2 = 0.0
        alpha = w * tn
        beta = -alpha + g0
        b1 = -w + g1
        b2 = g2
        # columns x, y, z of the running attitude C (frame axes in P), from the identity
        cx = (1.0, 0.0, 0.0)
        cy = (0.0, 1.0, 0.0)
        cz = (0.0, 0.0, 1.0)
        # main axis, arm, the constant links of the arm end and the azimuth axis
        wr, wd = _joint(cz, w, 0.0, zero, zero)
        cx, cy = _mix(cx, cy, np.cos(alpha), np.sin(alpha))
        p, v, a = _offset(cx, cy, cz, ro, wr, wd, zero, zero, zero)
        if links[0] != 0.0:
            cz, cx = _mix(cz, cx, cl[0], sl[0])
        if links[1] != 0.0:
            cx, cy = _mix(cx, cy, cl[1], sl[1])
        if links[2] != 0.0:
            cy, cz = _mix(cy, cz, cl[2], sl[2])
        if links[3] != 0.0:
            cz, cx = _mix(cz, cx, cl[3], sl[3])
        # azimuth axis and its first-harmonic wobble
        wr, wd = _joint(cz, b1, b2, wr, wd)
        cb = np.cos(beta)
        sb = np.sin(beta)
        cx, cy = _mix(cx, cy, cb, sb)
        # cos and sin of beta + px by the addition theorem (px, py constant: their cos and sin
        # once); equal to the direct form to rounding
        if ax != 0.0:
            co = cb * cpx - sb * spx
            si = sb * cpx + cb * spx
            wr, wd = _joint(cx, -ax * si * b1, -ax * co * b1**2 - ax * si * b2, wr, wd)
            q = ax * co
            cy, cz = _mix(cy, cz, np.cos(q), np.sin(q))
        if ay != 0.0:
            co = cb * cpy - sb * spy
            si = sb * cpy + cb * spy
            wr, wd = _joint(cy, -ay * si * b1, -ay * co * b1**2 - ay * si * b2, wr, wd)
            q = ay * co
            cz, cx = _mix(cz, cx, np.cos(q), np.sin(q))
        if has_ecc:
            p, v, a = _offset(cx, cy, cz, eo, wr, wd, p, v, a)
        # specific force and inertial rate in P
        f0, f1, f2 = a
        if earth_in_acc:
            k = _cross(W, p)
            u = _cross(W, v)
            m = _cross(W, k)
            f0 += 2.0 * u[0] + m[0]
            f1 += 2.0 * u[1] + m[1]
            f2 += 2.0 * u[2] + m[2]
        f2 += gravity
        i0, i1, i2 = wr[0] + W[0], wr[1] + W[1], wr[2] + W[2]
        # columns I, O, S in P: C fixture; project and rotate to ENU
        for col in range(3):
            fa, fb, fc = fixture[0, col], fixture[1, col], fixture[2, col]
            m0 = cx[0] * fa + cy[0] * fb + cz[0] * fc
            m1 = cx[1] * fa + cy[1] * fb + cz[1] * fc
            m2 = cx[2] * fa + cy[2] * fb + cz[2] * fc
            omega_ios[n, col] = m0 * i0 + m1 * i1 + m2 * i2
            f_ios[n, col] = m0 * f0 + m1 * f1 + m2 * f2
            if with_attitude:
                for r in range(3):
                    attitude[n, r, col] = c_pe[r, 0] * m0 + c_pe[r, 1] * m1 + c_pe[r, 2] * m2
            if full:
                attitude_p[n, 0, col] = m0
                attitude_p[n, 1, col] = m1
                attitude_p[n, 2, col] = m2
        if full:
            for r in range(3):
                position_p[n, r] = p[r]
                velocity_p[n, r] = v[r]
                acceleration_p[n, r] = a[r]
                omega_rel_p[n, r] = wr[r]
