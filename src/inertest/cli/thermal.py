"""``inertest thermal``: temperature compensation of a gyro's scale factor or bias (seed 003)."""

from __future__ import annotations

import contextlib
from pathlib import Path

import click
import numpy as np

from inertest.cli._common import (
    DATA_PATH,
    REAL,
    check_paths,
    echo_json,
    figure_format,
    input_identity,
    print_table,
    recording_options,
    save_figure,
)
from inertest.io.atomic import target_directory, target_file
from inertest.io.data_file import write_table
from inertest.io.recordings import read_data
from inertest.plan import Plan
from inertest.report.rounding import format_with_std

_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)
#: thermal_compensation.QUANTITIES, named here so that --help need not import the procedure
#: (issue 18: every --help within 2x of `import numpy`); tests/cli check they agree.
QUANTITY_NAMES = ("scale_factor", "bias")


@click.group()
def thermal() -> None:
    """Scale factor and bias against temperature: polynomial and BP-network compensation."""


@thermal.command()
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Data file to write (.csv, .parquet, .h5).")
@click.option("--cycles", type=int, default=4, show_default=True, help="Temperature cycles.")
@click.option("--t-min-c", type=REAL, default=-40.0, show_default=True)
@click.option("--t-max-c", type=REAL, default=60.0, show_default=True)
@click.option("--ramp-c-per-min", type=REAL, default=1.0, show_default=True)
@click.option("--lag-s", type=REAL, default=600.0, show_default=True,
              help="Time constant of the coil behind the temperature sensor [s].")
@click.option("--noise-ppm", type=REAL, default=3.0, show_default=True)
@click.option("--noise-deg-h", type=REAL, default=0.01, show_default=True)
@click.option("--seed", type=int, default=None, help="Random seed for the noise.")
def simulate(output: Path, cycles: int, t_min_c: float, t_max_c: float, ramp_c_per_min: float,
             lag_s: float, noise_ppm: float, noise_deg_h: float, seed: int | None) -> None:
    """Simulate temperature cycles of a FOG whose coil lags its temperature sensor."""
    check_paths([output], [])
    from inertest.procedures.thermal_compensation import simulate_thermal

    data = simulate_thermal(cycles=cycles, t_min_c=t_min_c, t_max_c=t_max_c,
                            ramp_c_per_min=ramp_c_per_min, lag_s=lag_s, noise_ppm=noise_ppm,
                            noise_deg_h=noise_deg_h, rng=seed)
    write_table(output, data, {"time_s": "s", "temperature_c": "degC", "bias_deg_h": "deg/h",
                                   "coil_temperature_c": "degC"})
    click.echo(f"wrote {len(data['cycle'])} rows ({cycles} cycles) to {output}")


@thermal.command()
@click.argument("data", type=DATA_PATH)
@recording_options
@click.option("--quantity", type=click.Choice(QUANTITY_NAMES), default="scale_factor",
              show_default=True, help="scale_factor (column scale_factor) or bias (bias_deg_h).")
@click.option("--validation-cycles", type=int, default=1, show_default=True,
              help="Last cycles held out for validation.")
@click.option("--max-degree", type=click.IntRange(1, 12), default=5, show_default=True,
              help="Highest polynomial degree tried (cross-validated; 12 at most: higher "
                   "degrees in temperature are ill-conditioned).")
@click.option("--no-rate", is_flag=True, help="Temperature only (no temperature-rate input).")
@click.option("--hidden", type=click.IntRange(1, 10_000), default=10, show_default=True,
              help="Neurons of the network's hidden layer.")
@click.option("--max-iter", type=int, default=3000, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the figure (.png, .svg or .pdf).")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Write a self-contained HTML report into this folder.")
@click.option("--model-out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the model (JSON: coefficients and covariance, or network weights) "
              "for inertest apply.")
@click.option("--model", "model_name", type=click.Choice(["polynomial", "neural-network"]),
              default="polynomial", show_default=True, help="Model written by --model-out.")
