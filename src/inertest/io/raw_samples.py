"""One column of samples from a data file: tables, ``.npy`` or raw binary (read in chunks).

Long records (larger than memory) come as raw little-endian binary (``.bin``, ``.f32``,
``.f64``, ``.raw``) or 1-D ``.npy``; both are opened as :class:`SampleFile`, an array-like that
reads only the slices asked for (``np.fromfile`` at an offset), so the Allan-family statistics
of :mod:`inertest.noise` stream through them in bounded memory. A memory map would do the same
arithmetic, but the pages it touches count as the process's resident memory.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from numpy.typing import DTypeLike, NDArray

from inertest.errors import DataError, InputError
from inertest.io.data_file import read_table
from inertest.io.hdf5_table import column_kind


class SampleFile:
    """Read-only 1-D array-like over samples stored contiguously in a file.

    Supports ``len()``, integer indexing and slices with step 1 (what the streaming statistics
    use); each slice is read from the file as a new array.
    """

    def __init__(self, path: Path, dtype: np.dtype, offset: int, count: int) -> None:
        self.path = path
        self.dtype = dtype
        self.offset = offset
        self.shape = (count,)
        self.ndim = 1

    def __len__(self) -> int:
        return self.shape[0]

    def _read(self, start: int, stop: int) -> NDArray:
        n = max(0, stop - start)
        if n == 0:
            return np.empty(0, dtype=self.dtype)
        return np.fromfile(self.path, dtype=self.dtype, count=n,
                           offset=self.offset + start * self.dtype.itemsize)

    def __getitem__(self, key: int | slice) -> NDArray | float:
        if isinstance(key, slice):
            start, stop, step = key.indices(len(self))
            if step != 1:
                raise IndexError("SampleFile reads contiguous slices only")
            return self._read(start, stop)
        i = int(key)
        if i < 0:
            i += len(self)
        if not 0 <= i < len(self):
            raise IndexError(i)
        return self._read(i, i + 1)[0]

    def __array__(self, dtype: DTypeLike | None = None, copy: object = None) -> NDArray:
        a = self._read(0, len(self))
        return a if dtype is None else a.astype(dtype)


RAW_SUFFIXES = {".bin": None, ".raw": None, ".f32": "float32", ".f64": "float64"}
RAW_DTYPES = ("float32", "float64", "int16", "int32", "int64")


def read_samples(
    path: str | os.PathLike[str], column: str | None = None, *, dtype: str | None = None,
    topic: str | None = None, layout: str | os.PathLike[str] | None = None,
) -> NDArray | SampleFile:
    """Samples of one column, as an array, or a :class:`SampleFile` for a long record.

    Parameters
    ----------
    path : path
        CSV, Parquet, HDF5 (``column`` required when there are several), ``.npy`` (1-D, or 2-D
        with ``column`` an integer index) or raw binary (``dtype`` from the suffix ``.f32``/
        ``.f64`` or given; ``.bin``/``.raw`` need it).
    column : str, optional
        Column name (tables) or index (2-D ``.npy``).
    dtype : str, optional
        Sample type of a raw binary file, one of :data:`RAW_DTYPES`.
    topic, layout : optional
        A recording's topic and a binary record's TOML layout
        (:func:`inertest.io.recordings.read_data`); its columns are read like a table's.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    suffix = p.suffix.lower()
    from inertest.io.recordings import recording_format

    if layout is not None or recording_format(p) is not None:
        from inertest.io.recordings import open_recording

        rec = open_recording(p, topic=topic, layout=layout)
        names = list(rec.names)
        if column is None:
            raise InputError(f"{p} has columns {', '.join(names) or '(by message)'}; choose "
                             "one with --column")
        if names and column not in names:
            raise DataError(f"{p} has no column {column!r}; it has {', '.join(names)}: fix "
                            "--column")
        values = rec.read([column]).get(column)
        if values is None or values.dtype.kind not in "fiu":
            raise DataError(f"column {column!r} of {p} is not numeric")
        return np.asarray(values, dtype=np.float64)
    if topic is not None:
        raise InputError(f"{p.name}: --topic is for recordings (ROS bags, MCAP, ULog, TDMS)")
    if suffix in RAW_SUFFIXES:
        dt = dtype or RAW_SUFFIXES[suffix]
        if dt is None:
            raise InputError(
                f"raw binary file {p}: give the sample type with --dtype "
                f"({', '.join(RAW_DTYPES)}), or name the file .f32/.f64"
            )
        if dt not in RAW_DTYPES:
            raise InputError(f"unknown --dtype {dt!r}; use one of {', '.join(RAW_DTYPES)}")
        size = p.stat().st_size
        item = np.dtype(dt).itemsize
        if size == 0 or size % item:
            raise DataError(f"raw file {p} has {size} bytes, not a whole number of {dt} samples")
        return SampleFile(p, np.dtype(dt).newbyteorder("<"), 0, size // item)
    if suffix == ".npy":
        try:
            arr = np.load(p, mmap_mode="r", allow_pickle=False)
        except ValueError as exc:
            raise DataError(f"data file {p} cannot be read as .npy: {exc}") from None
        if arr.dtype.kind not in "fiu":
            raise DataError(f"data file {p} {column_kind(arr.dtype)}")
        if arr.ndim == 1:
            return SampleFile(p, arr.dtype, int(arr.offset), arr.shape[0])
        if arr.ndim == 2 and column is not None and column.isdigit():
            if int(column) >= arr.shape[1]:
                raise DataError(f"{p} has {arr.shape[1]} columns (0 to {arr.shape[1] - 1}); "
                                f"--column {column} is out of range")
            return arr[:, int(column)]
        raise DataError(
            f"{p} holds an array of shape {arr.shape}; save one column (1-D), or give "
            "--column as the index of the column"
        )
    table = read_table(p)
    numeric = [k for k, v in table.items() if v.dtype.kind == "f"]
    if column is None:
        if len(numeric) == 1:
            return table[numeric[0]]
        raise InputError(
            f"{p} has columns {', '.join(table)}; choose one with --column"
        )
    if column not in table:
        raise DataError(
            f"{p} has no column {column!r}; it has {', '.join(table)}: fix --column"
        )
    if table[column].dtype.kind != "f":
        raise DataError(f"column {column!r} of {p} is not numeric")
    return table[column]
