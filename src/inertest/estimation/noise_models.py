"""The noise models of an instrument, as values: written once, used by every procedure.

A static or rotation test's readings carry white noise and, often, a slower component: the
fixture re-settles between positions, the bias wanders (a random walk) or flickers (1/f). Each
model here is one value, :class:`NoiseModel`, with the covariance of its component in the three
shapes the procedures need, all from one definition:

* :meth:`NoiseModel.unit_kernel`: the means of units (positions, runs) of a record of rows
  (readings in time order), for a component of unit variance per reading (the identification
  of :func:`inertest.estimation.identify.solve`);
* :meth:`NoiseModel.row_apply`: ``K v`` over the rows of a record (a Ferraris session's face
  means and turn integrals, propagated from the level fitted on its faces);
* :meth:`NoiseModel.window_kernel`: integrals over counting windows in continuous time (the
  gyro-triad rotation test's counts).

The models (:data:`MODELS`):

``white``
    Independent readings: no component.
``position-offsets``
    A random offset per unit (one-way random effects: the table re-settles, the drift moves
    between positions); per window a random rate offset.
``random-walk``
    A random walk of the bias over the rows, ``W_t = sum_{k<=t} e_k`` with unit step variance
    per reading (per second for windows): ``Cov(W_i, W_k) = min(i, k) + 1``.
``flicker``
    Band-limited 1/f noise: power ``1/f`` from ``f_lo = 1/(2 s T)`` (``T`` the record, ``s``
    the bias time scale in records, :data:`BIAS_TIME_SCALE_DEFAULT`) to the Nyquist frequency,
    autocovariance ``c(L) = Ci(pi L) - Ci(2 pi f_lo L)`` (Ci the cosine integral; Kasdin,
    Proc. IEEE 83(5), 1995, doi:10.1109/5.381848), normalised to unit variance per reading of
    the record (for windows: unit variance of the rate averaged over the shortest window).

The variance components (their levels) are estimated by REML (:mod:`inertest.estimation.reml`);
the choice among them by :mod:`inertest.estimation.selection`; the checks of the fitted model by
:mod:`inertest.estimation.model_checks`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.special
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError, PlanError
from inertest.estimation.units import Units

#: Default time scale of the constant (bias-type) terms under flicker, in test durations: the
#: flicker model's spectrum starts at ``1 / (2 * scale)`` cycles per record, ``1/(4 T)`` for a
#: test of duration ``T`` (see :func:`flicker_unit_kernel`).
BIAS_TIME_SCALE_DEFAULT = 2.0


#: Noise models a user may name; ``auto`` picks one of the others
#: (:func:`inertest.estimation.selection.common_noise_model`).
NOISE_MODELS = ("auto", "white", "position-offsets", "random-walk", "flicker")


def check_bias_time_scale(value: object) -> float:
    """Validate ``bias_time_scale`` (test durations, at least 1; a plan key or an argument)."""
    if (isinstance(value, bool) or not isinstance(value, int | float)
            or not np.isfinite(value) or value < 1.0):
        raise PlanError(
            "bias_time_scale is the time over which a constant term is meant, in test "
            f"durations (e.g. calibration interval / test duration), at least 1; got {value!r}")
    return float(value)


def flicker_low(n: int, bias_time_scale: float) -> float:
    """Lowest frequency of the flicker model [cycles per row] for an ``n``-row record."""
    return 1.0 / (2.0 * check_bias_time_scale(bias_time_scale) * max(n, 1))


def check_noise_model(value: object) -> str:
    """Validate the ``noise_model`` of a plan's ``[procedure]`` table (or an API argument)."""
    if not isinstance(value, str) or value not in NOISE_MODELS:
        raise PlanError(
            f"noise_model must be one of {', '.join(NOISE_MODELS)}, got {value!r}")
    return value


