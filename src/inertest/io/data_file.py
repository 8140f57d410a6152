"""Tabular data files (CSV, Parquet via pyarrow; HDF5 via h5py) <-> dicts of numpy columns."""

from __future__ import annotations

import functools
import hashlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError
from inertest.io.atomic import target_file
from inertest.io.hdf5_table import HDF5_SUFFIXES

if TYPE_CHECKING:
    import pyarrow as pa

_SUFFIXES = (".csv", ".parquet", ".pq")
#: A CSV text column with more distinct values than this is read as plain strings (then
#: encoded once); below it the reader encodes it while parsing.
_MAX_DICT_LABELS = 65536
#: Bytes of CSV text per block of the streaming reader (Arrow's default).
_CSV_BLOCK_BYTES = 1 << 20
#: Smallest block of the whole-file reader (a block costs its thread's start-up).
_CSV_MIN_BLOCK_BYTES = 1 << 17
#: A CSV up to this size is read whole (Arrow's threaded reader; its memory is a few MB):
#: opening the streaming reader costs more than the read itself on small files (a 0.4 MB
#: Ferraris session: 3.3 -> 2.5 ms).
_CSV_WHOLE_BYTES = 4 << 20


def read_table(path: str | os.PathLike[str]) -> dict[str, NDArray]:
    """Read a CSV, Parquet or HDF5 file into ``{column: ndarray}``.

    Numeric columns become float arrays (empty cells -> NaN, so the procedures can name them);
    text columns become arrays of str.

    Memory: a CSV is read block by block (:func:`_read_csv_blocks`), each block's columns
    converted and released at once, text columns as codes of their labels, so the peak is
    about the numpy columns plus one of them, not the file plus Arrow's table (3x the columns
    at 1e7 rows). A Parquet file is read whole, each Arrow column released once converted.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in HDF5_SUFFIXES:
        from inertest.io.hdf5_table import read_hdf5_table

        return read_hdf5_table(p)
    from inertest.io.psins_binary import PSINS_BINARY_SUFFIXES, read_psins_binary

    if suffix in PSINS_BINARY_SUFFIXES:
        return read_psins_binary(p)
    if suffix not in _SUFFIXES:
        raise DataError(f"data file {p}: unknown format {suffix!r}; use .csv, .parquet or .h5")
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    size = p.stat().st_size
    if suffix == ".csv" and size > _CSV_WHOLE_BYTES:
        streamed = _read_csv_blocks(p)
        if streamed is not None:
            return streamed
    try:
        if suffix == ".csv":
            # The system allocator: the parser's buffers, once freed, go back to malloc and
            # are reused by the numpy columns and the fit (mimalloc, Arrow's default, keeps
            # them: +60-90 MB at 1e6 rows on top of everything that follows). Blocks of a
            # quarter of the file, so that every core parses one: Arrow's default of 1 MB
            # leaves a small file to one thread (Arrow's read of a 0.4 MB Ferraris session:
            # 2.4 -> 1.8 ms; read_table 2.8 -> 2.5 ms).
            table = pacsv.read_csv(
                p, read_options=pacsv.ReadOptions(block_size=min(
                    _CSV_BLOCK_BYTES, max(_CSV_MIN_BLOCK_BYTES, size // 4))),
                convert_options=pacsv.ConvertOptions(
                    auto_dict_encode=True, auto_dict_max_cardinality=_MAX_DICT_LABELS),
                memory_pool=pa.system_memory_pool())
        else:  # one file: ParquetFile (pq.read_table's dataset layer imports pandas)
            with pq.ParquetFile(p) as pf:
                table = pf.read()
        names = list(table.column_names)  # decoded here: Arrow checks the values, not these
    except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError) as exc:
        raise DataError(f"data file {p} cannot be read: {_first_line(exc)}") from None
    except OSError as exc:
        if exc.errno is not None:  # the file system's error (permission, I/O), not the format
            raise
        raise DataError(f"data file {p} cannot be read: {_first_line(exc)}") from None
    except UnicodeDecodeError:
        raise DataError(f"data file {p} is not UTF-8 text; save it as UTF-8 CSV") from None
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DataError(f"data file {p} has the column {dup[0]!r} more than once; give each "
                        "column its own name")
    pending = dict(zip(table.column_names, table.columns, strict=True))
    del table
    out: dict[str, NDArray] = {}
    for name in list(pending):
        col = pending.pop(name)
        if pa.types.is_integer(col.type) or pa.types.is_floating(col.type):
            out[name] = _numeric_column(col)
        elif pa.types.is_null(col.type):
            out[name] = np.full(len(col), np.nan)
        elif pa.types.is_nested(col.type):
            raise DataError(f"data file {p}: column {name!r} holds {col.type} values (a list or "
                            "record per row); inertest reads one real number or text per row: "
                            "store each element as a column of its own")
        else:
            try:
                out[name] = _text_column(col)
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError, pa.ArrowTypeError):
                raise DataError(f"data file {p}: column {name!r} holds {col.type} values that "
                                "are neither numbers nor text; store it as numbers or UTF-8 "
                                "text") from None
        del col
    return out


def _read_csv_blocks(p: Path) -> dict[str, NDArray] | None:
    """A CSV read by Arrow's streaming reader, converted block by block; None to read it whole.

    The streaming reader fixes each column's type on the first block (as the whole-file reader
    does); a later block that does not fit it (or any other Arrow error, an empty file) returns
    None, and :func:`read_table` reads the file whole, which gives the same columns or the
    error message of before. Numeric blocks are copied out of the Arrow buffers; text blocks
    become codes into one list of labels (the labels of each block's dictionary looked up once).
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    pool = pa.system_memory_pool()  # freed blocks go back to malloc, reused by the columns

    def open_csv(types: dict[str, pa.DataType]) -> pacsv.CSVStreamingReader:
        return pacsv.open_csv(p, read_options=pacsv.ReadOptions(
            block_size=_CSV_BLOCK_BYTES), convert_options=pacsv.ConvertOptions(
            column_types=types, auto_dict_encode=True,
            auto_dict_max_cardinality=_MAX_DICT_LABELS), memory_pool=pool)

    try:
        reader = open_csv({})
        names = reader.schema.names
        if len(set(names)) != len(names):
            reader.close()
            return None  # read whole: the duplicate is named there
        # Integers in the first block (a table angle of 0 for its first 100,000 readings)
        # are parsed as float64 throughout: the numbers they become anyway, and a later
        # "22.5" then fits the column.
        ints = {n: pa.float64() for n, t in zip(names, reader.schema.types, strict=True)
                if pa.types.is_integer(t)}
        if ints:
            reader.close()
            reader = open_csv(ints)
    except (pa.ArrowException, UnicodeDecodeError, OSError):
        return None
    kinds = []
    for t in reader.schema.types:
        numeric = pa.types.is_integer(t) or pa.types.is_floating(t)
        kinds.append("num" if numeric else "null" if pa.types.is_null(t) else "text")
    # Each column is written block by block into one array sized from the first block's
    # rows per byte (grown if later rows are shorter): no list of blocks to concatenate, which
    # touched twice the column's memory (2 x 80 MB per column at 1e7 rows).
    columns: list[NDArray | None] = [None] * len(names)
    label_codes: list[dict[str, int]] = [{} for _ in names]
    size = p.stat().st_size
    rows = 0
    try:
        for batch in reader:
            k = batch.num_rows
            for j, kind in enumerate(kinds):
                if kind == "null":
                    continue
                col = batch.column(j)
                dest = columns[j]
                if dest is None or rows + k > dest.size:
                    want = k if rows == 0 else rows + k
                    if rows == 0 and size > _CSV_BLOCK_BYTES:  # ~1 block per _CSV_BLOCK_BYTES
                        want = int(k * (1.02 * size / _CSV_BLOCK_BYTES + 1))
                    grown = np.empty(max(want, int(1.25 * rows)),
                                     dtype=np.float64 if kind == "num" else np.int32)
                    if dest is not None:
                        grown[:rows] = dest[:rows]
                    columns[j] = dest = grown
                if kind == "num":
                    _fill_numeric(col, dest[rows:rows + k])
                else:
                    dest[rows:rows + k] = _text_codes(col, label_codes[j])
            rows += k
            del batch
    except (pa.ArrowException, UnicodeDecodeError, OSError):
        return None
    finally:
        reader.close()
    if rows == 0:
        return None
    out: dict[str, NDArray] = {}
    for j, name in enumerate(names):
        values, columns[j] = columns[j], None
        if kinds[j] == "null" or values is None:
            out[name] = np.full(rows, np.nan)
        elif kinds[j] == "num":
            out[name] = values[:rows]  # pages beyond ``rows`` were never touched
        else:
            labels = np.asarray(list(label_codes[j]), dtype=str)
            out[name] = labels[values[:rows]]
    return out


def _text_codes(arr: pa.Array, codes_of: dict[str, int]) -> NDArray[np.int32]:
    """Codes of a block of a text column into ``codes_of`` (label -> code, extended here)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if pa.types.is_dictionary(arr.type) and pa.types.is_string(arr.type.value_type):
        enc = arr
    else:
        enc = pc.dictionary_encode(pc.cast(arr, pa.string()))
    lut = np.array([codes_of.setdefault(v if v is not None else "", len(codes_of))
                    for v in enc.dictionary.to_pylist()] or [0], dtype=np.int32)
    index_type = enc.indices.type
    dtype = np.dtype(f"{'i' if pa.types.is_signed_integer(index_type) else 'u'}"
                     f"{index_type.bit_width // 8}")
    codes = lut[_buffer_values(enc.indices, dtype)]
    if enc.null_count:
        codes[~_validity(enc.indices)] = codes_of.setdefault("", len(codes_of))
    return codes


def _first_line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def _numeric_column(col: pa.ChunkedArray) -> NDArray[np.float64]:
    """Numeric column as a new float array (nulls become NaN).

    Read from the Arrow buffers with ``np.frombuffer``, chunk by chunk into one array: Arrow's
    own ``to_numpy`` imports pandas (~0.3 s and ~40 MB), which nothing else here needs.
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    if not pa.types.is_float64(col.type):  # one cast for every chunk
        col = pc.cast(col, pa.float64(), safe=False)  # ints round as astype(float)
    if col.null_count == 0:  # the common case: one copy of all chunks
        parts = [_buffer_values(c, np.dtype(np.float64)) for c in col.chunks]
        return np.concatenate(parts) if parts else np.empty(0)
    out = np.empty(len(col))
    start = 0
    for chunk in col.chunks:
        k = len(chunk)
        _fill_numeric(chunk, out[start:start + k])
        start += k
    return out


def _fill_numeric(chunk: pa.Array, dest: NDArray[np.float64]) -> None:
    """Write a numeric Arrow array into ``dest`` as float64 (nulls become NaN)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if not pa.types.is_float64(chunk.type):
        # Ints round as numpy's astype(float) does; other floats widen exactly.
        chunk = pc.cast(chunk, pa.float64(), safe=False)
    dest[:] = _buffer_values(chunk, np.dtype(np.float64))
    if chunk.null_count:
        dest[~_validity(chunk)] = np.nan


def _buffer_values(arr: pa.Array, dtype: np.dtype) -> NDArray:
    """Read-only view of the values of a primitive Arrow array (no copy)."""
    buf = arr.buffers()[1]
    if buf is None or len(arr) == 0:
        return np.empty(0, dtype=dtype)
    return np.frombuffer(buf, dtype=dtype, count=len(arr), offset=arr.offset * dtype.itemsize)


def _validity(arr: pa.Array) -> NDArray[np.bool_]:
    """True where an Arrow array holds a value (its validity bitmap, LSB first)."""
    bits = arr.buffers()[0]
    if bits is None:
        return np.ones(len(arr), dtype=bool)
    flags = np.unpackbits(np.frombuffer(bits, dtype=np.uint8), bitorder="little")
    return flags[arr.offset:arr.offset + len(arr)].astype(bool)


def _text_column(col: pa.ChunkedArray) -> NDArray:
    """Text column as an array of str (empty cells become "").

    Test data repeat a few labels (mountings, directions), so the distinct values are converted
    once and indexed, much faster than one Python object per row.
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    if pa.types.is_dictionary(col.type) and pa.types.is_string(col.type.value_type):
        enc = col.unify_dictionaries().combine_chunks()  # as the CSV reader encoded it
    else:
        enc = pc.dictionary_encode(pc.cast(col, pa.string())).combine_chunks()
    labels = np.asarray([v if v is not None else "" for v in enc.dictionary.to_pylist()],
                        dtype=str)
    index_type = enc.indices.type
    dtype = np.dtype(f"{'i' if pa.types.is_signed_integer(index_type) else 'u'}"
                     f"{index_type.bit_width // 8}")
    codes = _buffer_values(enc.indices, dtype)
    if enc.null_count:
        labels = np.append(labels, "")
        codes = np.where(_validity(enc.indices), codes, labels.size - 1)
    return labels[codes]


def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a file's bytes (hex), read in blocks.

    A folder (a ROS 2 bag) hashes the relative name and the bytes of each of its files in
    name order; links are not followed out of it.
    """
    h = hashlib.sha256()
    p = Path(path)
    files = ([f for f in sorted(p.rglob("*")) if f.is_file() and not f.is_symlink()]
             if p.is_dir() else [p])
    for f in files:
        if p.is_dir():
            h.update(f.relative_to(p).as_posix().encode("utf-8") + b"\0")
        with f.open("rb") as fh:
            for block in iter(functools.partial(fh.read, 1 << 20), b""):
                h.update(block)
    return h.hexdigest()


def write_table(
    path: str | os.PathLike[str],
    columns: Mapping[str, NDArray],
    units: Mapping[str, str] | None = None,
) -> Path:
    """Write columns to CSV, Parquet or HDF5 (by suffix), atomically.

    ``units`` (column -> unit) is stored as HDF5 dataset attributes and as Parquet field
    metadata (``unit``); CSV has no place for it (callers print it or put it in the names).
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in HDF5_SUFFIXES:
        from inertest.io.hdf5_table import write_hdf5_table

        return write_hdf5_table(p, columns, units)
    if suffix not in _SUFFIXES:
        raise DataError(f"output file {p}: unknown format {suffix!r}; use .csv, .parquet or .h5")
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    table = pa.table({k: np.asarray(v) for k, v in columns.items()})
    if units and suffix != ".csv":
        table = table.cast(pa.schema([
            f.with_metadata({"unit": units[f.name]}) if f.name in units else f
            for f in table.schema]))
    with target_file(p) as tmp:
        if suffix == ".csv":
            pacsv.write_csv(table, tmp)
        else:
            pq.write_table(table, tmp)
    return p
