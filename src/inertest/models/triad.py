"""Sensor triads (three accelerometers or gyros): scale factor, misalignment, bias.

Output model (seed ``003_f374f866dfe7c99f.txt``, FOG triad output model)::

    raw = K (I + M) u + b          (gyros also: + G a, the g-sensitivity)

with ``u`` the true input on the triad's orthogonal reference axes (SI: m/s^2 or rad/s), ``K``
diagonal scale factors [raw unit per SI unit], ``M`` small non-orthogonality / misalignment
(dimensionless, zero diagonal), ``b`` bias [raw unit] and, for gyros, ``G`` [raw unit per m/s^2].

The inverse, used to correct recordings, is the calibration::

    calibrated = matrix @ (raw - offset)                       (accelerometer)
    calibrated = matrix @ (raw - g_sensitivity @ a_cal - offset)   (gyroscope)

so ``matrix = (K (I + M))^-1`` and ``offset = b``; in JSON (every triad procedure's result)::

    "calibration": {"accelerometer": {"matrix": 3x3, "offset": [3], "unit": ..., "raw_unit": ...},
                    "gyroscope": {"matrix": 3x3, "offset": [3], "g_sensitivity": 3x3, ...}}

``g_sensitivity`` is in raw units per (m/s^2) of *calibrated* acceleration.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError

AXES = ("x", "y", "z")


@dataclass(frozen=True)
class TriadCalibration:
    """Correction of one triad: ``calibrated = matrix @ (raw - [g_sensitivity @ a] - offset)``.

    Attributes
    ----------
    matrix : ndarray, shape (3, 3)
        ``(K (I + M))^-1`` [SI unit per raw unit].
    offset : ndarray, shape (3,)
        Bias [raw unit].
    unit : str
        Unit of the calibrated output (``"m/s^2"`` or ``"rad/s"``).
    raw_unit : str
        Unit of the raw output (e.g. ``"count"``).
    g_sensitivity : ndarray, shape (3, 3) or None
        Gyro bias per calibrated specific force [raw unit per m/s^2]; None for accelerometers.
    """

    matrix: NDArray[np.float64]
    offset: NDArray[np.float64]
    unit: str
    raw_unit: str = "count"
    g_sensitivity: NDArray[np.float64] | None = field(default=None)

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix, dtype=float)
        o = np.asarray(self.offset, dtype=float)
        if m.shape != (3, 3) or o.shape != (3,):
            raise InputError(
                f"calibration matrix must be 3x3 and offset 3, got {m.shape}, {o.shape}"
            )
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(o))):
            raise InputError("calibration matrix and offset must be finite")
        if abs(np.linalg.det(m)) < 1e-300:
            raise InputError("calibration matrix is singular")
        object.__setattr__(self, "matrix", m)
        object.__setattr__(self, "offset", o)
        if self.g_sensitivity is not None:
            g = np.asarray(self.g_sensitivity, dtype=float)
            if g.shape != (3, 3) or not np.all(np.isfinite(g)):
                raise InputError(f"g_sensitivity must be a finite 3x3 matrix, got {g.shape}")
            object.__setattr__(self, "g_sensitivity", g)

    @classmethod
    def from_model(
        cls,
        scale: ArrayLike,
        misalignment: ArrayLike,
        bias: ArrayLike,
        *,
        unit: str,
        raw_unit: str = "count",
        g_sensitivity: ArrayLike | None = None,
    ) -> TriadCalibration:
        """From the output model: ``K = diag(scale)``, ``M`` (3x3, zero diagonal), ``b``."""
        K = np.diag(np.asarray(scale, dtype=float))
        M = np.asarray(misalignment, dtype=float)
        if M.shape != (3, 3):
            raise InputError(f"misalignment must be 3x3, got {M.shape}")
        return cls(
            matrix=np.linalg.inv(K @ (np.eye(3) + M)),
            offset=np.asarray(bias, dtype=float),
            unit=unit,
            raw_unit=raw_unit,
            g_sensitivity=None if g_sensitivity is None else np.asarray(g_sensitivity, float),
        )

    @property
    def forward(self) -> NDArray[np.float64]:
        """``K (I + M)`` [raw unit per SI unit], the inverse of :attr:`matrix`."""
        return np.linalg.inv(self.matrix)

    def apply(
        self, raw: ArrayLike, acc_calibrated: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Calibrated output, shape (n, 3), from raw output, shape (n, 3).

        Gyroscopes with a ``g_sensitivity`` need ``acc_calibrated`` [m/s^2], shape (n, 3).
        """
        r = np.atleast_2d(np.asarray(raw, dtype=float))
        if r.shape[-1] != 3:
            raise InputError(f"raw triad data must have 3 columns, got shape {r.shape}")
        r = r - self.offset
        if self.g_sensitivity is not None:
            if acc_calibrated is None:
                raise InputError("this gyroscope calibration needs the calibrated acceleration")
            r = r - np.atleast_2d(np.asarray(acc_calibrated, dtype=float)) @ self.g_sensitivity.T
        return r @ self.matrix.T

    def simulate(
        self, true_input: ArrayLike, acc_true: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Raw output for true inputs (the inverse of :meth:`apply`), shape (n, 3)."""
        u = np.atleast_2d(np.asarray(true_input, dtype=float))
        raw = u @ self.forward.T + self.offset
        if self.g_sensitivity is not None and acc_true is not None:
            raw = raw + np.atleast_2d(np.asarray(acc_true, dtype=float)) @ self.g_sensitivity.T
        return raw

    def to_dict(self) -> dict[str, object]:
        """JSON layout of the issue: matrix, offset, [g_sensitivity], unit, raw_unit."""
        d: dict[str, object] = {
            "matrix": self.matrix.tolist(),
            "offset": self.offset.tolist(),
            "unit": self.unit,
            "raw_unit": self.raw_unit,
        }
        if self.g_sensitivity is not None:
            d["g_sensitivity"] = self.g_sensitivity.tolist()
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> TriadCalibration:
        """Inverse of :meth:`to_dict`; errors name the missing or malformed key."""
        for key in ("matrix", "offset", "unit"):
            if key not in d:
                raise InputError(f'calibration lacks "{key}"')
        try:
            return cls(
                matrix=np.asarray(d["matrix"], dtype=float),
                offset=np.asarray(d["offset"], dtype=float),
                unit=str(d["unit"]),
                raw_unit=str(d.get("raw_unit", "count")),
                g_sensitivity=(
                    None if d.get("g_sensitivity") is None
                    else np.asarray(d["g_sensitivity"], dtype=float)
                ),
            )
        except (TypeError, ValueError) as exc:
            raise InputError(f"malformed calibration: {exc}") from None


@dataclass(frozen=True)
class ImuCalibration:
    """Calibration of an IMU: accelerometer triad and optionally gyroscope triad."""

    accelerometer: TriadCalibration | None = None
    gyroscope: TriadCalibration | None = None

    def to_dict(self) -> dict[str, object]:
        """``{"accelerometer": {...}, "gyroscope": {...}}`` (absent triads omitted)."""
        out: dict[str, object] = {}
        if self.accelerometer is not None:
            out["accelerometer"] = self.accelerometer.to_dict()
        if self.gyroscope is not None:
            out["gyroscope"] = self.gyroscope.to_dict()
        return out

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> ImuCalibration:
        """Inverse of :meth:`to_dict`."""
        acc = d.get("accelerometer")
        gyr = d.get("gyroscope")
        if acc is None and gyr is None:
            raise InputError('calibration has neither "accelerometer" nor "gyroscope"')
        return cls(
            accelerometer=None if acc is None else TriadCalibration.from_dict(acc),  # type: ignore[arg-type]
            gyroscope=None if gyr is None else TriadCalibration.from_dict(gyr),  # type: ignore[arg-type]
        )
