"""The IMU model: an accelerometer triad and a gyro triad on one body.

Each triad follows :mod:`inertest.models.triad` (``raw = K (I + M) u + b [+ G a]``); the IMU
calibration corrects a recording with both: the accelerometers first, then the gyros with their
g-sensitivity to the *calibrated* specific force (JSON ``"calibration"`` block of every triad
procedure's result, read back by ``inertest apply``). A systematic calibration adds the terms that
couple the two triads (:class:`CouplingTerms`, :mod:`inertest.models.strapdown_imu`): the
second-order accelerometer terms, the accelerometers' lever arms and the gyro-accelerometer time
asynchrony, applied by :meth:`ImuCalibration.correct`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.models.triad import TriadCalibration


def _block(d: Mapping[str, object], key: str, shape: tuple[int, ...], unit: str) -> NDArray:
    """``d[key]["value"]`` as a finite array of ``shape`` in ``unit``; zeros when absent."""
    if key not in d:
        return np.zeros(shape)
    item = d[key]
    if not isinstance(item, Mapping) or item.get("unit") != unit:
        raise InputError(f'calibration coupling "{key}" must be {{"value": ..., "unit": '
                         f'"{unit}"}}')
    try:
        a = np.asarray(item.get("value"), dtype=float).reshape(shape)
    except (TypeError, ValueError):
        raise InputError(f'calibration coupling "{key}" must hold {shape} numbers') from None
    if not np.all(np.isfinite(a)):
        raise InputError(f'calibration coupling "{key}" must be finite')
    return a


@dataclass(frozen=True)
class CouplingTerms:
    """What a strapdown IMU's calibration holds beyond its two triads (SI, model conventions).

    Attributes (:mod:`inertest.models.strapdown_imu`)
    ----------
    second_order : ndarray, shape (3,)
        ``k2`` [1/(m/s^2)]: accelerometer i reads ``k2_i f_i^2`` high.
    lever_arm : ndarray, shape (3, 3)
        Row i: position of accelerometer i relative to the reference point [m].
    time_asynchrony_s : float
        Accelerometer samples' lag behind the gyros' [s].
    asymmetric_gyro, asymmetric_acc : ndarray, shape (3,)
        Asymmetric scale factors [-].
    """

    second_order: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    lever_arm: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))
    time_asynchrony_s: float = 0.0
    asymmetric_gyro: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    asymmetric_acc: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def to_dict(self) -> dict[str, object]:
        """JSON block, each value with its unit."""
        return {
            "second_order": {"value": np.asarray(self.second_order).tolist(),
                             "unit": "1/(m/s^2)"},
            "lever_arm": {"value": np.asarray(self.lever_arm).tolist(), "unit": "m",
                          "rows": "position of the x, y, z accelerometer"},
            "time_asynchrony": {"value": float(self.time_asynchrony_s), "unit": "s",
                                "meaning": "accelerometer samples lag the gyro samples"},
            "asymmetric_gyro": {"value": np.asarray(self.asymmetric_gyro).tolist(), "unit": "1"},
            "asymmetric_acc": {"value": np.asarray(self.asymmetric_acc).tolist(), "unit": "1"},
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> CouplingTerms:
        """Inverse of :meth:`to_dict` (absent terms zero); errors name the malformed key."""
        lag = _block(d, "time_asynchrony", (), "s")
        return cls(second_order=_block(d, "second_order", (3,), "1/(m/s^2)"),
                   lever_arm=_block(d, "lever_arm", (3, 3), "m"),
                   time_asynchrony_s=float(lag),
                   asymmetric_gyro=_block(d, "asymmetric_gyro", (3,), "1"),
                   asymmetric_acc=_block(d, "asymmetric_acc", (3,), "1"))


@dataclass(frozen=True)
class ImuCalibration:
    """Calibration of an IMU: accelerometer triad and optionally gyroscope triad."""

    accelerometer: TriadCalibration | None = None
    gyroscope: TriadCalibration | None = None
    coupling: CouplingTerms | None = None

    def to_dict(self) -> dict[str, object]:
        """``{"accelerometer", "gyroscope"[, "coupling"]}`` blocks (absent ones omitted)."""
        out: dict[str, object] = {}
        if self.accelerometer is not None:
            out["accelerometer"] = self.accelerometer.to_dict()
        if self.gyroscope is not None:
            out["gyroscope"] = self.gyroscope.to_dict()
        if self.coupling is not None:
            out["coupling"] = self.coupling.to_dict()
        return out

    def correct(self, acc_raw: ArrayLike, gyr_raw: ArrayLike, dt_s: float
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Calibrated specific force [m/s^2] and rate [rad/s] (n, 3) of a whole IMU recording.

        The triads as :meth:`TriadCalibration.apply`, then the coupling terms (first order,
        :mod:`inertest.models.strapdown_imu`, :meth:`~inertest.models.strapdown_imu.
        StrapdownImu.correct`): ``f = v - k2 v^2 - A_a |v| - L(w, dw) - tGA w x f (+ the
        second order)``, ``w`` less ``A_g |w|``, the angular acceleration ``dw`` by central
        differences at the sample interval ``dt_s`` [s].
        """
        from inertest.models.strapdown_imu import angular_acceleration, lever_matrix

        if self.accelerometer is None or self.gyroscope is None:
            raise InputError("correcting a whole IMU needs both the accelerometer and the "
                             "gyroscope calibration")
        c = self.coupling or CouplingTerms()
        v = self.accelerometer.apply(acc_raw)
        f1 = v - c.second_order * v**2 - c.asymmetric_acc * np.abs(v)
        g = self.gyroscope
        w0 = (np.atleast_2d(np.asarray(gyr_raw, dtype=float)) - g.offset) @ g.matrix.T
        w1 = w0 - c.asymmetric_gyro * np.abs(w0)
        W = lever_matrix(w1, angular_acceleration(w1, dt_s))
        wf = np.cross(w1, f1)
        f = (f1 - np.einsum("nij,ij->ni", W, c.lever_arm) - c.time_asynchrony_s * wf
             + 0.5 * c.time_asynchrony_s**2 * np.cross(w1, wf))
        if g.g_sensitivity is not None:
            w1 = w1 - f @ (g.matrix @ g.g_sensitivity).T
        return f, w1

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> ImuCalibration:
        """Inverse of :meth:`to_dict`."""
        acc = d.get("accelerometer")
        gyr = d.get("gyroscope")
        if acc is None and gyr is None:
            raise InputError('calibration has neither "accelerometer" nor "gyroscope"')
        coupling = d.get("coupling")
        if coupling is not None and not isinstance(coupling, Mapping):
            raise InputError('calibration "coupling" must be an object')
        return cls(
            accelerometer=None if acc is None else TriadCalibration.from_dict(acc),  # type: ignore[arg-type]
            gyroscope=None if gyr is None else TriadCalibration.from_dict(gyr),  # type: ignore[arg-type]
            coupling=None if coupling is None else CouplingTerms.from_dict(coupling),
        )
