"""``inertest apply CAL.json DATA -o OUT``: correct a recording with a triad calibration.

CAL.json is the ``fit --json`` output of a triad procedure (its ``"calibration"`` block is used)
or that block alone: ``{"accelerometer": {"matrix", "offset", "unit", ...}, "gyroscope": {...}}``
with ``calibrated = matrix @ (raw - offset)`` (gyroscope: ``raw - g_sensitivity @ a_cal -
offset``). A systematic calibration's block also holds ``"coupling"`` (second-order terms,
the accelerometers' lever arms, the gyro-accelerometer time asynchrony): both triads are then
corrected together, the sample interval taken from ``--time-column`` (or ``t_s``).
DATA and OUT are CSV, Parquet or HDF5 (by suffix). The calibrated columns replace the
raw ones; in CSV and Parquet their names carry the unit (``acc_x [m/s^2]``), in HDF5 the name
stays and the unit is the dataset attribute ``unit``. Other columns are copied unchanged.

CAL.json may instead be a thermal model (``inertest thermal fit --model-out``): then
``--temperature-column`` names the temperature [degC] and the model's quantity column (or
``--columns``) is compensated, ``raw - bias(T, dT/dt)`` or ``raw / scale(T, dT/dt)``, the rate
[degC/min] from ``--time-column`` [s]; a polynomial model adds the column
``<column>_correction_std``, the standard uncertainty of the correction propagated from the
coefficient covariance. Rows outside the model's temperature (or rate) range are refused, or
with ``--extrapolate`` compensated with a warning that gives the distance.

CAL.json may also be a triad thermal model (``inertest thermal triad --model-out``): each row of
the raw columns (``--columns x,y,z``, default ``output_x,output_y,output_z``) is corrected with
K, M, B at its temperature, ``u = (I + M(T))^-1 K(T)^-1 raw - B(T)``, into ``--acc-unit``;
``<column>_correction_std`` is the correction's standard uncertainty from the laws' covariance.
The same range check and ``--extrapolate`` apply.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import click
import numpy as np

from inertest.cli._common import DATA_PATH, check_paths, recording_options
from inertest.errors import DataError
from inertest.io.calibration_file import load_calibration, read_json_object
from inertest.io.data_file import write_table
from inertest.io.hdf5_table import is_hdf5
from inertest.io.recordings import read_data
from inertest.procedures.spec import require_columns
from inertest.units import ACCEL_UNITS, RATE_UNITS, accel_from_si, rate_from_si

_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


def _columns(text: str, option: str) -> tuple[str, str, str]:
    names = tuple(t.strip() for t in text.split(","))
    if len(names) != 3 or not all(names):
        raise click.BadParameter(f"expected three comma-separated column names, got {text!r}",
                                 param_hint=option)
    return (names[0], names[1], names[2])


@click.command(name="apply")
@click.argument("calibration", type=_FILE)
@click.argument("data", type=DATA_PATH)
@recording_options
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
@click.option("--temperature-column", default=None,
              help="Thermal model: column of the temperature [degC].")
@click.option("--time-column", default="time_s", show_default=True,
              help="Thermal model using the rate: column of the time [s].")
@click.option("--columns", "thermal_columns", default=None,
              help="Thermal model: comma-separated columns to compensate (default: bias_deg_h "
              "or scale_factor, by the model's quantity; output_x,output_y,output_z for a "
              "triad thermal model).")
@click.option("--extrapolate", is_flag=True,
              help="Thermal model: compensate rows outside the valid range (with a warning).")
@click.option("--only", type=click.Choice(["accelerometer", "gyroscope"]), default=None,
              help="Triad calibration: correct only this sensor (by default every sensor the "
              "calibration holds, and each needs its three raw columns).")
@click.option("--unit-in-names", is_flag=True,
              help="Name the calibrated columns 'acc_x [m/s^2]' (default: the input's names; "
              "the unit is printed, and stored in Parquet and HDF5).")
def apply(calibration: Path, data: Path, topic: str | None, layout: Path | None, output: Path,
          acc_columns: str, gyr_columns: str, acc_unit: str, gyr_unit: str,
          temperature_column: str | None, time_column: str, thermal_columns: str | None,
          extrapolate: bool, only: str | None, unit_in_names: bool) -> None:
    """Apply the triad calibration or thermal model in CALIBRATION to the raw columns of DATA.

    The other columns are written as they were read: same names, same types (an integer
    column stays integer). The calibrated columns keep their names unless --unit-in-names.
    """
    check_paths([output], [calibration, data])
    # thermal models load their procedures (scipy.stats): only when a command runs
    from inertest.io.thermal_model import is_thermal_model, is_triad_thermal_model

    # which kind of file it is; the loader of that kind checks its numbers
    doc = read_json_object(calibration, "calibration", finite=False)
    if is_thermal_model(doc):
        _apply_thermal(calibration, data, output, temperature_column, time_column,
                       thermal_columns, extrapolate, (topic, layout))
        return
    if is_triad_thermal_model(doc):
        _apply_triad_thermal(calibration, data, output, temperature_column, time_column,
                             thermal_columns, extrapolate, acc_unit, (topic, layout),
                             unit_in_names)
        return
    if temperature_column is not None or thermal_columns is not None:
        raise click.UsageError(f"{calibration} is a triad calibration, not a thermal model: "
                               "--temperature-column and --columns apply to thermal models")
    acc_cols = _columns(acc_columns, "--acc-columns")
    gyr_cols = _columns(gyr_columns, "--gyr-columns")
    cal = load_calibration(calibration)
    table = read_data(data, topic=topic, layout=layout, keep_types=True)
    use_acc = cal.accelerometer is not None and only in (None, "accelerometer")
    use_gyr = cal.gyroscope is not None and only in (None, "gyroscope")
    if only is not None and not (use_acc or use_gyr):
        raise DataError(f"{calibration} holds no {only} calibration; drop --only or use the "
                        "other sensor")
    wanted = [*(acc_cols if use_acc else ()), *(gyr_cols if use_gyr else ())]
    missing = [c for c in wanted if c not in table]
    if missing:
        others = [s for s, u in (("accelerometer", use_acc), ("gyroscope", use_gyr)) if u]
        hint = (f", or correct one sensor only with --only {' / --only '.join(others)}"
                if len(others) == 2 else "")
        raise DataError(
            f"{data} lacks the raw column(s) {', '.join(missing)} (found: {', '.join(table)}); "
            f"name them with --acc-columns x,y,z / --gyr-columns x,y,z{hint}; nothing written"
        )
    out = dict(table)
    units: dict[str, str] = {}
    a_si = None
    done = []

    def put(cols: tuple[str, str, str], values: np.ndarray, unit: str) -> None:
        for k, c in enumerate(cols):
            name = f"{c} [{unit}]" if unit_in_names and not is_hdf5(output) else c
            # keep the column order of the input: replace in place
            pos = list(out).index(c)
            items = list(out.items())
            items[pos] = (name, values[:, k])
            out.clear()
            out.update(items)
            units[name] = unit

    if cal.coupling is not None and use_acc != use_gyr:
        click.echo("warning: the calibration's coupling terms (second order, lever arms, time "
                   "asynchrony) need both sensors; only the triad is corrected", err=True)
    if cal.coupling is not None and use_acc and use_gyr:
        # a systematic calibration: both triads and the terms that couple them, at once
        dt = _sample_interval(table, data, time_column)
        acc_raw = _raw(table, acc_cols, data)
        gyr_raw = _raw(table, gyr_cols, data)
        a_si, w_si = cal.correct(acc_raw, gyr_raw, dt)
        put(acc_cols, accel_from_si(a_si, acc_unit), acc_unit)
        put(gyr_cols, rate_from_si(w_si, gyr_unit), gyr_unit)
        done += [f"accelerometer -> {acc_unit}", f"gyroscope -> {gyr_unit}",
                 "second-order terms, lever arms, time asynchrony"]
        use_acc = use_gyr = False
    if use_acc:
        assert cal.accelerometer is not None
        raw = _raw(table, acc_cols, data)
        a_si = cal.accelerometer.apply(raw)
        put(acc_cols, accel_from_si(a_si, acc_unit), acc_unit)
        done.append(f"accelerometer -> {acc_unit}")
    if use_gyr:
        assert cal.gyroscope is not None
        if cal.gyroscope.g_sensitivity is not None and a_si is None:
            raise DataError("this gyroscope calibration corrects g-sensitivity and needs the "
                            "accelerometer columns and calibration (--acc-columns)")
        raw = _raw(table, gyr_cols, data)
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


def _raw(table: dict, cols: Sequence[str], data: Path) -> np.ndarray:
    """The raw columns as one float array; a column of text is refused with its name."""
    for c in cols:
        if np.asarray(table[c]).dtype.kind not in "iuf":
            raise DataError(f"column {c!r} of {data} is not numeric (it holds text); give the "
                            "raw sensor columns")
    return np.column_stack([np.asarray(table[c], dtype=float) for c in cols])


def _sample_interval(table: dict, data: Path, time_column: str) -> float:
    """The recording's sample interval [s] from its time column (``--time-column``, or t_s)."""
    name = next((c for c in (time_column, "t_s") if c in table), None)
    if name is None:
        raise DataError(f"{data} has no time column ({time_column} or t_s): this calibration "
                        "corrects lever arms and time asynchrony, which need the sample "
                        "interval; name the time column [s] with --time-column")
    t = np.asarray(table[name], dtype=float)
    dt = np.diff(t)
    if t.size < 2 or not np.all(np.isfinite(dt)) or not np.all(dt > 0):
        raise DataError(f"{data}: the time column {name} must increase from row to row [s]; "
                        "repair it (nothing written)")
    return float(np.median(dt))


