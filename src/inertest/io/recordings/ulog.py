"""PX4 ULog files (``.ulg``) through :mod:`pyulog` (docs.px4.io, "ULog File Format").

A topic is one logged uORB message (``--topic sensor_combined``; another instance as
``vehicle_imu:1``), read as the columns :mod:`pyulog` gives, named and typed as it gives them
(``timestamp`` [us] as uint64, ``gyro_rad[0]`` [rad/s] as float32, ...). Without a topic the IMU
topics are looked for in this order: ``sensor_combined`` (``gyro_rad`` [rad/s],
``accelerometer_m_s2`` [m/s^2], PX4's field names carry the unit) and ``vehicle_imu`` (integrated
``delta_angle`` [rad] and ``delta_velocity`` [m/s] over ``delta_angle_dt`` /
``delta_velocity_dt`` [us]; here divided by their intervals into rates, columns ``gyro_x``..
``accel_z``). pyulog reads the whole file into memory (it has no streaming reader): a ULog is
the flight controller's own log, hundreds of MB at most.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, import_extra

IMU_TOPICS = ("sensor_combined", "vehicle_imu")
_WHAT = "reading PX4 ULog files"


def _split(topic: str) -> tuple[str, int]:
    name, _, inst = topic.partition(":")
    try:
        return name, int(inst) if inst else 0
    except ValueError:
        raise DataError(f"topic {topic!r}: a ULog topic is a message name, optionally "
                        "':N' for instance N (e.g. vehicle_imu:1)") from None


def _open(path: Path, names: list[str] | None) -> Any:
    pyulog = import_extra("pyulog", _WHAT)
    if path.stat().st_size == 0:
        raise DataError(f"{path} is empty (0 bytes): no messages to read")
    try:
        return pyulog.ULog(str(path), message_name_filter_list=names)  # type: ignore[attr-defined]
    except Exception as exc:  # noqa: BLE001 - pyulog raises several kinds on a bad file
        text = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise DataError(f"{path} cannot be read as a PX4 ULog file: {text}") from None


def topics(path: Path) -> dict[str, int]:
    """``{topic: messages}`` of every logged topic (instances after the first as ``name:N``)."""
    u = _open(path, None)
    out = {}
    for d in u.data_list:
        key = d.name if d.multi_id == 0 else f"{d.name}:{d.multi_id}"
        out[key] = int(len(d.data["timestamp"]))
    return out


def listing(found: dict[str, int]) -> str:
    """The topics found, for messages."""
    return ", ".join(f"{k} ({n} messages)" for k, n in found.items()) or "none"


def choose_topic(path: Path, topic: str | None,
                 found: dict[str, int] | None = None) -> str:
    """The topic asked for, or the first IMU topic in :data:`IMU_TOPICS`; errors name them.

    ``found``: :func:`topics` of the file, when already read.
    """
    found = topics(path) if found is None else found
    if topic is not None:
        if topic not in found and _split(topic)[0] + ":0" not in found:
            raise DataError(f"{path} has no topic {topic!r}; topics found: {listing(found)}; "
                            "choose one with --topic")
        if found.get(topic, 1) == 0:
            raise DataError(f"topic {topic} of {path} has no messages; topics found: "
                            f"{listing(found)}")
        return topic
    for name in IMU_TOPICS:
        if found.get(name):
            return name
    raise DataError(f"{path} has no IMU topic ({', '.join(IMU_TOPICS)}); topics found: "
                    f"{listing(found)}; choose one with --topic")


def read_topic(path: Path, topic: str) -> dict[str, NDArray]:
    """The columns of one topic as pyulog gives them (plus rates for ``vehicle_imu``)."""
    name, instance = _split(topic)
    u = _open(path, [name])
    data = next((d for d in u.data_list if d.name == name and d.multi_id == instance), None)
    if data is None:
        raise DataError(f"{path} has no topic {topic!r}; topics found: "
                        f"{listing(topics(path))}; choose one with --topic")
    out = {k: np.asarray(v) for k, v in data.data.items()}
    if name == "vehicle_imu":
        out.update(vehicle_imu_rates(out, path))
    return out


def vehicle_imu_rates(cols: dict[str, NDArray], path: Path) -> dict[str, NDArray]:
    """``gyro_x..z`` [rad/s] and ``accel_x..z`` [m/s^2]: PX4's increments over their intervals."""
    out = {}
    for prefix, delta, dt in (("gyro", "delta_angle", "delta_angle_dt"),
                              ("accel", "delta_velocity", "delta_velocity_dt")):
        if dt not in cols or f"{delta}[0]" not in cols:
            continue
        seconds = np.asarray(cols[dt], dtype=np.float64) * 1e-6
        if np.any(seconds <= 0):
            raise DataError(f"{path}: vehicle_imu has a {dt} of zero or less; its increments "
                            "cannot be turned into rates")
        for i, axis in enumerate("xyz"):
            out[f"{prefix}_{axis}"] = np.asarray(cols[f"{delta}[{i}]"], dtype=np.float64) / seconds
    return out


def imu_columns(topic: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Gyro [rad/s] and accelerometer [m/s^2] columns of a known IMU topic, else empty."""
    name = _split(topic)[0]
    if name == "sensor_combined":
        return (tuple(f"gyro_rad[{i}]" for i in range(3)),
                tuple(f"accelerometer_m_s2[{i}]" for i in range(3)))
    if name == "vehicle_imu":
        return (tuple(f"gyro_{a}" for a in "xyz"), tuple(f"accel_{a}" for a in "xyz"))
    return (), ()
