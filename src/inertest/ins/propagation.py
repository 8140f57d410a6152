"""Exact error propagation of a north-pointing local-level INS on a static base.

Seed ``002_1196b4fb2ac75bfc.txt`` (INS error propagation report): the error equations
``x' = A x + B u`` of :mod:`inertest.ins.error_model`, states
``x = [dVE, dVN, dL, dlambda, phiE, phiN, phiU]`` (m/s, m/s, rad, rad, rad, rad, rad) and
constant sources ``u = [bE, bN, eE, eN, eU]`` (m/s^2, m/s^2, rad/s, rad/s, rad/s): sensor
output errors resolved in ENU, errors computed minus true, signs as stated once in
:mod:`inertest.ins.error_model` (a gyro drift enters ``phi'`` with a minus sign).

For constant inputs the solution is exact::

    x(t) = e^{A t} x0 + (int_0^t e^{A s} ds) B u

Both terms come from one matrix exponential of the augmented matrix (Van Loan 1978,
IEEE Trans. Autom. Control 23(3), doi:10.1109/TAC.1978.1101743)::

    expm([[A, B], [0, 0]] t) = [[e^{A t}, int_0^t e^{A s} ds B], [0, I]]

so there is no step-size error: the grid only chooses where the solution is sampled. The
exponentials are taken of a balanced matrix (velocities over ``sqrt(g R)``), and a uniform grid
is filled by doubling (:func:`propagate_many`): 24 h at 1 s for 13 cases takes a few tens of
milliseconds and agrees with a 40-digit reference to ~1e-13 of each state's range
(``benchmarks/bench_ins_errors.py`` compares with scipy's ``solve_ivp``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.ins.error_model import (
    INPUTS,
    STATES,
    InsSite,
    input_matrix,
    system_matrix,
)
from inertest.ins.scenario import InsScenario, time_grid

__all__ = [
    "SOURCES",
    "CharacteristicPeriods",
    "SourceResponses",
    "characteristic_periods",
    "propagate",
    "propagate_many",
    "source_responses",
    "transition",
]

#: The separate error sources, in order: the five constant inputs, then the seven initial
#: errors (suffix 0). Each is one column of the superposition in :func:`source_responses`.
SOURCES: tuple[str, ...] = (*INPUTS, *(f"{name}0" for name in STATES))

_NX = 7
_NU = 5
#: Relative tolerance within which a time grid counts as uniform (then one step transition is
#: reused by doubling; otherwise every sample gets its own matrix exponential).
_UNIFORM_RTOL = 1e-9
#: Samples per batched matrix exponential on a non-uniform grid (bounds the memory).
_EXPM_CHUNK = 8192
#: Rows (samples x cases) per chunk of the doubling products (~230 kB of states: L2 cache).
_CHUNK_ROWS = 4096


def transition(site: InsSite, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Discrete transition over ``dt`` seconds: ``x(t+dt) = F x(t) + G u`` for constant ``u``.

    Parameters
    ----------
    site : InsSite
        Linearisation point (latitude, radius, gravity, Earth rate, Coriolis on/off).
    dt : float
        Time step [s]; any real value (negative steps propagate backwards).

    Returns
    -------
    F : ndarray, shape (7, 7)
        ``e^{A dt}``.
    G : ndarray, shape (7, 5)
        ``int_0^dt e^{A s} ds B``.
    """
    phi = _expm_si(site, np.array([float(dt)]))[0]
    return phi[:_NX, :_NX].copy(), phi[:_NX, _NX:].copy()


