"""In-memory tables from notebooks -> ``{column: ndarray}``.

pandas DataFrames, pyarrow Tables and RecordBatches, mappings of arrays.

The columns keep their dtype where numpy has it (integers stay integers, float32 stays
float32); pandas' nullable integers and booleans with missing values become float64 with NaN,
categoricals and text become arrays of str (missing text ""), as the file readers give them.
pandas is never imported here: a DataFrame is recognised by its type's module.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, InputError


def is_frame(obj: object) -> bool:
    """A pandas DataFrame, or a pyarrow Table / RecordBatch."""
    mod = type(obj).__module__
    return ((mod.startswith("pandas") and hasattr(obj, "columns") and hasattr(obj, "dtypes"))
            or (mod.startswith("pyarrow") and hasattr(obj, "column_names")))


def columns_of(obj: object, *, what: str = "data") -> dict[str, NDArray]:
    """The columns of a DataFrame, a pyarrow Table or RecordBatch, or a mapping of arrays.

    Raises
    ------
    InputError
        Anything else (naming what was given and what is read), or duplicate column names.
    """
    mod = type(obj).__module__
    if mod.startswith("pyarrow") and hasattr(obj, "column_names"):
        return _arrow(obj, what)
    if mod.startswith("pandas") and hasattr(obj, "columns") and hasattr(obj, "dtypes"):
        return _pandas(obj, what)
    if isinstance(obj, Mapping):
        return {str(k): np.asarray(v) for k, v in obj.items()}
    raise InputError(f"{what} must be a path to a data file, a pandas DataFrame, a pyarrow "
                     f"Table or a dict of column arrays; got {type(obj).__name__}")


def _pandas(df: Any, what: str) -> dict[str, NDArray]:
    names = [str(c) for c in df.columns]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise DataError(f"{what}: the DataFrame has the column {dup!r} more than once; give "
                        "each column its own name")
    out: dict[str, NDArray] = {}
    for name, col in zip(names, (df[c] for c in df.columns), strict=True):
        dtype = col.dtype
        kind = getattr(dtype, "kind", "O")
        if str(dtype) in ("category", "string", "str") or kind in "OUS":
            values = col.astype(object).to_numpy()
            out[name] = np.asarray(["" if v is None or v != v else str(v) for v in values],
                                   dtype=str)
        elif kind in "iufb" and not getattr(col, "hasnans", False):
            out[name] = col.to_numpy(dtype=getattr(dtype, "numpy_dtype", dtype))
        elif kind in "iufb":  # nullable integers/booleans with <NA>
            out[name] = col.to_numpy(dtype=np.float64, na_value=np.nan)
        elif kind == "M":
            out[name] = col.to_numpy()
        else:
            raise DataError(f"{what}: column {name!r} holds {dtype} values; inertest reads "
                            "numbers or text")
    return out


def _arrow(table: Any, what: str) -> dict[str, NDArray]:
    import pyarrow as pa

    from inertest.io.data_file import _numeric_column, _text_column

    names = list(table.column_names)
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise DataError(f"{what}: the Table has the column {dup!r} more than once; give each "
                        "column its own name")
    out: dict[str, NDArray] = {}
    for name in names:
        col = table.column(name)
        if isinstance(col, pa.Array):
            col = pa.chunked_array([col])
        t = col.type
        if (pa.types.is_integer(t) or pa.types.is_floating(t)) and col.null_count == 0:
            parts = [c.to_numpy(zero_copy_only=False) for c in col.chunks]
            out[name] = (np.concatenate(parts) if parts
                         else np.empty(0, dtype=t.to_pandas_dtype()))
        elif pa.types.is_integer(t) or pa.types.is_floating(t):
            out[name] = _numeric_column(col)
        elif pa.types.is_nested(t):
            raise DataError(f"{what}: column {name!r} holds {t} values (a list per row); "
                            "store each element as a column")
        else:
            out[name] = _text_column(col)
    return out
