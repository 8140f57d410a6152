"""LabVIEW TDMS files (``.tdms``) through :mod:`nptdms`.

A topic is a TDMS group (``--topic "IMU"``; default the only group, else the group whose channels
look like an IMU's); its channels are the columns, with the channel's ``unit_string`` property
as its unit. A waveform channel (``wf_increment`` [s]) gets a ``time_s`` column [s] from the
start (nptdms' ``time_track``), unless the group has a time channel of its own. Channels are
read in blocks (``TdmsFile.open``, ``read_data``), so a long bench record streams.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, import_extra

_WHAT = "reading LabVIEW TDMS files"
BLOCK_ROWS = 1 << 20


def _open(path: Path) -> Any:
    nptdms = import_extra("nptdms", _WHAT)
    if path.stat().st_size == 0:
        raise DataError(f"{path} is empty (0 bytes): no channels to read")
    try:
        return nptdms.TdmsFile.open(str(path))  # type: ignore[attr-defined]
    except Exception as exc:  # noqa: BLE001 - nptdms raises several kinds on a bad file
        text = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise DataError(f"{path} cannot be read as a TDMS file: {text}; it may be truncated "
                        "(LabVIEW still writing it) or not TDMS") from None


def groups(path: Path) -> dict[str, list[str]]:
    """``{group: [channel, ...]}``."""
    with _open(path) as f:
        return {g.name: [c.name for c in g.channels()] for g in f.groups()}


def listing(found: dict[str, list[str]]) -> str:
    """The groups found, for messages."""
    return "; ".join(f"{g} ({', '.join(c) or 'no channels'})" for g, c in found.items()) or "none"


def choose_group(path: Path, topic: str | None, looks_like_imu: Any) -> str:
    """The group asked for, the only one, or the only one ``looks_like_imu(channels)``."""
    found = groups(path)
    if topic is not None:
        if topic not in found:
            raise DataError(f"{path} has no group {topic!r}; groups found: {listing(found)}; "
                            "choose one with --topic")
        return topic
    filled = {g: c for g, c in found.items() if c}
    if len(filled) == 1:
        return next(iter(filled))
    imu = [g for g, c in filled.items() if looks_like_imu(c)]
    if len(imu) == 1:
        return imu[0]
    if not filled:
        raise DataError(f"{path} has no channels (groups found: {listing(found)})")
    raise DataError(f"{path} has several groups: {listing(found)}; choose one with --topic")


class TdmsGroup:
    """The channels of one group, read in blocks."""

    def __init__(self, path: Path, group: str) -> None:
        self.path = path
        self.group = group
        with _open(path) as f:
            chans = f[group].channels()
            self.names = [c.name for c in chans]
            self.units = {c.name: str(c.properties.get("unit_string", "")) for c in chans
                          if c.properties.get("unit_string")}
            lengths = {c.name: len(c) for c in chans}
            self.increment = next((float(c.properties["wf_increment"]) for c in chans
                                   if "wf_increment" in c.properties), None)
        counts = set(lengths.values())
        if len(counts) > 1:
            raise DataError(f"group {group} of {path} has channels of different lengths "
                            f"({', '.join(f'{k}: {v}' for k, v in lengths.items())}); "
                            "mixed-rate channels are not one table: choose channels of one "
                            "rate (--gyro-columns/--accel-columns) or resample them")
        self.count = counts.pop() if counts else 0
        if self.count == 0:
            raise DataError(f"group {group} of {path} has no samples")
        self.time_column = ("time_s" if self.increment is not None and "time_s" not in self.names
                            else None)

    def batches(self, columns: Sequence[str] | None = None,
                rows: int = BLOCK_ROWS) -> Iterator[dict[str, NDArray]]:
        """Columns block by block (``time_s`` [s] for a waveform group)."""
        names = [c for c in self.names if columns is None or c in columns]
        with _open(self.path) as f:
            g = f[self.group]
            for start in range(0, self.count, rows):
                k = min(rows, self.count - start)
                out = {}
                for name in names:
                    values = g[name].read_data(start, k)
                    out[name] = np.asarray(values)
                if self.time_column is not None and (columns is None
                                                     or self.time_column in columns):
                    assert self.increment is not None
                    out[self.time_column] = (np.arange(start, start + k) * self.increment)
                yield out