def _apply_thermal(model_path: Path, data: Path, output: Path, temperature_column: str | None,
                   time_column: str, columns: str | None, extrapolate: bool,
                   recording: tuple[str | None, Path | None]) -> None:
    """Compensate the thermal model's quantity in DATA; write OUTPUT with the uncertainty."""
    from inertest.io.thermal_model import load_thermal_model
    from inertest.procedures.thermal_compensation import QUANTITIES

    model = load_thermal_model(model_path)
    cols = ([c.strip() for c in columns.split(",") if c.strip()] if columns is not None
            else [QUANTITIES[model.quantity][0]])
    table, arr, temp, rate = _thermal_inputs(model, model_path, "thermal model", data,
                                             temperature_column, time_column, cols, "--columns",
                                             extrapolate, recording)
    out = dict(table)
    units: dict[str, str] = {}
    unit = "deg/h" if model.quantity == "bias" else ""
    for c in cols:
        with np.errstate(over="ignore", invalid="ignore"):  # refused below, naming the model
            corrected, std = model.compensate(arr[c], temp, rate)
        out[c] = corrected
        if unit:
            units[c] = unit
        if std is not None:
            out[f"{c}_correction_std"] = std
            if unit:
                units[f"{c}_correction_std"] = unit
    _check_finite_output(model_path, out, cols)
    write_table(output, out, units)
    what = "bias removed" if model.quantity == "bias" else "divided by the scale factor"
    click.echo(f"wrote {temp.size} compensated rows ({', '.join(cols)}: {what}, "
               f"{model.model_type} model) to {output}")


