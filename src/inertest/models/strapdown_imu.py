"""The error model of a strapdown IMU as one unit: both triads and what couples them.

A navigation-grade IMU (ring-laser, fibre-optic or high-end MEMS) is calibrated as a whole
(the systematic calibration, :mod:`inertest.procedures.systematic`): besides the two triads of
:mod:`inertest.models.triad` it has terms that only show when the unit turns: the second-order
response of the accelerometers, the accelerometers' inner lever arms (the size effect: the
three proof masses are not at one point) and the time asynchrony between the gyro and the
accelerometer samples. States as PSINS ``kf/sysclbt.m`` (Yan Gongmin, BSD-2), written here in
the conventions of :mod:`inertest.models.triad`.

Forward model (what the unit reads for a true motion; SI)::

    gyro:   w_raw = S_g (w + A_g |w| + G f) + b_g                  S_g = K_g (I + M_g)
    accel:  f_i'  = f_i + e_i . (dw x r_i + w x (w x r_i)) + (R(w tGA) f - f)_i
            f_raw = S_a (f' + k2 f'^2 + A_a |f'|) + b_a            S_a = K_a (I + M_a)

``w`` the inertial angular rate and ``f`` the specific force at the reference point, both on
the body axes, ``dw`` the angular acceleration; powers and ``|.|`` element-wise.

* ``S_g``, ``S_a``, ``b``: the triad model (``M_ij``: sensor i, reference axis j; the bias adds
  to the output, reported input-referred ``B = S^-1 b``). The body frame is *defined by the
  accelerometers* (PSINS: ``Ka`` lower triangular): the x accelerometer is the x axis and the y
  accelerometer lies in the x-y plane, so ``M_a,xy = M_a,xz = M_a,yz = 0`` by definition (the
  turns determine the unit's attitude only up to that choice). All nine gyro entries are free.
* ``k2`` [1/(m/s^2)]: second-order coefficient of each accelerometer, input side: a positive
  ``k2_i`` raises the reading by ``k2_i f_i^2``. Reported as ``K2a_i`` in ug/g^2.
* ``r_i`` [m]: position of accelerometer i relative to the reference point (the z
  accelerometer, ``r_z = 0``, as PSINS), body axes; accelerometer i reads the specific force
  at its own position, the size effect ``e_i . (dw x r_i + w x (w x r_i))``. Only the
  differences between the three positions are observable from static navigation errors (a
  common offset is the velocity of a point, which vanishes between dwells).
* ``tGA`` [s]: time by which the accelerometer samples lag the gyro samples. At rest in the
  local frame ``df/dt = -w x f`` on the body axes, so ``f(t - tGA) = f + tGA (w x f)`` to
  first order (PSINS's term; the model carries the second order ``tGA^2 w x (w x f) / 2`` of
  the rotation ``R(w tGA)`` too, 2e-7 g at 2 ms and 20 deg/s).
* options: ``G`` gyro g-sensitivity [rad/s per m/s^2] (input-referred ``G``, deg/h/g); ``A_g``,
  ``A_a`` asymmetric scale factors [-] (ppm): the scale factor for positive inputs exceeds that
  for negative ones by ``2 A``.

Calibration (the inverse, applied to a recording, first order in the small terms)::

    v  = S_a^-1 (f_raw - b_a);  f1 = v - k2 v^2 - A_a |v|
    w1 = S_g^-1 (w_raw - b_g);  w1 <- w1 - A_g |w1|
    f  = f1 - L(w1, dw1) - tGA (w1 x f1) + tGA^2 w1 x (w1 x f1) / 2;   w = w1 - G f

Mapping to PSINS (``kf/sysclbt.m`` returns the correction ``wm = Kg wm - eb ts``,
``vm = Ka vm - (db + Ka2 fb^2 + fL + tGA wb x fb) ts``): ``Kg = S_g^-1``, ``eb = B_g``,
``Ka = S_a^-1``, ``db = B_a``, ``Ka2 = k2``, ``rx, ry = r_x, r_y``, ``tGA = tGA``
(:func:`psins_sysclbt`).
PSINS's ``imu/imuclbt.m`` (the struct that *makes* raw data from an ideal IMU, its demo input
``imusysclbt.bin``): raw ``= Kg w - eb``, ``Ka (f - Ka2 f^2) - db - fL - tGA wb x fb``, so
``Kg = S_g``, ``eb = -b_g``, ``Ka = S_a``, ``db = -b_a``, ``Ka2 = -k2``, ``rx = -r_x``,
``tGA = -tGA`` (:func:`psins_imuclbt`). PSINS's units: ``ug = 1e-6 x 9.7803267714 m/s^2`` and
``ug/g^2`` with the same g (``glv.g0``), not g0 = 9.80665.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import PlanError
from inertest.models import triad
from inertest.models.triad import AXES
from inertest.units import (
    ARCSEC_TO_RAD,
    DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2,
    DEG_PER_H_TO_RAD_PER_S,
    G0,
    PPM_TO_RATIO,
)

#: Accelerometer misalignments fixed to zero by the frame definition (x accel = x axis, y in x-y).
ACC_GAUGE = ("M_xy", "M_xz", "M_yz")
#: Free entries of ``S_a`` (row, column): lower triangular.
ACC_FREE = ((0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (2, 2))
#: ug/g^2 [1/(m/s^2)] with g = g0.
UG_PER_G2 = 1e-6 / G0
#: PSINS's g (``glv.g0``) [m/s^2]: its ug and ug/g^2 use it.
PSINS_G0 = 9.7803267714
MM_TO_M = 1e-3
MS_TO_S = 1e-3


def _names(prefix: str, names: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(f"{n[0]}{prefix}{n[1:]}" for n in names)


GYRO_NAMES = _names("g", triad.parameter_names())
ACC_NAMES = tuple(n for n in _names("a", triad.parameter_names())
                  if n not in _names("a", ACC_GAUGE))
SECOND_ORDER_NAMES = tuple(f"K2a_{a}" for a in AXES)
LEVER_NAMES = {i: tuple(f"r{AXES[i]}_{c}" for c in AXES) for i in range(3)}
TGA_NAME = "tGA"
G_SENS_NAMES = tuple(f"Gg_{a}{c}" for a in AXES for c in AXES)
ASYM_GYRO_NAMES = tuple(f"Ag_{a}" for a in AXES)
ASYM_ACC_NAMES = tuple(f"Aa_{a}" for a in AXES)


@dataclass(frozen=True)
class StateSet:
    """Which optional states a model carries (PSINS's set is the default).

    Attributes
    ----------
    second_order : bool
        ``k2`` of each accelerometer.
    lever_arms : {"xy", "xyz", "none"}
        Lever arms of the x and y accelerometers (the z one the reference, PSINS), of all three
        (their common part is then not determined: the result says so), or none.
    time_asynchrony : bool
        ``tGA``.
    g_sensitivity : bool
        Gyro g-sensitivity ``G`` (nine terms).
    asymmetric_scale : bool
        Asymmetric scale factors of the gyros and the accelerometers.
    """

    second_order: bool = True
    lever_arms: str = "xy"
    time_asynchrony: bool = True
    g_sensitivity: bool = False
    asymmetric_scale: bool = False

    @property
    def lever_rows(self) -> tuple[int, ...]:
        """Accelerometers whose position is a state."""
        return {"xy": (0, 1), "xyz": (0, 1, 2), "none": ()}[self.lever_arms]

    def names(self) -> tuple[str, ...]:
        """Engineering names of the states, in the order of :func:`engineering`."""
        out = list(GYRO_NAMES) + list(ACC_NAMES)
        if self.second_order:
            out += SECOND_ORDER_NAMES
        for i in self.lever_rows:
            out += LEVER_NAMES[i]
        if self.time_asynchrony:
            out.append(TGA_NAME)
        if self.g_sensitivity:
            out += G_SENS_NAMES
        if self.asymmetric_scale:
            out += ASYM_GYRO_NAMES + ASYM_ACC_NAMES
        return tuple(out)


def units(names: tuple[str, ...]) -> dict[str, str]:
    """Engineering unit of each name."""
    out = {}
    for n in names:
        if n[0] == "K" and n[1] in "ga":
            out[n] = "1"
        elif n[0] == "M":
            out[n] = triad.MISALIGNMENT_UNIT
        elif n.startswith("Bg"):
            out[n] = "deg/h"
        elif n.startswith("Ba"):
            out[n] = "mg"
        elif n.startswith("K2a"):
            out[n] = "ug/g^2"
        elif n[0] == "r":
            out[n] = "mm"
        elif n == TGA_NAME:
            out[n] = "ms"
        elif n.startswith("Gg"):
            out[n] = triad.G_SENSITIVITY_UNIT
        elif n[0] == "A":
            out[n] = "ppm"
    return out


def _skew(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``[v x]`` for vectors ``v`` (..., 3) -> (..., 3, 3)."""
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def lever_matrix(omega: NDArray[np.float64], domega: NDArray[np.float64]) -> NDArray[np.float64]:
    """``W = [dw x] + [w x]^2`` (n, 3, 3): the acceleration ``W r`` of a point at ``r``.

    ``dw x r + w x (w x r)``, the tangential and centripetal acceleration of a body-fixed point
    at ``r`` [m] relative to the reference point [m/s^2 per m].
    """
    Wx = _skew(omega)
    return _skew(domega) + Wx @ Wx


@dataclass(frozen=True)
class StrapdownImu:
    """One strapdown IMU's error model (module docstring), SI.

    Attributes
    ----------
    S_g, S_a : ndarray, shape (3, 3)
        Forward matrices ``K (I + M)`` of the gyro and accelerometer triads [-].
    b_g, b_a : ndarray, shape (3,)
        Output biases [rad/s], [m/s^2].
    k2 : ndarray, shape (3,)
        Second-order coefficients [1/(m/s^2)].
    lever : ndarray, shape (3, 3)
        Row i: position of accelerometer i relative to the reference point [m].
    tga : float
        Accelerometer lag behind the gyros [s].
    G : ndarray, shape (3, 3)
        Gyro g-sensitivity, input-referred [rad/s per m/s^2].
    A_g, A_a : ndarray, shape (3,)
        Asymmetric scale factors [-].
    """

    S_g: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    b_g: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    S_a: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    b_a: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    k2: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    lever: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))
    tga: float = 0.0
    G: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))
    A_g: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    A_a: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def raw(self, omega: ArrayLike, domega: ArrayLike, force: ArrayLike
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Raw rates ``(w_raw, f_raw)`` (n, 3) for the true motion (forward model).

        Parameters
        ----------
        omega, domega : array_like, shape (n, 3)
            Body angular rate [rad/s] and angular acceleration [rad/s^2].
        force : array_like, shape (n, 3)
            Specific force at the reference point, body axes [m/s^2].
        """
        w = np.atleast_2d(np.asarray(omega, dtype=float))
        dw = np.atleast_2d(np.asarray(domega, dtype=float))
        f = np.atleast_2d(np.asarray(force, dtype=float))
        w_in = w + self.A_g * np.abs(w) + f @ self.G.T
        w_raw = w_in @ self.S_g.T + self.b_g
        W = lever_matrix(w, dw)
        wf = np.cross(w, f)
        fa = (f + np.einsum("nij,ij->ni", W, self.lever) + self.tga * wf
              + 0.5 * self.tga**2 * np.cross(w, wf))
        f_in = fa + self.k2 * fa**2 + self.A_a * np.abs(fa)
        return w_raw, f_in @ self.S_a.T + self.b_a

    def correct(self, w_raw: ArrayLike, f_raw: ArrayLike, dt_s: float) -> Corrected:
        """The calibrated rates of a recording (module docstring: the inverse, first order).

        Parameters
        ----------
        w_raw, f_raw : array_like, shape (n, 3)
            Raw rates [rad/s] and specific forces [m/s^2], one row per sample.
        dt_s : float
            Sample interval [s] (the angular acceleration by central differences).
        """
        wr = np.atleast_2d(np.asarray(w_raw, dtype=float))
        fr = np.atleast_2d(np.asarray(f_raw, dtype=float))
        v = np.asarray(np.linalg.solve(self.S_a, (fr - self.b_a).T).T, dtype=float)
        f1 = v - self.k2 * v**2 - self.A_a * np.abs(v)
        w0 = np.asarray(np.linalg.solve(self.S_g, (wr - self.b_g).T).T, dtype=float)
        w1 = w0 - self.A_g * np.abs(w0)
        dw = angular_acceleration(w1, dt_s)
        W = lever_matrix(w1, dw)
        wf = np.cross(w1, f1)
        f = (f1 - np.einsum("nij,ij->ni", W, self.lever) - self.tga * wf
             + 0.5 * self.tga**2 * np.cross(w1, wf))
        w = w1 - f @ self.G.T
        return Corrected(omega=w, force=f, v=v, f1=f1, w0=w0, w1=w1, domega=dw, W=W)


@dataclass(frozen=True)
class Corrected:
    """Calibrated rates and the intermediate quantities the sensitivities use (SI, (n, 3)).

    ``omega`` and ``force``: the calibrated rate and specific force; ``v = S_a^-1 (f_raw -
    b_a)``, ``f1`` after the second-order and asymmetry terms, ``w0 = S_g^-1 (w_raw - b_g)``,
    ``w1`` after the asymmetry, ``domega`` its derivative, ``W`` the lever matrices (n, 3, 3).
    """

    omega: NDArray[np.float64]
    force: NDArray[np.float64]
    v: NDArray[np.float64]
    f1: NDArray[np.float64]
    w0: NDArray[np.float64]
    w1: NDArray[np.float64]
    domega: NDArray[np.float64]
    W: NDArray[np.float64]


def angular_acceleration(omega: NDArray[np.float64], dt_s: float) -> NDArray[np.float64]:
    """Angular acceleration by central differences of the sample rates (one-sided at the ends)."""
    if omega.shape[0] < 2:
        return np.zeros_like(omega)
    return np.asarray(np.gradient(omega, dt_s, axis=0))


# --- parameters <-> engineering units ----------------------------------------------------------

def parameter_count(states: StateSet) -> int:
    """Length of the SI parameter vector of :func:`to_parameters`."""
    return len(states.names())


def to_parameters(m: StrapdownImu, states: StateSet) -> NDArray[np.float64]:
    """SI parameter vector, one entry per name of ``states.names()`` in the same order.

    Gyro ``S_g`` (9, row-wise), ``b_g``; accelerometer ``S_a`` free entries (:data:`ACC_FREE`),
    ``b_a``; then ``k2``, lever arms (rows), ``tGA``, ``G`` (row-wise), ``A_g``, ``A_a``.
    """
    parts: list[ArrayLike] = [m.S_g.ravel(), m.b_g, [m.S_a[i, j] for i, j in ACC_FREE], m.b_a]
    if states.second_order:
        parts.append(m.k2)
    for i in states.lever_rows:
        parts.append(m.lever[i])
    if states.time_asynchrony:
        parts.append([m.tga])
    if states.g_sensitivity:
        parts.append(m.G.ravel())
    if states.asymmetric_scale:
        parts += [m.A_g, m.A_a]
    return np.concatenate([np.asarray(x, dtype=float) for x in parts])


def from_parameters(p: ArrayLike, states: StateSet) -> StrapdownImu:
    """Inverse of :func:`to_parameters` (absent states zero)."""
    x = np.asarray(p, dtype=float)
    S_g = x[:9].reshape(3, 3)
    b_g = x[9:12]
    S_a = np.zeros((3, 3))
    for k, (i, j) in enumerate(ACC_FREE):
        S_a[i, j] = x[12 + k]
    b_a = x[18:21]
    k = 21
    k2 = np.zeros(3)
    if states.second_order:
        k2, k = x[k:k + 3], k + 3
    lever = np.zeros((3, 3))
    for i in states.lever_rows:
        lever[i], k = x[k:k + 3], k + 3
    tga = 0.0
    if states.time_asynchrony:
        tga, k = float(x[k]), k + 1
    G = np.zeros((3, 3))
    if states.g_sensitivity:
        G, k = x[k:k + 9].reshape(3, 3), k + 9
    A_g, A_a = np.zeros(3), np.zeros(3)
    if states.asymmetric_scale:
        A_g, A_a = x[k:k + 3], x[k + 3:k + 6]
    return StrapdownImu(S_g=S_g.copy(), b_g=b_g.copy(), S_a=S_a, b_a=b_a.copy(), k2=np.array(k2),
                        lever=lever, tga=tga, G=np.array(G), A_g=np.array(A_g),
                        A_a=np.array(A_a))


#: SI value of one engineering unit of each non-triad state.
_SCALE = {"ug/g^2": UG_PER_G2, "mm": MM_TO_M, "ms": MS_TO_S, "ppm": PPM_TO_RATIO,
          triad.G_SENSITIVITY_UNIT: DEG_PER_H_PER_G_TO_RAD_PER_S_PER_M_PER_S2}


def engineering(p: ArrayLike, states: StateSet) -> NDArray:
    """Engineering values of :func:`to_parameters`'s vector, in ``states.names()`` order.

    ``K`` [1], ``M`` [urad], ``B`` [deg/h, mg] of both triads (the triad model's
    :func:`~inertest.models.triad.engineering`), ``K2a`` [ug/g^2], lever arms [mm], ``tGA``
    [ms], ``Gg`` [deg/h/g], ``Ag``, ``Aa`` [ppm]. Works on complex input (complex step).
    """
    x = np.asarray(p)
    one = triad.ScaleUnit("1", 1.0, 1.0, 1.0)
    eg = triad.engineering(x[:12], "gyroscope", one)
    S_a = np.zeros((3, 3), dtype=x.dtype)
    for k, (i, j) in enumerate(ACC_FREE):
        S_a[i, j] = x[12 + k]
    ea = triad.engineering(np.concatenate([S_a.ravel(), x[18:21]]), "accelerometer", one)
    keep = [i for i, n in enumerate(triad.parameter_names()) if n not in ACC_GAUGE]
    rest = x[21:]
    names = states.names()[21:]
    u = units(names)
    conv = [rest[k] / _SCALE[u[n]] for k, n in enumerate(names)]
    return np.concatenate([eg, ea[keep], np.asarray(conv, dtype=x.dtype)])


def engineering_jacobian(p: ArrayLike, states: StateSet
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`engineering` at ``p`` and ``d engineering / d p`` (complex step, exact)."""
    return triad.complex_step_jacobian(lambda q: engineering(q, states), p)


def from_engineering(values: Mapping[str, float], states: StateSet, *,
                     what: str = "truth") -> StrapdownImu:
    """The model from engineering values by name (absent: nominal 1 for K, else 0).

    Unknown names are an error naming the known ones.
    """
    names = states.names()
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise PlanError(f"{what} has unknown name(s) {', '.join(unknown)}; the states of this "
                        f"plan are {', '.join(names)}")
    one = triad.ScaleUnit("1", 1.0, 1.0, 1.0)
    pg = triad.parameters_from_engineering(values, "gyroscope", one, prefix="g", what=what)
    pa = triad.parameters_from_engineering(values, "accelerometer", one, prefix="a", what=what)
    u = units(names)
    si = {n: float(values.get(n, 0.0)) * _SCALE[u[n]] for n in names[21:]}
    lever = np.array([[si.get(f"r{AXES[i]}_{c}", 0.0) for c in AXES] for i in range(3)])
    return StrapdownImu(
        S_g=pg[:9].reshape(3, 3), b_g=pg[9:12], S_a=pa[:9].reshape(3, 3), b_a=pa[9:12],
        k2=np.array([si.get(n, 0.0) for n in SECOND_ORDER_NAMES]), lever=lever,
        tga=si.get(TGA_NAME, 0.0),
        G=np.array([si.get(n, 0.0) for n in G_SENS_NAMES]).reshape(3, 3),
        A_g=np.array([si.get(n, 0.0) for n in ASYM_GYRO_NAMES]),
        A_a=np.array([si.get(n, 0.0) for n in ASYM_ACC_NAMES]))


# --- PSINS ------------------------------------------------------------------------------------

#: PSINS's units: ug and ug/g^2 with its own g (glv.g0), arcsec, deg/h.
PSINS_UG = 1e-6 * PSINS_G0
PSINS_UGPG2 = PSINS_UG / PSINS_G0**2


def psins_sysclbt(m: StrapdownImu) -> dict[str, NDArray[np.float64] | float]:
    """The correction struct PSINS ``kf/sysclbt.m`` returns for this IMU (module docstring).

    Keys ``Kg``, ``Ka`` (3x3, [-]), ``eb`` [deg/h], ``db`` [PSINS ug], ``Ka2`` [PSINS ug/g^2],
    ``rx``, ``ry``, ``rz`` [m], ``tGA`` [s].
    """
    return {"Kg": np.linalg.inv(m.S_g), "eb": np.linalg.solve(m.S_g, m.b_g) /
            DEG_PER_H_TO_RAD_PER_S, "Ka": np.linalg.inv(m.S_a),
            "db": np.linalg.solve(m.S_a, m.b_a) / PSINS_UG, "Ka2": m.k2 / PSINS_UGPG2,
            "rx": m.lever[0].copy(), "ry": m.lever[1].copy(), "rz": m.lever[2].copy(),
            "tGA": m.tga}


def psins_imuclbt(m: StrapdownImu) -> dict[str, NDArray[np.float64] | float]:
    """The struct PSINS ``imu/imuclbt.m`` applies to an ideal IMU to make this IMU's raw data.

    Same keys and units as :func:`psins_sysclbt`: ``Kg = S_g``, ``eb = -b_g``, ``Ka = S_a``,
    ``db = -b_a``, ``Ka2 = -k2``, ``rx = -r_x``, ``ry = -r_y``, ``tGA = -tGA`` (the module
    docstring: PSINS's demo input ``imusysclbt.bin`` was made so).
    """
    return {"Kg": m.S_g.copy(), "eb": -m.b_g / DEG_PER_H_TO_RAD_PER_S, "Ka": m.S_a.copy(),
            "db": -m.b_a / PSINS_UG, "Ka2": -m.k2 / PSINS_UGPG2, "rx": -m.lever[0],
            "ry": -m.lever[1], "rz": -m.lever[2], "tGA": -m.tga}


def from_psins_imuclbt(clbt: Mapping[str, ArrayLike | float]) -> StrapdownImu:
    """Inverse of :func:`psins_imuclbt` (absent keys: identity matrices, zero vectors)."""
    def vec(key: str) -> NDArray[np.float64]:
        return np.asarray(clbt.get(key, np.zeros(3)), dtype=float).reshape(3)

    lever = -np.vstack([vec("rx"), vec("ry"), vec("rz")])
    return StrapdownImu(
        S_g=np.asarray(clbt.get("Kg", np.eye(3)), dtype=float),
        b_g=-vec("eb") * DEG_PER_H_TO_RAD_PER_S,
        S_a=np.asarray(clbt.get("Ka", np.eye(3)), dtype=float), b_a=-vec("db") * PSINS_UG,
        k2=-vec("Ka2") * PSINS_UGPG2, lever=lever, tga=-float(clbt.get("tGA", 0.0)))  # type: ignore[arg-type]


def psins_default_clbt() -> dict[str, NDArray[np.float64] | float]:
    """PSINS ``imuclbt.m``'s default struct (the one behind ``imusysclbt.bin``), PSINS units.

    ``Kg = I - diag(10, 20, 30) ppm + [0 10 20; 30 0 40; 50 60 0]"``, ``eb = (0.1, 0.2, 0.3)
    deg/h``, ``Ka = I - diag(10, 20, 30) ppm + [0 0 0; 10 0 0; 20 30 0]"``, ``db = (10, 20,
    30) ug``, ``Ka2 = (10, 20, 30) ug/g^2``, ``rx = (1, 2, 3) cm``, ``ry = (4, 5, 6) cm``,
    ``rz = 0``, ``tGA = 1 ms`` (PSINS ``imu/imuclbt.m``, ``nargin < 2`` branch).
    """
    ppm = np.diag([10.0, 20.0, 30.0]) * PPM_TO_RATIO
    return {
        "Kg": np.eye(3) - ppm + np.array([[0, 10, 20], [30, 0, 40], [50, 60, 0.0]]) * ARCSEC_TO_RAD,
        "eb": np.array([0.1, 0.2, 0.3]),
        "Ka": np.eye(3) - ppm + np.array([[0, 0, 0], [10, 0, 0], [20, 30, 0.0]]) * ARCSEC_TO_RAD,
        "db": np.array([10.0, 20.0, 30.0]), "Ka2": np.array([10.0, 20.0, 30.0]),
        "rx": np.array([0.01, 0.02, 0.03]), "ry": np.array([0.04, 0.05, 0.06]),
        "rz": np.zeros(3), "tGA": 0.001,
    }
