"""Tabular data in HDF5: one 1-D dataset per column at the file's root, via h5py.

Text columns are stored as UTF-8 strings; a dataset attribute ``unit`` carries the column's
unit when known. Only datasets stored in the file itself are read: external and soft links,
external raw storage and virtual datasets (which would read other files) are refused.
Reached through :func:`inertest.io.data_file.read_table` and ``write_table``
for ``.h5`` and ``.hdf5`` files.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError
from inertest.io.atomic import target_file

HDF5_SUFFIXES = (".h5", ".hdf5")


def _h5py():  # noqa: ANN202 - the module
    """h5py, or a one-line error naming the extra that installs it."""
    from inertest.errors import import_extra

    return import_extra("h5py", "reading and writing HDF5 tables")


def is_hdf5(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names an HDF5 file (by suffix)."""
    return Path(path).suffix.lower() in HDF5_SUFFIXES


def read_hdf5_table(path: str | os.PathLike[str]) -> dict[str, NDArray]:
    """Read the root-level 1-D datasets of an HDF5 file into ``{column: ndarray}``."""
    h5py = _h5py()

    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    out: dict[str, NDArray] = {}
    try:
        with h5py.File(p, "r") as fh:
            for name in fh:
                link = fh.get(name, getlink=True)
                if not isinstance(link, h5py.HardLink):
                    raise DataError(
                        f"data file {p}: {name!r} is a link to {_link_target(link)}; inertest "
                        "reads only datasets stored in the file itself: copy the data in")
                ds = fh[name]
                if not isinstance(ds, h5py.Dataset) or ds.ndim != 1:
                    continue
                if ds.external or ds.is_virtual:
                    raise DataError(
                        f"data file {p}: dataset {name!r} keeps its values in other files "
                        "(external or virtual storage); copy the data into the file")
                if ds.dtype.kind == "S" or h5py.check_string_dtype(ds.dtype) is not None:
                    out[name] = np.asarray(ds.asstr()[()], dtype=str)
                elif ds.dtype.kind in "fiub":
                    out[name] = np.asarray(ds[()], dtype=float)
                else:
                    raise DataError(f"data file {p}: column {name!r} {column_kind(ds.dtype)}")
    except DataError:
        raise
    except (OSError, ValueError, TypeError, UnicodeDecodeError) as exc:
        if isinstance(exc, OSError) and exc.errno is not None:
            raise  # the file system's error (permission, I/O), not the format
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise DataError(f"data file {p} cannot be read as HDF5: {reason}") from None
    if not out:
        raise DataError(f"data file {p} has no 1-D datasets at its root (one per column)")
    return out


def column_kind(dtype: np.dtype) -> str:
    """What a column of ``dtype`` that is neither real numbers nor text holds, and the fix."""
    if dtype.kind == "c":
        return (f"holds complex numbers ({dtype}); inertest reads real numbers only (a complex "
                "value's imaginary part would be lost): store the real and imaginary parts, or "
                "the magnitude, as columns of their own")
    return (f"holds {dtype} values, not one real number or text per row; store each "
            "element as a column of real numbers")


def _link_target(link: object) -> str:
    file = getattr(link, "filename", None)
    path = getattr(link, "path", "?")
    return f"{path} in {file}" if file else str(path)


def write_hdf5_table(
    path: str | os.PathLike[str],
    columns: Mapping[str, NDArray],
    units: Mapping[str, str] | None = None,
) -> Path:
    """Write columns as root-level datasets (with a ``unit`` attribute when given), atomically."""
    h5py = _h5py()

    p = Path(path)
    with target_file(p) as tmp:
        with h5py.File(tmp, "w") as fh:
            for name, col in columns.items():
                a = np.asarray(col)
                if a.dtype.kind in "USO":
                    ds = fh.create_dataset(name, data=a.astype(str).astype(object),
                                           dtype=h5py.string_dtype("utf-8"))
                else:
                    ds = fh.create_dataset(name, data=a)
                if units and name in units:
                    ds.attrs["unit"] = units[name]
    return p