def _check_finite_output(model_path: Path, out: dict[str, np.ndarray],
                         columns: list[str]) -> None:
    """Refuse to write a corrected column that is not finite (its inputs were checked)."""
    for c in columns:
        bad = ~np.isfinite(out[c])
        if np.any(bad):
            raise DataError(
                f"the thermal model {model_path} gives a non-finite {c} at data row "
                f"{int(np.flatnonzero(bad)[0]) + 1} (finite inputs): its numbers overflow; "
                "write the model again with inertest thermal fit --model-out; nothing written")


def _thermal_inputs(
    model, model_path: Path, what: str, data: Path, temperature_column: str | None,
    time_column: str, cols: list[str] | tuple[str, ...], columns_option: str, extrapolate: bool,
    recording: tuple[str | None, Path | None] = (None, None),
) -> tuple[dict, dict[str, np.ndarray], np.ndarray, np.ndarray | None]:
    """DATA's table, the columns the thermal model needs, the temperature and the rate.

    The columns (to correct, temperature [degC], time [s]) as finite floats, the rate
    [degC/min] only if the model uses it; errors name the option that fixes them.
    """
    if temperature_column is None:
        raise click.UsageError(f"{model_path} is a {what}: name the temperature column with "
                               "--temperature-column")
    table = read_data(data, topic=recording[0], layout=recording[1], keep_types=True)
    need = [temperature_column, *cols, *([time_column] if model.uses_rate else [])]
    missing = [c for c in need if c not in table]
    if missing:
        hint = (f"--temperature-column, {columns_option}"
                + (", --time-column" if model.uses_rate else ""))
        raise DataError(f"{data} lacks column(s) {', '.join(missing)} (found: "
                        f"{', '.join(table)}); name them with {hint}")
    try:
        arr = require_columns(table, need, (), procedure="its")
    except DataError as exc:
        raise DataError(f"{data}: {exc}") from None
    temp = arr[temperature_column]
    return table, arr, temp, _rate_and_range_check(model, data, temp, arr.get(time_column),
                                                    extrapolate)