@click.option("--t-ref-c", type=REAL, default=None,
              help="Reference temperature of the polynomial [degC] (default: training mean).")
@click.option("--serial", default="", help="Instrument serial (written into the model; needed "
              "by --store).")
@click.option("--store", is_flag=True, help="Store the run and its models in the history "
              "database.")
@click.option("--db", default=None, help="History database URL or SQLite path (default: "
              "$INERTEST_DB or ~/.local/share/inertest/history.db).")
def fit(data: Path, topic: str | None, layout: Path | None, quantity: str,
        validation_cycles: int, max_degree: int, no_rate: bool,
        hidden: int, max_iter: int, as_json: bool, plot: Path | None,
        report_dir: Path | None, model_out: Path | None, model_name: str,
        t_ref_c: float | None, serial: str, store: bool, db: str | None) -> None:
    """Fit the compensation models to the temperature cycles in DATA.

    With --model-out, the chosen model is written as plain JSON for inertest apply; with
    --store, the run (both models in its result) goes to the history database. Outputs and
    the stored run are one transaction: when any step fails, nothing is kept.
    """
    from inertest.report.certificate import RESULTS_STATEMENT
    from inertest.report.html import page  # plotting loads only when the command runs
    from inertest.report.thermal import summary_rows, thermal_figure, thermal_sections

    figure_format(plot)
    check_paths([plot, report_dir, model_out], [data])
    if store and not serial:
        raise click.UsageError("--store needs --serial (the instrument's serial number)")
    from inertest.procedures.thermal_compensation import fit_thermal

    result = fit_thermal(read_data(data, topic=topic, layout=layout), quantity=quantity,
                         validation_cycles=validation_cycles, max_degree=max_degree,
                         use_rate=not no_rate, hidden=hidden, max_iter=max_iter,
                         t_ref_c=t_ref_c, serial=serial)
    from inertest.app.run import data_summary, file_run
    from inertest.io.data_file import file_sha256
    from inertest.plan import Instrument

    def outputs() -> None:  # the figure and the model, inside the run's transaction
        # both or neither: a model that cannot be written withdraws the figure (the figure
        # was left behind; an independent review found it)
        with contextlib.ExitStack() as stack:
            if plot is not None:  # drawn beside, moved into place once the model is written
                drawn = stack.enter_context(target_file(plot))
                save_figure(thermal_figure(result), drawn, fmt=figure_format(plot))
            if model_out is not None:
                from inertest.io.thermal_model import write_thermal_model

                write_thermal_model(model_out, result.model(model_name))

    digest = file_sha256(data)
    outcome = file_run(
        result, None, instrument=Instrument(kind="rate-gyro", serial=serial),
        plan_text="# inertest thermal fit\n" + (
            f"quantity = {quantity!r}\nvalidation_cycles = {validation_cycles}\n"
            f"max_degree = {max_degree}\nuse_rate = {str(not no_rate).lower()}\n"
            f"hidden = {hidden}\nmax_iter = {max_iter}\n"),
        data_sha256=digest, data_summary=data_summary(data, {}, digest),
        store=(db or True) if store else False,
        report_dir=report_dir, inputs=[data], allow_duplicate=True, outputs=outputs,
        report_html=lambda history, report_id, test: page(
            f"Temperature compensation: {quantity}",
            thermal_sections(result, title=f"{quantity} compensation"),
            subtitle=f"data: {data}", report_id=report_id,
            identity=input_identity([data], serial=serial, test=test),
            statement=RESULTS_STATEMENT))
    stored = outcome.stored_run
    if as_json:
        echo_json(outcome.to_dict())
        return
    header, rows = summary_rows(result)
    print_table(f"thermal compensation of the {quantity}", header, rows)
    for m in result.messages:
        click.echo(f"warning: {m}", err=True)
    if plot is not None:
        click.echo(f"figure: {plot}")
    if report_dir is not None:
        click.echo(f"report: {report_dir / 'index.html'}")
    if model_out is not None:
        click.echo(f"model: {model_out} ({model_name}; "
                   f"{result.model(model_name).to_dict().get('equation', 'network arrays')})")
    if stored is not None:
        click.echo(f"stored run {stored} of {serial}")


