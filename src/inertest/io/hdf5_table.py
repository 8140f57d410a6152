"""Tabular data in HDF5: one 1-D dataset per column at the file's root, via h5py.

Text columns are stored as UTF-8 strings; a dataset attribute ``unit`` carries the column's
unit when known. Reached through :func:`inertest.io.data_file.read_table` and ``write_table``
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


def is_hdf5(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names an HDF5 file (by suffix)."""
    return Path(path).suffix.lower() in HDF5_SUFFIXES


def read_hdf5_table(path: str | os.PathLike[str]) -> dict[str, NDArray]:
    """Read the root-level 1-D datasets of an HDF5 file into ``{column: ndarray}``."""
    import h5py

    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    out: dict[str, NDArray] = {}
    try:
        with h5py.File(p, "r") as fh:
            for name, ds in fh.items():
                if not isinstance(ds, h5py.Dataset) or ds.ndim != 1:
                    continue
                if ds.dtype.kind in "SO":
                    out[name] = np.asarray(ds.asstr()[()], dtype=str)
                else:
                    out[name] = np.asarray(ds[()], dtype=float)
    except OSError as exc:
        raise DataError(f"data file {p} cannot be read as HDF5: {exc}") from None
    if not out:
        raise DataError(f"data file {p} has no 1-D datasets at its root (one per column)")
    return out


def write_hdf5_table(
    path: str | os.PathLike[str],
    columns: Mapping[str, NDArray],
    units: Mapping[str, str] | None = None,
) -> Path:
    """Write columns as root-level datasets (with a ``unit`` attribute when given), atomically."""
    import h5py

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