def _rate_and_range_check(model, data: Path, temp: np.ndarray, time_s: np.ndarray | None,
                          extrapolate: bool) -> np.ndarray | None:
    """The temperature rate [degC/min] if the model uses it; rows out of range refused.

    With ``extrapolate`` they are warned about (with the distance) instead.
    """
    from inertest.procedures.thermal_compensation import temperature_rate

    rate = None
    if model.uses_rate:
        if time_s is None:
            raise DataError(f"{data}: the model uses the temperature rate: give the time column")
        rate = temperature_rate(np.zeros(temp.size, dtype=int), time_s, temp)
    dt, dr = model.out_of_range(temp, rate)
    outside = [f"{int(np.count_nonzero(dt))} row(s) up to {np.max(dt):.3g} degC outside the "
               f"temperature range {model.temperature_range_c[0]:.4g} to "
               f"{model.temperature_range_c[1]:.4g} degC"] if np.any(dt > 0) else []
    if dr is not None and np.any(dr > 0):
        lo, hi = model.rate_range_c_per_min
        outside.append(f"{int(np.count_nonzero(dr))} row(s) up to {np.max(dr):.3g} degC/min "
                       f"outside the rate range {lo:.3g} to {hi:.3g} degC/min")
    unseen = (model.outside_support(temp, rate) if hasattr(model, "outside_support")
              else np.zeros(temp.size, dtype=bool))
    unseen &= dt == 0
    if dr is not None:
        unseen &= dr == 0
    if np.any(unseen):
        k = int(np.flatnonzero(unseen)[0])
        assert rate is not None  # a model with a support is a model with a rate
        tol_t, tol_r = model.support_tolerance
        outside.append(f"{int(np.count_nonzero(unseen))} row(s) inside the ranges but at "
                       f"temperature x rate combinations not seen in training (first: "
                       f"{temp[k]:.4g} degC at {rate[k]:.3g} degC/min; more than {tol_t:.3g} degC "
                       f"/ {tol_r:.3g} degC/min from every training point)")
    if outside and not extrapolate:
        raise DataError(f"{data}: {'; '.join(outside)} of the model; nothing written. Use data "
                        "inside the range, refit over a wider range, or --extrapolate")
    for line in outside:
        click.echo(f"warning: extrapolating the thermal model: {line}", err=True)
    return rate


def _apply_triad_thermal(model_path: Path, data: Path, output: Path,
                         temperature_column: str | None, time_column: str,
                         columns: str | None, extrapolate: bool, acc_unit: str,
                         recording: tuple[str | None, Path | None],
                         unit_in_names: bool = False) -> None:
    """Correct the raw triad columns of DATA with K, M, B at each row's temperature."""
    from inertest.io.thermal_model import load_triad_thermal_model

    model = load_triad_thermal_model(model_path)
    cols = _columns(columns or "output_x,output_y,output_z", "--columns")
    table, arr, temp, rate = _thermal_inputs(model, model_path, "triad thermal model", data,
                                             temperature_column, time_column, cols,
                                             "--columns x,y,z", extrapolate, recording)
    with np.errstate(over="ignore", invalid="ignore"):  # refused below, naming the model
        u, std = model.compensate(np.column_stack([arr[c] for c in cols]), temp, rate)
    hdf5 = is_hdf5(output)
    out: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    for name, values in table.items():
        if name not in cols:
            out[name] = values
            continue
        k = cols.index(name)
        for col, v in ((name, u[:, k]), (f"{name}_correction_std", std[:, k])):
            key = f"{col} [{acc_unit}]" if unit_in_names and not hdf5 else col
            out[key] = accel_from_si(v, acc_unit)
            units[key] = acc_unit
    _check_finite_output(model_path, out, list(units))
    write_table(output, out, units)
    click.echo(f"wrote {temp.size} corrected rows ({', '.join(cols)} -> {acc_unit}, K, M, B at "
               f"each row's temperature) to {output}")
