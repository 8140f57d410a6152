"""The IMU model: an accelerometer triad and a gyro triad on one body.

Each triad follows :mod:`inertest.models.triad` (``raw = K (I + M) u + b [+ G a]``); the IMU
calibration corrects a recording with both: the accelerometers first, then the gyros with their
g-sensitivity to the *calibrated* specific force (JSON ``"calibration"`` block of every triad
procedure's result, read back by ``inertest apply``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from inertest.errors import InputError
from inertest.models.triad import TriadCalibration


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
