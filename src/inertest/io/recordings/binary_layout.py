"""A vendor's fixed-size binary record, described by a small TOML layout (``--layout``).

A lab reads its STIM300 datagrams or its test bench's log without code::

    [record]
    size = 38                 # bytes per record
    byte_order = "big"        # "little" (default) or "big"
    header_bytes = 0          # bytes before the first record (default 0)
    rate_hz = 125.0           # sample rate, when no field is the time (optional)
    time = "counter_s"        # the field holding the time (optional)
    sync = { offset = 0, value = 0x93 }   # a byte every record holds (optional, checked)

    [fields.gyro_x]           # one table per field, in any order
    offset = 1                # byte offset in the record
    type = "int24"            # int8/16/24/32/64, uint8/16/24/32/64, float32, float64
    scale = 1.9073486328125e-06   # value = raw * scale + add
    add = 0.0                 # (optional)
    unit = "deg/s"            # unit of the value (optional)

Values are read straight from the file block by block (``np.fromfile`` with a structured dtype
of the record), so a long record streams; 24-bit integers (the STIM300's) are assembled from
their three bytes, two's complement for ``int24``.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, InputError

TYPES = ("int8", "uint8", "int16", "uint16", "int24", "uint24", "int32", "uint32", "int64",
         "uint64", "float32", "float64")
BLOCK_RECORDS = 1 << 18


@dataclass(frozen=True)
class Field:
    """One field of the record."""

    name: str
    offset: int
    type: str
    scale: float = 1.0
    add: float = 0.0
    unit: str = ""

    @property
    def size(self) -> int:
        """Bytes the field takes."""
        return 3 if self.type.endswith("24") else np.dtype(self.type).itemsize


@dataclass(frozen=True)
class Layout:
    """A record layout read from TOML (module docstring)."""

    size: int
    byte_order: str
    header_bytes: int
    fields: tuple[Field, ...]
    rate_hz: float | None = None
    time: str | None = None
    sync: tuple[int, int] | None = None
    source: str = "the layout"

    @property
    def units(self) -> dict[str, str]:
        """Unit of each field that states one."""
        return {f.name: f.unit for f in self.fields if f.unit}


def _bad(source: str, text: str) -> InputError:
    return InputError(f"layout {source}: {text}")


def read_layout(path: str | os.PathLike[str]) -> Layout:
    """Read and check a TOML record layout."""
    p = Path(path)
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise _bad(str(p), f"not valid TOML ({exc})") from None
    except UnicodeDecodeError:
        raise _bad(str(p), "not UTF-8 text") from None
    return layout_from_dict(doc, source=str(p))


def layout_from_dict(doc: dict, *, source: str = "the layout") -> Layout:
    """A :class:`Layout` from the parsed TOML (see the module docstring)."""
    rec = doc.get("record")
    if not isinstance(rec, dict):
        raise _bad(source, "needs a [record] table with size (bytes per record)")
    unknown = set(rec) - {"size", "byte_order", "header_bytes", "rate_hz", "time", "sync"}
    if unknown:
        raise _bad(source, f"[record] has unknown key {sorted(unknown)[0]!r}; keys are size, "
                           "byte_order, header_bytes, rate_hz, time, sync")
    size = rec.get("size")
    if not isinstance(size, int) or isinstance(size, bool) or size <= 0:
        raise _bad(source, f"[record] size must be a positive whole number of bytes, got {size!r}")
    order = rec.get("byte_order", "little")
    if order not in ("little", "big"):
        raise _bad(source, f"byte_order must be 'little' or 'big', got {order!r}")
    header = rec.get("header_bytes", 0)
    if not isinstance(header, int) or isinstance(header, bool) or header < 0:
        raise _bad(source, f"header_bytes must be a whole number >= 0, got {header!r}")
    rate = rec.get("rate_hz")
    if rate is not None and not (isinstance(rate, int | float) and math.isfinite(rate)
                                 and rate > 0):
        raise _bad(source, f"rate_hz must be a positive number, got {rate!r}")
    sync = rec.get("sync")
    sync_t = None
    if sync is not None:
        if not (isinstance(sync, dict) and isinstance(sync.get("offset"), int)
                and isinstance(sync.get("value"), int) and 0 <= sync["value"] <= 255
                and 0 <= sync["offset"] < size):
            raise _bad(source, "sync must be { offset = BYTE, value = 0..255 } inside the record")
        sync_t = (int(sync["offset"]), int(sync["value"]))
    table = doc.get("fields")
    if not isinstance(table, dict) or not table:
        raise _bad(source, "needs [fields.NAME] tables (offset, type, scale, unit)")
    fields = []
    for name, f in table.items():
        if not isinstance(f, dict):
            raise _bad(source, f"fields.{name} must be a table")
        extra = set(f) - {"offset", "type", "scale", "add", "unit"}
        if extra:
            raise _bad(source, f"fields.{name} has unknown key {sorted(extra)[0]!r}; keys are "
                               "offset, type, scale, add, unit")
        typ = f.get("type")
        if typ not in TYPES:
            raise _bad(source, f"fields.{name}: type {typ!r} is not known; use one of "
                               f"{', '.join(TYPES)}")
        off = f.get("offset")
        if not isinstance(off, int) or isinstance(off, bool) or off < 0:
            raise _bad(source, f"fields.{name}: offset must be a whole number of bytes >= 0")
        scale, add = f.get("scale", 1.0), f.get("add", 0.0)
        for key, v in (("scale", scale), ("add", add)):
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)):
                raise _bad(source, f"fields.{name}: {key} must be a finite number, got {v!r}")
        fld = Field(str(name), off, typ, float(scale), float(add), str(f.get("unit", "")))
        if off + fld.size > size:
            raise _bad(source, f"fields.{name} ({typ} at byte {off}) runs past the end of the "
                               f"{size}-byte record")
        fields.append(fld)
    time = rec.get("time")
    if time is not None and time not in table:
        raise _bad(source, f"[record] time = {time!r} names no field; fields: "
                           f"{', '.join(table)}")
    return Layout(size, order, header, tuple(fields), None if rate is None else float(rate),
                  time, sync_t, source)


class BinaryRecords:
    """The records of a binary file under a :class:`Layout`, read in blocks."""

    def __init__(self, path: Path, layout: Layout) -> None:
        self.path = path
        self.layout = layout
        total = path.stat().st_size - layout.header_bytes
        if total <= 0:
            raise DataError(f"{path} is empty (no bytes after the {layout.header_bytes}-byte "
                            "header): no records to read")
        self.count, rest = divmod(total, layout.size)
        if rest:
            raise DataError(f"{path} ends {rest} bytes into a record (records of "
                            f"{layout.size} bytes from byte {layout.header_bytes}): the file is "
                            "cut off or the layout's size is wrong; cut it at the last whole "
                            f"record ({self.count} records) or fix {layout.source}")
        self.names = [f.name for f in layout.fields]
        self._dtype = self._record_dtype()

    def _record_dtype(self) -> np.dtype:
        end = "<" if self.layout.byte_order == "little" else ">"
        names, formats, offsets = [], [], []
        for f in self.layout.fields:
            names.append(f.name)
            offsets.append(f.offset)
            formats.append("(3,)u1" if f.type.endswith("24")
                           else f"{end}{np.dtype(f.type).str[1:]}")
        if self.layout.sync is not None:
            names.append("__sync__")
            offsets.append(self.layout.sync[0])
            formats.append("u1")
        return np.dtype({"names": names, "formats": formats, "offsets": offsets,
                         "itemsize": self.layout.size})

    def batches(self, columns: Sequence[str] | None = None,
                rows: int = BLOCK_RECORDS) -> Iterator[dict[str, NDArray]]:
        """Scaled columns (float64) block by block."""
        lay = self.layout
        for start in range(0, self.count, rows):
            k = min(rows, self.count - start)
            block = np.fromfile(self.path, dtype=self._dtype, count=k,
                                offset=lay.header_bytes + start * lay.size)
            if lay.sync is not None:
                bad = np.flatnonzero(block["__sync__"] != lay.sync[1])
                if bad.size:
                    i = start + int(bad[0])
                    raise DataError(f"{self.path}: record {i} (byte "
                                    f"{lay.header_bytes + i * lay.size}) does not hold the sync "
                                    f"byte 0x{lay.sync[1]:02x} at offset {lay.sync[0]}: the file "
                                    f"is out of step with {lay.source} (wrong size or "
                                    "header_bytes, or a lost byte)")
            out = {}
            for f in lay.fields:
                if columns is not None and f.name not in columns:
                    continue
                raw = _int24(block[f.name], lay.byte_order, f.type) if f.type.endswith(
                    "24") else block[f.name]
                out[f.name] = raw.astype(np.float64) * f.scale + f.add
            yield out


def _int24(b: NDArray[np.uint8], order: str, typ: str) -> NDArray[np.int64]:
    """24-bit integers from their three bytes (two's complement for ``int24``)."""
    b = b.astype(np.int64)
    v = (b[:, 0] << 16 | b[:, 1] << 8 | b[:, 2]) if order == "big" else (
        b[:, 2] << 16 | b[:, 1] << 8 | b[:, 0])
    if typ == "int24":
        v = np.where(v >= 1 << 23, v - (1 << 24), v)
    return v