@thermal.command()
@click.argument("plan", type=_FILE)
@click.argument("data", type=DATA_PATH)
@recording_options
@click.option("--degree", type=int, default=2, show_default=True,
              help="Polynomial degree of each coefficient in (T - T_ref).")
@click.option("--rate", "use_rate", is_flag=True,
              help="Add a term in the temperature rate (column temperature_rate_c_per_min).")
@click.option("--t-ref-c", type=REAL, default=None,
              help="Reference temperature [degC] (default: mean step temperature).")
@click.option("--sigma", type=REAL, default=None,
              help="Known noise per reading [output unit] (default: from each step).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--model-out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the K, M, B laws (JSON with covariance, units, valid range) for "
              "inertest apply.")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Write a self-contained HTML report into this folder.")
def triad(plan: Path, data: Path, topic: str | None, layout: Path | None, degree: int,
          use_rate: bool, t_ref_c: float | None, sigma: float | None, as_json: bool,
          model_out: Path | None, report_dir: Path | None) -> None:
    """Triad K, M, B against temperature from multi-position data at several temperatures.

    PLAN is a triad-multiposition plan; DATA has the columns temperature_c, branch
    (heating/cooling), position, output_x, output_y, output_z (optional step,
    temperature_rate_c_per_min). Hysteresis between heating and cooling is tested per
    coefficient. --model-out writes the laws; inertest apply MODEL DATA --temperature-column
    T corrects a recording with them at each row's temperature.
    """
    from inertest.api import load_plan
    from inertest.procedures.thermal_triad import fit_triad_thermal
    from inertest.quality.lab import test_time

    check_paths([model_out, report_dir], [plan, data])
    p = load_plan(plan)
    result = fit_triad_thermal(p, read_data(data, topic=topic, layout=layout), degree=degree,
                               use_rate=use_rate, sigma=sigma, t_ref_c=t_ref_c)
    model = result.model() if model_out is not None else None
    if report_dir is not None:
        from inertest.report.html import page
        from inertest.report.thermal import triad_thermal_sections

        html = page("Triad calibration against temperature",
                    triad_thermal_sections(result, title="K, M, B against temperature"),
                    subtitle=f"plan: {plan}; data: {data}",
                    identity=input_identity(
                        [plan, data], serial=p.instrument.serial, site=plan_site_text(p),
                        operator=p.test.operator if p.test is not None else None,
                        test=test_time(p.test).to_dict()))
        with target_directory(report_dir, inputs=[plan, data]) as tmp:
            (tmp / "index.html").write_text(html, encoding="utf-8")
    if model is not None and model_out is not None:
        from inertest.io.thermal_model import write_thermal_model

        write_thermal_model(model_out, model)
    if as_json:
        echo_json(result.to_dict())
        return
    t_ref = next(iter(result.laws.values())).t_ref_c
    header = ["coefficient", f"at {t_ref:g} degC", "slope per degC", "heating - cooling",
              "hysteresis"]
    rows = []
    for n, law in result.laws.items():
        s = np.sqrt(np.diag(law.covariance))
        u = law.unit
        h = result.hysteresis.get(n)
        rows.append([n, format_with_std(law.coefficients[0], s[0], u),
                     (format_with_std(law.coefficients[1], s[1], f"{u}/degC") if degree >= 1
                      else "-"),
                     "-" if h is None else f"{format_with_std(h.max_difference, h.std, u)} at "
                     f"{h.at_temperature_c:.0f} degC",
                     "-" if h is None else ("SIGNIFICANT" if h.significant else "no")])
    print_table(f"triad against temperature ({len(result.step_temperature_c)} steps)",
                header, rows)
    for m in result.messages:
        click.echo(f"warning: {m}", err=True)
    if report_dir is not None:
        click.echo(f"report: {report_dir / 'index.html'}")
    if model is not None:
        lo, hi = model.temperature_range_c
        click.echo(f"model: {model_out} (K, M, B laws of degree {degree}; valid {lo:.4g} to "
                   f"{hi:.4g} degC)")


