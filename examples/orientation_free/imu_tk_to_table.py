"""Convert imu_tk's text recordings (two files: t[s], x, y, z per line) to one inertest table.

    python imu_tk_to_table.py xsens_acc.txt xsens_gyro.txt -o xsens.parquet

Columns written: ``t_s`` [s], ``acc_x..acc_z``, ``gyr_x..gyr_z`` (raw counts, as recorded).
The two files must share their time stamps (imu_tk's test data do).
"""

from __future__ import annotations

import argparse

import numpy as np

from inertest.errors import DataError
from inertest.io.data_file import write_table


def read_imu_tk(acc_path: str, gyr_path: str) -> dict[str, np.ndarray]:
    """Columns ``t_s``, ``acc_*``, ``gyr_*`` from imu_tk's accelerometer and gyro text files."""
    acc = np.loadtxt(acc_path, ndmin=2)
    gyr = np.loadtxt(gyr_path, ndmin=2)
    if acc.shape[1] != 4 or gyr.shape[1] != 4:
        raise DataError("imu_tk files must have four columns: t [s], x, y, z")
    if acc.shape != gyr.shape or np.any(np.abs(acc[:, 0] - gyr[:, 0]) > 1e-9):
        raise DataError("the accelerometer and gyro files must share their time stamps")
    out = {"t_s": acc[:, 0]}
    for k, a in enumerate("xyz"):
        out[f"acc_{a}"] = acc[:, k + 1]
    for k, a in enumerate("xyz"):
        out[f"gyr_{a}"] = gyr[:, k + 1]
    return out


def main(argv: list[str] | None = None) -> int:
    """Command line: the two text files in, one CSV/Parquet table out."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("acc")
    ap.add_argument("gyro")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args(argv)
    cols = read_imu_tk(a.acc, a.gyro)
    if a.output.endswith(".parquet"):  # whole counts as integers, zstd: 0.6 MB for imu_tk's
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table({k: v if k == "t_s" or np.any(v != np.round(v)) else
                          v.astype(np.int32) for k, v in cols.items()})
        pq.write_table(table, a.output, compression="zstd", compression_level=19)
    else:
        write_table(a.output, cols)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