def propagate(
    site: InsSite,
    t: ArrayLike,
    *,
    x0: ArrayLike | None = None,
    u: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Exact state history (n, 7) for initial errors ``x0`` and constant sources ``u``, SI.

    Parameters
    ----------
    site : InsSite
        Linearisation point.
    t : array_like, shape (n,)
        Sample times [s], measured from the initial state at ``t = 0``. Any finite values; a
        uniform grid is fastest (one step transition, applied by doubling).
    x0 : array_like, shape (7,), optional
        Initial errors ``[dVE, dVN, dL, dlambda, phiE, phiN, phiU]`` [m/s, m/s, rad x 5];
        zero when omitted.
    u : array_like, shape (5,), optional
        Constant sources ``[bE, bN, eE, eN, eU]`` [m/s^2, m/s^2, rad/s x 3]; zero when omitted.

    Returns
    -------
    ndarray, shape (n, 7)
        States at the times ``t``, SI.
    """
    x0a = np.zeros(_NX) if x0 is None else _vector(x0, _NX, "x0")
    ua = np.zeros(_NU) if u is None else _vector(u, _NU, "u")
    return propagate_many(site, t, x0=x0a[None, :], u=ua[None, :])[0]


def propagate_many(
    site: InsSite,
    t: ArrayLike,
    *,
    x0: ArrayLike | None = None,
    u: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Exact state histories of several cases at once (superposition of sources, sweeps).

    Parameters
    ----------
    site : InsSite
        Linearisation point.
    t : array_like, shape (n,)
        Sample times [s] from the initial state at ``t = 0``.
    x0 : array_like, shape (m, 7), optional
        Initial errors of each case, SI; zero when omitted.
    u : array_like, shape (m, 5), optional
        Constant sources of each case, SI; zero when omitted. ``x0`` and ``u`` must have the
        same number of rows ``m`` when both are given.

    Returns
    -------
    ndarray, shape (m, n, 7)
        ``out[j]`` is the history of case ``j``.

    Notes
    -----
    All cases share one transition ``[[F, G], [0, I]]``. On a uniform grid
    ``t_k = t_0 + k dt`` the samples are filled by doubling: with ``F_p, G_p`` the transition
    over ``p dt``, ``x[k + p] = F_p x[k] + G_p u`` for ``k < p``, so ``log2(n)`` matrix products
    of size ``(p m) x 7`` fill the grid; each ``F_p, G_p`` is its own matrix exponential (of
    the balanced matrix), so rounding grows only like ``log2(n)``: ~1e-13 of each state's
    range after 24 h at 1 s, against a 40-digit reference.
    """
    tt = _times(t)
    x0m, um = _cases(x0, u)
    m, n = x0m.shape[0], tt.size
    z0 = np.hstack([x0m, um])  # (m, 12)
    # Layout (n, m, 7): a block of consecutive samples is one contiguous (p*m, 7) matrix.
    xs = np.empty((n, m, _NX))
    dts = np.diff(tt)
    uniform = n > 1 and dts[0] != 0 and bool(
        np.all(np.abs(dts - dts[0]) <= _UNIFORM_RTOL * abs(dts[0]))
    )
    if not uniform:
        for i in range(0, n, _EXPM_CHUNK):
            ts = tt[i:i + _EXPM_CHUNK]
            phis = _expm_si(site, ts)  # (c, 12, 12)
            xs[i:i + ts.size] = np.einsum("cij,mj->cmi", phis[:, :_NX, :], z0)
        return xs.transpose(1, 0, 2)
    dt = (tt[-1] - tt[0]) / (n - 1)
    phi0 = _expm_si(site, tt[:1])[0] if tt[0] != 0 else np.eye(_NX + _NU)
    xs[0] = z0 @ phi0[:_NX, :].T
    # One exponential per doubling level rather than squaring the previous one: it keeps the
    # relative error near 1e-13 after 24 h at 1 s (squaring loses ~100 times more). All levels
    # in one batched call, before the big products.
    levels = 1 << np.arange(max(1, int(n - 1).bit_length()))
    steps = _expm_si(site, levels * dt)
    p = 1
    while p < n:
        step = steps[p.bit_length() - 1]
        q = min(p, n - p)
        ft, gu = step[:_NX, :_NX].T, um @ step[:_NX, _NX:].T
        # In cache-sized chunks, so the product and the source term touch memory once.
        ch = max(1, _CHUNK_ROWS // m)
        for c in range(0, q, ch):
            e = min(c + ch, q)
            block = xs[p + c:p + e]
            np.matmul(xs[c:e].reshape(-1, _NX), ft, out=block.reshape(-1, _NX))
            block += gu  # broadcast over the samples of the chunk
        p += q
    return xs.transpose(1, 0, 2)


@dataclass(frozen=True)
class SourceResponses:
    """Response of every state to every error source separately, and to all of them together.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times [s].
    sources : tuple of str
        Names of the sources (:data:`SOURCES` order), one per row of ``per_source``.
    per_source : ndarray, shape (12, n, 7)
        ``per_source[j, k, i]``: state ``i`` at ``t[k]`` caused by source ``j`` alone, SI.
    combined : ndarray, shape (n, 7)
        All sources together (their sum, by linearity; computed as its own case).
    active : tuple of bool
        Whether each source is non-zero in the scenario.
    """

    t: NDArray[np.float64]
    sources: tuple[str, ...]
    per_source: NDArray[np.float64]
    combined: NDArray[np.float64]
    active: tuple[bool, ...]


def source_responses(scenario: InsScenario, t: ArrayLike | None = None) -> SourceResponses:
    """Exact responses to each source of ``scenario`` separately and combined (superposition).

    Parameters
    ----------
    scenario : InsScenario
        Site, sources and (when ``t`` is omitted) the duration and step of the output grid.
    t : array_like, shape (n,), optional
        Sample times [s]; default ``0, step, ..., duration``.

    Returns
    -------
    SourceResponses
        13 cases propagated at once with :func:`propagate_many`.
    """
    tt = time_grid(scenario.duration_s, scenario.step_s) if t is None else _times(t)
    n_src = len(SOURCES)
    x0s = np.zeros((n_src + 1, _NX))
    us = np.zeros((n_src + 1, _NU))
    for j in range(_NU):
        us[j, j] = scenario.u[j]
    for i in range(_NX):
        x0s[_NU + i, i] = scenario.x0[i]
    x0s[-1], us[-1] = scenario.x0, scenario.u
    out = propagate_many(scenario.site, tt, x0=x0s, u=us)
    active = tuple(bool(v != 0) for v in np.concatenate([scenario.u, scenario.x0]))
    return SourceResponses(t=tt, sources=SOURCES, per_source=out[:n_src], combined=out[-1],
                           active=active)


@dataclass(frozen=True)
class CharacteristicPeriods:
    """Natural periods of the undamped error dynamics, from the eigenvalues of ``A``.

    Attributes
    ----------
    schuler_s : float
        Schuler period [s]: ``2 pi / sqrt(ws^2 + wf^2)`` from the mean of the two modulated
        Schuler frequencies (``2 pi sqrt(R/g)``, 84.4 min, when the Foucault rate is zero).
    foucault_s : float or None
        Foucault period ``2 pi / (W |sin L|)`` [s] (half the difference of the two Schuler
        frequencies); ``None`` without the Coriolis terms or on the equator.
    earth_s : float
        Earth (sidereal day) period ``2 pi / W`` [s].
    modes_s : tuple of float
        Every distinct oscillation period of ``A``, ascending [s].
    eigenvalues : ndarray, shape (7,)
        Eigenvalues of ``A`` [1/s] (purely imaginary up to rounding, one zero: longitude).
    """

    schuler_s: float
    foucault_s: float | None
    earth_s: float
    modes_s: tuple[float, ...]
    eigenvalues: NDArray[np.complex128]

    def as_dict(self) -> dict[str, float | None | list[float]]:
        """JSON-ready periods in seconds."""
        return {"schuler": self.schuler_s, "foucault": self.foucault_s, "earth": self.earth_s,
                "modes": list(self.modes_s)}


def characteristic_periods(site: InsSite) -> CharacteristicPeriods:
    """Schuler, Foucault and Earth periods from the eigenvalues of the system matrix.

    Notes
    -----
    With the Coriolis terms the characteristic polynomial of the static-base equations is
    ``s (s^2 + W^2) [(s^2 + ws^2)^2 + 4 s^2 wf^2]`` (``ws^2 = g/R``, ``wf = W sin L``; Titterton
    & Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., sec. 12.3.4), whose roots
    are ``0``, ``+-i W`` and ``+-i (sqrt(ws^2 + wf^2) +- wf)``: the Schuler oscillation
    amplitude-modulated at the Foucault rate. Without Coriolis the Schuler pair is double
    (``+-i ws``) and there is no Foucault period.
    """
    ev = np.linalg.eigvals(system_matrix(site))
    w = np.sort(np.abs(ev.imag[ev.imag > 0]))
    # Cluster equal frequencies (a double Schuler pair without Coriolis).
    distinct: list[float] = []
    for wi in w:
        if not distinct or wi > distinct[-1] * (1 + 1e-6):
            distinct.append(float(wi))
    earth_rate = site.earth_rate_rad_s
    if earth_rate > 0:
        i_earth = int(np.argmin([abs(wi - earth_rate) for wi in distinct]))
        earth_w = distinct.pop(i_earth)
        earth_s = 2 * math.pi / earth_w
    else:
        earth_s = math.inf
    if len(distinct) == 2:
        schuler_w = 0.5 * (distinct[0] + distinct[1])
        foucault_w = 0.5 * (distinct[1] - distinct[0])
        foucault_s: float | None = 2 * math.pi / foucault_w
    elif len(distinct) == 1:
        schuler_w, foucault_s = distinct[0], None
    else:  # pragma: no cover - A always has a Schuler pair
        raise InputError(f"unexpected eigenvalue structure {ev}")
    modes = tuple(sorted(float(2 * math.pi / wi) for wi in w if wi > 0))
    modes = tuple(m for i, m in enumerate(modes) if i == 0 or m > modes[i - 1] * (1 + 1e-6))
    return CharacteristicPeriods(schuler_s=2 * math.pi / schuler_w, foucault_s=foucault_s,
                                 earth_s=earth_s, modes_s=modes,
                                 eigenvalues=np.asarray(ev, dtype=np.complex128))


def _augmented(site: InsSite) -> NDArray[np.float64]:
    """``[[A, B], [0, 0]]``, 12 x 12: the constant sources as extra states with zero rate."""
    aug = np.zeros((_NX + _NU, _NX + _NU))
    aug[:_NX, :_NX] = system_matrix(site)
    aug[:_NX, _NX:] = input_matrix()
    return aug


def _balanced_augmented(site: InsSite) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The augmented matrix in the units ``z = x / d`` and the scale vector ``d`` (12,).

    Velocities are divided by ``sqrt(g R)`` (about 7.9 km/s), so that ``dV' = g phi`` and
    ``phi' = dV / R`` both have the coefficient ``ws = sqrt(g / R)``; the sources are scaled so
    that their entries are ``ws`` too. The exponential of the balanced matrix needs few
    squarings and is accurate to ~1e-15 relative; the unbalanced one (entries from 1.6e-7 to
    10) loses about three digits.
    """
    v = np.sqrt(site.gravity_m_s2 * site.radius_m)
    ws = np.sqrt(site.gravity_m_s2 / site.radius_m)
    d = np.ones(_NX + _NU)
    d[[0, 1]] = v
    d[[_NX, _NX + 1]] = v * ws
    d[_NX + 2:] = ws
    aug = _augmented(site)
    return aug * d[None, :] / d[:, None], d


def _expm_si(site: InsSite, ts: NDArray[np.float64]) -> NDArray[np.float64]:
    """``expm([[A, B], [0, 0]] t)`` for each ``t`` in ``ts`` (c, 12, 12), via the balanced form."""
    aug, d = _balanced_augmented(site)
    phis = scipy.linalg.expm(aug[None, :, :] * ts[:, None, None])
    return phis * (d[:, None] / d[None, :])[None]


def _times(t: ArrayLike) -> NDArray[np.float64]:
    tt = np.asarray(t, dtype=float)
    if tt.ndim == 0:
        tt = tt[None]
    if tt.ndim != 1 or tt.size == 0:
        raise InputError(f"times must be a non-empty 1-D array [s], got shape {tt.shape}")
    if not np.all(np.isfinite(tt)):
        raise InputError("times contain NaN or infinity; give finite times in seconds")
    return tt


def _vector(v: ArrayLike, size: int, name: str) -> NDArray[np.float64]:
    a = np.asarray(v, dtype=float)
    if a.shape != (size,):
        raise InputError(f"{name} must have shape ({size},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains NaN or infinity; give finite SI values")
    return a


def _cases(
    x0: ArrayLike | None, u: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    xa = None if x0 is None else np.atleast_2d(np.asarray(x0, dtype=float))
    ua = None if u is None else np.atleast_2d(np.asarray(u, dtype=float))
    m = xa.shape[0] if xa is not None else (ua.shape[0] if ua is not None else 1)
    if xa is None:
        xa = np.zeros((m, _NX))
    if ua is None:
        ua = np.zeros((m, _NU))
    if xa.shape != (m, _NX) or ua.shape != (m, _NU):
        raise InputError(
            f"x0 must be (m, {_NX}) and u (m, {_NU}) with the same m, got {xa.shape} and "
            f"{ua.shape}"
        )
    if not (np.all(np.isfinite(xa)) and np.all(np.isfinite(ua))):
        raise InputError("x0 or u contains NaN or infinity; give finite SI values")
    return xa, ua
