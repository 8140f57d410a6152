"""``inertest apply CAL.json DATA -o OUT``: correct a recording with a triad calibration.

CAL.json is the ``fit --json`` output of a triad procedure (its ``"calibration"`` block is used)
or that block alone: ``{"accelerometer": {"matrix", "offset", "unit", ...}, "gyroscope": {...}}``
with ``calibrated = matrix @ (raw - offset)`` (gyroscope: ``raw - g_sensitivity @ a_cal -
offset``). DATA and OUT are CSV, Parquet or HDF5 (by suffix). The calibrated columns replace the
raw ones; in CSV and Parquet their names carry the unit (``acc_x [m/s^2]``), in HDF5 the name
stays and the unit is the dataset attribute ``unit``. Other columns are copied unchanged.
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from inertest.cli._common import check_paths
from inertest.errors import DataError
from inertest.io.calibration_file import load_calibration
from inertest.io.data_file import read_table, write_table
from inertest.io.hdf5_table import is_hdf5
from inertest.units import ACCEL_UNITS, RATE_UNITS, accel_from_si, rate_from_si

_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


def _columns(text: str, option: str) -> tuple[str, str, str]:
    names = tuple(t.strip() for t in text.split(","))
    if len(names) != 3 or not all(names):
        raise click.BadParameter(f"expected three comma-separated column names, got {text!r}",
                                 param_hint=option)
    return names  # type: ignore[return-value]


@click.command(name="apply")
@click.argument("calibration", type=_FILE)
@click.argument("data", type=_FILE)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Calibrated data file to write (.csv, .parquet, .h5).")
@click.option("--acc-columns", default="acc_x,acc_y,acc_z", show_default=True,
              help="Raw accelerometer columns x,y,z.")
@click.option("--gyr-columns", default="gyr_x,gyr_y,gyr_z", show_default=True,
              help="Raw gyro columns x,y,z.")
@click.option("--acc-unit", type=click.Choice(list(ACCEL_UNITS)), default="m/s^2",
              show_default=True, help="Unit of the calibrated specific force.")
@click.option("--gyr-unit", type=click.Choice(list(RATE_UNITS)), default="rad/s",
              show_default=True, help="Unit of the calibrated rate.")
def apply(calibration: Path, data: Path, output: Path, acc_columns: str, gyr_columns: str,
          acc_unit: str, gyr_unit: str) -> None:
    """Apply the triad calibration in CALIBRATION to the raw columns of DATA."""
    check_paths([output], [calibration, data])
    acc_cols = _columns(acc_columns, "--acc-columns")
    gyr_cols = _columns(gyr_columns, "--gyr-columns")
    cal = load_calibration(calibration)
    table = read_table(data)
    use_acc = cal.accelerometer is not None and all(c in table for c in acc_cols)
    use_gyr = cal.gyroscope is not None and all(c in table for c in gyr_cols)
    if not (use_acc or use_gyr):
        wanted = [*(acc_cols if cal.accelerometer else ()), *(gyr_cols if cal.gyroscope else ())]
        missing = [c for c in wanted if c not in table]
        raise DataError(
            f"{data} lacks the raw column(s) {', '.join(missing)} (found: {', '.join(table)}); "
            "name them with --acc-columns x,y,z / --gyr-columns x,y,z"
        )
    out = dict(table)
    units: dict[str, str] = {}
    a_si = None
    done = []

    def put(cols: tuple[str, str, str], values: np.ndarray, unit: str) -> None:
        for k, c in enumerate(cols):
            name = c if is_hdf5(output) else f"{c} [{unit}]"
            # keep the column order of the input: replace in place
            pos = list(out).index(c)
            items = list(out.items())
            items[pos] = (name, values[:, k])
            out.clear()
            out.update(items)
            units[name] = unit

    if use_acc:
        raw = np.column_stack([np.asarray(table[c], dtype=float) for c in acc_cols])
        a_si = cal.accelerometer.apply(raw)
        put(acc_cols, accel_from_si(a_si, acc_unit), acc_unit)
        done.append(f"accelerometer -> {acc_unit}")
    if use_gyr:
        if cal.gyroscope.g_sensitivity is not None and a_si is None:
            raise DataError("this gyroscope calibration corrects g-sensitivity and needs the "
                            "accelerometer columns and calibration (--acc-columns)")
        raw = np.column_stack([np.asarray(table[c], dtype=float) for c in gyr_cols])
        w_si = cal.gyroscope.apply(raw, a_si)
        put(gyr_cols, rate_from_si(w_si, gyr_unit), gyr_unit)
        done.append(f"gyroscope -> {gyr_unit}")
    for name, unit in units.items():
        if not np.all(np.isfinite(out[name])):
            raise DataError(f"{data} has NaN/inf in the raw columns behind {name} ({unit}); "
                            "repair or remove those rows")
    write_table(output, out, units)
    n = len(next(iter(out.values())))
    click.echo(f"wrote {n} calibrated rows ({', '.join(done)}) to {output}")
