"""PSINS binary IMU files (``binfile32``/``binfile``): increments as columns.

PSINS (Yan Gongmin's toolbox, BSD-2) stores an IMU record ``[wm, vm, t]`` as raw little-endian
floats, row after row: ``dtheta_x, dtheta_y, dtheta_z`` [rad] and ``dv_x, dv_y, dv_z`` [m/s]
per sample, and the time ``t`` [s] at the end of each sample; ``binfile32`` writes float32
(``.bin``, e.g. the systematic-calibration demo input ``imusysclbt.bin``), ``binfile`` float64.
The element size is taken from the file: the time column must increase by a constant step in
exactly one of the two readings (a float64 file read as float32 is nonsense, and vice versa).

Columns returned: ``dtheta_x..z``, ``dv_x..z``, ``t_s``, as the systematic calibration reads
them (:mod:`inertest.procedures.systematic`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError

#: Suffixes read as PSINS binary IMU files.
PSINS_BINARY_SUFFIXES = (".bin",)
COLUMNS = ("dtheta_x", "dtheta_y", "dtheta_z", "dv_x", "dv_y", "dv_z", "t_s")


def _regular_time(t: NDArray[np.float64]) -> bool:
    if t.size < 2 or not np.all(np.isfinite(t)):
        return False
    dt = np.diff(t)
    step = float(np.median(dt))
    return step > 0 and bool(np.all(np.abs(dt - step) <= 1e-3 * step + 1e-6 * np.abs(t[1:])))


def read_psins_binary(path: str | os.PathLike[str]) -> dict[str, NDArray]:
    """The increments and times of a PSINS binary IMU file (module docstring).

    Raises
    ------
    DataError
        The size is not a whole number of 7-value rows, or neither float32 nor float64 gives
        a regular time column (naming what to do).
    """
    p = Path(path)
    raw = p.read_bytes()
    found = []
    for dtype in ("<f4", "<f8"):
        size = np.dtype(dtype).itemsize * len(COLUMNS)
        if len(raw) == 0 or len(raw) % size:
            continue
        d = np.frombuffer(raw, dtype=dtype).reshape(-1, len(COLUMNS)).astype(float)
        if _regular_time(d[:, 6]):
            found.append(d)
    if len(found) != 1:
        raise DataError(
            f"{p}: not a PSINS binary IMU file (rows of 7 little-endian floats: dtheta_x,y,z "
            "[rad], dv_x,y,z [m/s], t [s] with a regular time step, as binfile32 writes); "
            "convert it to CSV with those columns")
    d = found[0]
    return {name: np.ascontiguousarray(d[:, k]) for k, name in enumerate(COLUMNS)}