def random_walk_apply(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``K v`` over rows for a random walk of unit step variance per row: two cumulative sums."""
    return np.cumsum(np.cumsum(v[::-1], axis=0)[::-1], axis=0)


def rows_unit_kernel(
    u: Units, apply: Callable[[NDArray[np.float64]], NDArray[np.float64]]
) -> NDArray[np.float64]:
    """``M K M^T`` for a row kernel given as ``v -> K v`` (units not contiguous in time)."""
    G, out = u.size, np.empty((u.size, u.size))
    for start in range(0, G, 16):
        cols = np.arange(start, min(G, start + 16))
        Mt = (u.index[:, None] == cols[None, :]) / u.counts[cols]
        KMt = apply(Mt)
        out[:, cols] = np.stack([np.bincount(u.index, KMt[:, j], minlength=G)
                                 for j in range(cols.size)], axis=1) / u.counts[:, None]
    return 0.5 * (out + out.T)


def random_walk_unit_kernel(u: Units) -> NDArray[np.float64]:
    """Covariance of unit means of a random walk with unit step variance per row.

    The walk is ``W_t = sum_{k<=t} e_k`` over the row index t, ``Cov(W_i, W_k) = min(i, k) + 1``.
    """
    if u.contiguous:
        m, a = u.counts, u.first.astype(float)
        mean_t = a + 1 + (m - 1) / 2  # mean of (i + 1) over the unit's rows
        earlier = u.first[:, None] < u.first[None, :]
        K = np.where(earlier, mean_t[:, None], mean_t[None, :])
        within = (a + 1) + (2 * m - 1) * (m - 1) / (6 * m)
        np.fill_diagonal(K, within)
        return K
    return rows_unit_kernel(u, random_walk_apply)


def flicker_row_covariance(
    n: int, bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT
) -> NDArray[np.float64]:
    """Autocovariance at lags ``0..n`` of flicker noise over an ``n``-row record (arbitrary scale).

    The spectrum is ``1/f`` from ``f_lo = 1 / (2 s n)`` (``s`` the ``bias_time_scale`` in
    record lengths) to the Nyquist frequency (cycles per row), so
    ``c(L) = int cos(2 pi f L) / f df = Ci(pi L) - Ci(2 pi f_lo L)`` and
    ``c(0) = ln(1 / (2 f_lo))`` (Ci the cosine integral, evaluated by
    :mod:`inertest.estimation._flicker_kernel`).
    """
    f_lo = flicker_low(n, bias_time_scale)
    c = np.empty(n + 1)
    c[0] = np.log(0.5 / f_lo)
    if n < COMPILED_FROM:
        c[1:] = _ci_difference(np.arange(1, n + 1, dtype=float), f_lo)
        return c
    from inertest.estimation import _flicker_kernel as kernel  # numba: only when evaluated

    kernel.row_covariance(2 * np.pi * f_lo, _ci_pi_head(), c)
    return c


#: Records of fewer rows evaluate the flicker covariance with scipy's ``sici`` in one block
#: (about 1 ms at 1e5 rows); longer ones in the compiled loop of
#: :mod:`inertest.estimation._flicker_kernel` (2.7x faster at 4.5e6 rows, no arrays of the
#: record's length). Importing numba and loading the loop costs a short ``inertest fit``
#: about 0.4 s, more than the whole fit. The two agree within 4e-16 (tested).
COMPILED_FROM = 1 << 17


def _ci_difference(lag: NDArray[np.float64], f_lo: float) -> NDArray[np.float64]:
    """``Ci(pi L) - Ci(2 pi f_lo L)`` by scipy."""
    return scipy.special.sici(np.pi * lag)[1] - scipy.special.sici(2 * np.pi * f_lo * lag)[1]


def _ci_pi_head() -> NDArray[np.float64]:
    """``Ci(pi L)`` for ``L < ASYMPTOTIC_FROM`` (scipy; ``L = 0`` unused)."""
    from inertest.estimation._flicker_kernel import ASYMPTOTIC_FROM

    head = np.zeros(ASYMPTOTIC_FROM)
    head[1:] = scipy.special.sici(np.pi * np.arange(1, ASYMPTOTIC_FROM, dtype=float))[1]
    return head


def flicker_phi(
    n: int, lags: NDArray[np.intp], bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> tuple[float, NDArray[np.float64]]:
    """``c(0)``, and ``Phi`` at ``lags`` (sorted, ``0..n + 1``) of the flicker row covariance.

    ``Phi(k) = sum_{j<k} (c(0) / 2 + c(1) + ... + c(j))``, the even second antidifference of the
    row autocovariance ``c`` (:func:`flicker_row_covariance`), by the same running sums as
    over the whole record (so the same numbers to the last bit), in one compiled loop up to
    the largest lag asked for (``_flicker_kernel.second_antidifference``): no array of the
    record's length.
    """
    f_lo = flicker_low(n, bias_time_scale)
    c0 = float(np.log(0.5 / f_lo))
    if n < COMPILED_FROM:  # one block of scipy: the same running sums
        if lags.size and (lags[0] < 0 or lags[-1] > n + 1):
            raise InputError(f"flicker kernel: lag {lags[-1]} beyond the record ({n} rows)")
        sums = np.cumsum(np.concatenate(([0.0], _ci_difference(
            np.arange(1, n + 1, dtype=float), f_lo))))  # sum c(1..j), j = 0 .. n
        phi = np.cumsum(np.concatenate(([0.0], c0 / 2 + sums)))  # Phi(0 .. n + 1)
        return c0, phi[np.asarray(lags, dtype=np.intp)]
    from inertest.estimation import _flicker_kernel as kernel  # numba: only when evaluated

    want = np.ascontiguousarray(lags, dtype=np.int64)
    out = np.empty(want.size)
    taken = kernel.second_antidifference(int(n), 2 * np.pi * f_lo, c0, _ci_pi_head(), want,
                                         out)
    if taken < lags.size:
        raise InputError(f"flicker kernel: lag {lags[taken]} beyond the record ({n} rows)")
    return c0, out


def flicker_unit_kernel(
    u: Units, bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT
) -> NDArray[np.float64]:
    """Covariance of unit means of flicker (1/f) noise of unit variance per row.

    Flicker is band-limited 1/f noise over the row index: power ``1/f`` from
    ``1/(2 s n)`` cycles per row (n rows in the record, ``s = bias_time_scale``, default 2:
    ``1/(4 n)``) to the Nyquist frequency, autocovariance by the cosine integral
    (:func:`flicker_row_covariance`). Slower wander is a constant over the record,
    indistinguishable from the constant terms of the model. The lower edge is that of an
    ``1/f`` periodogram over ``s`` records (lines ``k / (s n)``, the first standing for the
    band from ``1/(2 s n)``), the usual way 1/f noise is synthesised (Kasdin, Proc. IEEE 83(5),
    1995, doi:10.1109/5.381848): the reported uncertainties of the constant terms match the
    scatter under such noise with a history of ``s`` records, i.e. they are uncertainties of
    the constant terms as the mean over a time of ``s`` test durations that holds the test
    (Monte Carlo in the procedures' tests). For 1/f noise the variance of a mean grows as the
    logarithm of that time, so a bias-type term has a std only for a stated time scale; the
    terms that change sign within the test (slopes, harmonics) barely depend on it. An
    earlier kernel, a sum of AR(1) processes with correlation times 1, 4, 16, ... rows up to
    a quarter of the record (Keshner, Proc. IEEE 70(3), 1982), is flat below
    ``1/(2 pi n / 4)`` and so put too much of the flicker into the record mean relative to
    the residuals: the biases of a 12-position triad test came out 1.2-1.4x conservative.

    Notes
    -----
    With ``Phi`` the even second antidifference of the row autocovariance ``c``
    (``Phi(d + 1) - 2 Phi(d) + Phi(d - 1) = c(d)``, ``Phi(0) = 0``), the sum of ``c(b - a)``
    over rows ``a`` in ``[a0, a1)`` and ``b`` in ``[b0, b1)`` is
    ``Phi(b1 - a0) - Phi(b1 - a1) - Phi(b0 - a0) + Phi(b0 - a1)``.
    """
    n = u.n_rows
    if u.contiguous:
        a0, a1 = u.first.astype(np.intp), u.last.astype(np.intp) + 1
        lags = [np.abs(a1[None, :] - a0[:, None]), np.abs(a1[None, :] - a1[:, None]),
                np.abs(a0[None, :] - a0[:, None]), np.abs(a0[None, :] - a1[:, None])]
        want = np.unique(np.concatenate([d.ravel() for d in lags]))
        c0, phi = flicker_phi(n, want, bias_time_scale=bias_time_scale)

        def Phi(d: NDArray[np.intp]) -> NDArray[np.float64]:
            return phi[np.searchsorted(want, d)]

        S = Phi(lags[0]) - Phi(lags[1]) - Phi(lags[2]) + Phi(lags[3])
        K = S / np.outer(u.counts, u.counts)
        return 0.5 * (K + K.T) / c0
    c = flicker_row_covariance(n, bias_time_scale)
    col = c[:n] / c[0]
    return rows_unit_kernel(
        u, lambda v: scipy.linalg.matmul_toeplitz((col, col), v, check_finite=False))


#: Points per shortest window of the time grid on which window kernels of flicker are summed
#: (the continuous-time integrals to a relative error below 1e-3, tested).
WINDOW_GRID = 64


def _window_rows(start_s: ArrayLike, duration_s: ArrayLike
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    a, T = np.asarray(start_s, dtype=float), np.asarray(duration_s, dtype=float)
    if a.shape != T.shape or a.ndim != 1 or a.size == 0 or np.any(~np.isfinite(a)) or np.any(
            ~(T > 0)):
        raise InputError("windows need finite starts and positive durations [s], one each")
    return a, T


@dataclass(frozen=True)
class NoiseModel:
    """One noise model of an instrument (see the module docstring).

    Attributes
    ----------
    name : str
        As the plans name it (:data:`NOISE_MODELS`).
    component : str or None
        Name of its variance component in results (``"position offset"``, ``"random walk"``,
        ``"flicker"``); None for white noise.
    """

    name: str
    component: str | None

    def unit_kernel(self, u: Units, *, bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT
                    ) -> NDArray[np.float64]:
        """Covariance (G, G) of the unit means for the component of unit variance per reading."""
        if self.name == "position-offsets":
            return np.eye(u.size)
        if self.name == "random-walk":
            return random_walk_unit_kernel(u)
        if self.name == "flicker":
            return flicker_unit_kernel(u, bias_time_scale)
        raise InputError(f"white noise has no component kernel ({self.name})")

    def row_apply(self, v: NDArray[np.float64], *, level_rows: int | None = None,
                  bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT) -> NDArray[np.float64]:
        """``K v`` over the rows of ``v`` (shape (n, k), rows in time order).

        ``K``: the component's row covariance over the ``n``-row record, its level that of unit
        variance per reading of a record of ``level_rows`` rows (default ``n``): the level
        fitted on part of a record (a Ferraris session's faces) carried over the whole record.
        For flicker the variance per reading grows with the record (``c(0) = ln(s n)``), so the
        level is taken per unit spectral density, as it was fitted.
        """
        n = v.shape[0]
        if self.name == "random-walk":
            return random_walk_apply(v)
        if self.name == "flicker":
            c = flicker_row_covariance(n, bias_time_scale)
            c0 = float(flicker_row_covariance(level_rows or n, bias_time_scale)[0]) if (
                level_rows and level_rows != n) else float(c[0])
            col = c[:n] / c0
            return scipy.linalg.matmul_toeplitz((col, col), v, check_finite=False)
        raise InputError(f"no row kernel for the {self.name} noise model")

    def window_kernel(self, start_s: ArrayLike, duration_s: ArrayLike, *,
                      bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT) -> NDArray[np.float64]:
        """Covariance (n, n) of the integrals over counting windows of the component [s^2, s^3].

        Parameters
        ----------
        start_s, duration_s : array_like, shape (n,)
            Window starts and lengths [s], not overlapping.

        Notes
        -----
        ``position-offsets``: a rate offset of unit variance per window, ``K = diag(T^2)``.
        ``random-walk``: a rate random walk ``W`` of unit step variance per second from the
        session start, ``Cov(W(s), W(t)) = min(s, t)``, so ``K_ik = T_k (b_i^2 - a_i^2) / 2``
        for window i = [a_i, b_i] before window k and ``K_ii = a_i T_i^2 + T_i^3 / 3``.
        ``flicker``: the 1/f rate of the module docstring over the session (its lowest
        frequency ``1 / (2 s span)``), on a time grid of :data:`WINDOW_GRID` points per
        shortest window, normalised so that the rate averaged over the shortest window has unit
        variance.
        """
        a, T = _window_rows(start_s, duration_s)
        b = a + T
        if self.name == "position-offsets":
            return np.diag(T**2)
        earlier = a[:, None] < a[None, :]
        if self.name == "random-walk":
            m = 0.5 * (b**2 - a**2)  # int_I s ds
            K = np.where(earlier, m[:, None] * T[None, :], T[:, None] * m[None, :])
            np.fill_diagonal(K, a * T**2 + T**3 / 3)
            return K
        if self.name != "flicker":
            raise InputError(f"no window kernel for the {self.name} noise model")
        dt = float(T.min()) / WINDOW_GRID
        a0 = np.rint((a - a.min()) / dt).astype(np.intp)
        a1 = a0 + np.maximum(np.rint(T / dt).astype(np.intp), 1)
        n = int(a1.max())
        lags = [np.abs(a1[None, :] - a0[:, None]), np.abs(a1[None, :] - a1[:, None]),
                np.abs(a0[None, :] - a0[:, None]), np.abs(a0[None, :] - a1[:, None])]
        want = np.unique(np.concatenate([d.ravel() for d in lags] + [np.array([WINDOW_GRID])]))
        _, phi = flicker_phi(n, want, bias_time_scale=bias_time_scale)

        def Phi(d: NDArray[np.intp]) -> NDArray[np.float64]:
            return phi[np.searchsorted(want, d)]

        S = Phi(lags[0]) - Phi(lags[1]) - Phi(lags[2]) + Phi(lags[3])  # row sums
        var_short = 2 * float(Phi(np.array([WINDOW_GRID]))[0]) / WINDOW_GRID**2
        K = S * dt**2 / var_short
        return 0.5 * (K + K.T)


WHITE = NoiseModel("white", None)
POSITION_OFFSETS = NoiseModel("position-offsets", "position offset")
RANDOM_WALK = NoiseModel("random-walk", "random walk")
FLICKER = NoiseModel("flicker", "flicker")
#: The noise models by name (``auto`` is a choice among them, not a model).
MODELS: Mapping[str, NoiseModel] = {m.name: m for m in (WHITE, POSITION_OFFSETS, RANDOM_WALK,
                                                        FLICKER)}
#: The correlated models, in the order ``auto`` tries them.
CORRELATED: tuple[str, ...] = ("position-offsets", "random-walk", "flicker")