def plan_site_text(p: Plan) -> str:
    """The plan's site as one identity row: latitude and gravity."""
    return (f"latitude {p.site.latitude_deg:.6f} deg, gravity {p.site.gravity_m_s2:.7f} "
            "m/s^2")


@thermal.command(name="triad-simulate")
@click.argument("plan", type=_FILE)
@click.argument("laws", type=_FILE)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Data file to write (.csv, .parquet, .h5).")
@click.option("--t-min-c", type=REAL, default=-40.0, show_default=True)
@click.option("--t-max-c", type=REAL, default=60.0, show_default=True)
@click.option("--step-c", type=REAL, default=10.0, show_default=True,
              help="Temperature step of the chamber [degC].")
@click.option("--branches", type=click.Choice(["both", "heating", "cooling"]), default="both",
              show_default=True)
@click.option("--noise", type=REAL, default=0.0, show_default=True,
              help="White noise per reading [plan output unit].")
@click.option("--seed", type=int, default=None, help="Random seed for the noise.")
def triad_simulate(plan: Path, laws: Path, output: Path, t_min_c: float, t_max_c: float,
                   step_c: float, branches: str, noise: float, seed: int | None) -> None:
    """Chamber steps of a virtual accelerometer triad whose K, M, B follow the laws in LAWS.

    LAWS is TOML: t_ref_c = 20.0 and a [laws] table, name = [a0, a1, ...] for
    a0 + a1 (T - t_ref_c) + ... (K_i [scale unit], M_ij [urad], B_i [mg]). The output has the
    columns of inertest thermal triad.
    """
    from inertest.api import load_plan
    from inertest.io.plan_file import read_toml
    from inertest.models.triad import parameter_names
    from inertest.procedures.thermal_triad import simulate_triad_thermal

    check_paths([output], [plan, laws])
    if step_c <= 0 or t_max_c < t_min_c:
        raise click.BadParameter("need --step-c > 0 and --t-max-c >= --t-min-c",
                                 param_hint="--step-c")
    doc = read_toml(laws, "laws")
    table = doc.get("laws")
    if not isinstance(table, dict) or not isinstance(doc.get("t_ref_c"), int | float):
        raise click.UsageError(f"{laws} needs t_ref_c = <degC> and a [laws] table of "
                               "name = [a0, a1, ...]")
    unknown = sorted(set(table) - set(parameter_names()))
    bad = [k for k, v in table.items()
           if not (isinstance(v, list) and v and all(isinstance(x, int | float) for x in v))]
    if unknown or bad:
        raise click.UsageError(f"{laws}: " + "; ".join(
            ([f"unknown law(s) {', '.join(unknown)} (known: {', '.join(parameter_names())})"]
             if unknown else [])
            + ([f"{', '.join(bad)} must be lists of numbers [a0, a1, ...]"] if bad else [])))
    temps = np.arange(t_min_c, t_max_c + 0.5 * step_c, step_c)
    data = simulate_triad_thermal(
        load_plan(plan), table, t_ref_c=float(doc["t_ref_c"]), temperatures_c=temps,
        branches=("heating", "cooling") if branches == "both" else (branches,), noise=noise,
        rng=seed)
    write_table(output, data, {"temperature_c": "degC"})
    click.echo(f"wrote {len(data['step'])} rows ({int(data['step'].max()) + 1} temperature "
               f"steps) to {output}")
