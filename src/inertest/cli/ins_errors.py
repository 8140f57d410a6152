"""``inertest ins-errors``: static-base error propagation of a local-level INS (seed 002)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import numpy as np

from inertest.cli._common import (
    REAL,
    check_paths,
    echo_json,
    figure_format,
    input_identity,
    parse_float_list,
    print_table,
    save_figure,
)
from inertest.report.rounding import format_number
from inertest.units import (
    DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S,
    DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S,
    M_PER_S_PER_SQRT_H_TO_M_PER_S_PER_SQRT_S,
)

if TYPE_CHECKING:
    from inertest.ins.propagation import SourceResponses
    from inertest.ins.scenario import InsScenario

#: CLI list options -> (TOML quantity, unit suffix, count).
_LIST_OPTIONS = {
    "accel_bias_ug": ("accel_bias", "ug", 2),
    "gyro_drift_deg_h": ("gyro_drift", "deg_h", 3),
    "initial_velocity_m_s": ("initial_velocity", "m_s", 2),
    "initial_position_arcsec": ("initial_position", "arcsec", 2),
    "initial_attitude_arcsec": ("initial_attitude", "arcsec", 3),
}


@click.command("ins-errors")
@click.option("--scenario", "scenario_file", type=click.Path(dir_okay=False, path_type=Path),
              help="TOML scenario ([site], [run], [errors]); options below override it.")
@click.option("--example", is_flag=True,
              help="Start from the worked example of the INS error-propagation report (39 deg, "
              "24 h, all sources).")
@click.option("--latitude", type=REAL, help="Latitude L [deg], strictly between -90 and 90.")
@click.option("--hours", type=REAL, help="Duration [h] (default 24).")
@click.option("--step", type=REAL, help="Output step [s] (default 60); the solution is exact.")
@click.option("--accel-bias-ug", help="Accelerometer biases E,N [ug] (g = 9.80665 m/s^2), "
              "output errors: f_out = f_true + bias.")
@click.option("--gyro-drift-deg-h", help="Gyro drifts E,N,U [deg/h], output errors: "
              "w_out = w_true + drift (a platform drift is minus this).")
@click.option("--initial-velocity-m-s", help="Initial velocity errors E,N [m/s], computed - true.")
@click.option("--initial-position-arcsec", help="Initial latitude, longitude errors [arcsec], "
              "computed - true.")
@click.option("--initial-attitude-arcsec", help="Initial attitude errors phi E,N,U [arcsec]: the "
              "computed frame is the true ENU frame turned by phi.")
@click.option("--radius", type=REAL, help="Earth radius R [m] (default 6378137).")
@click.option("--gravity", type=REAL, help="Gravity g [m/s^2] (default: normal gravity at L).")
@click.option("--coriolis/--no-coriolis", default=None,
              help="Keep the 2 W sinL Coriolis terms (default) or use the source's simplified "
                   "model without Foucault modulation.")
@click.option("--gyro-arw-deg-sqrt-h", type=REAL, default=0.0,
              help="Gyro angle random walk [deg/sqrt(h)] -> 1-sigma band.")
@click.option("--accel-vrw-m-s-sqrt-h", type=REAL, default=0.0,
              help="Accelerometer velocity random walk [m/s/sqrt(h)] -> 1-sigma band.")
@click.option("--gyro-rrw-deg-h-sqrt-h", type=REAL, default=0.0,
              help="Gyro rate random walk [deg/h/sqrt(h)] -> 1-sigma band.")
@click.option("--closed-forms/--no-closed-forms", default=True, show_default=True,
              help="Print the constant/secular parts (sympy) in the table output.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object in SI.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the 7-panel figure (png, pdf, svg by suffix).")
@click.option("--report", type=click.Path(dir_okay=False, path_type=Path),
              help="Write a self-contained HTML report.")
def ins_errors(scenario_file: Path | None, example: bool, latitude: float | None,
               hours: float | None, step: float | None, accel_bias_ug: str | None,
               gyro_drift_deg_h: str | None, initial_velocity_m_s: str | None,
               initial_position_arcsec: str | None, initial_attitude_arcsec: str | None,
               radius: float | None, gravity: float | None, coriolis: bool | None,
               gyro_arw_deg_sqrt_h: float, accel_vrw_m_s_sqrt_h: float,
               gyro_rrw_deg_h_sqrt_h: float, closed_forms: bool, as_json: bool,
               plot: Path | None, report: Path | None) -> None:
    """Error propagation of a north-pointing local-level INS on a static base.

    Source: Error propagation of an inertial navigation system.

    Exact solution of the linear error equations for constant accelerometer biases, gyro
    drifts and initial errors, each source separately and combined; Schuler, Foucault and
    Earth periods; constant and secular parts by the final value theorem. Signs: errors are
    computed - true; drift and bias are sensor output errors (output = true + error) in ENU;
    phi turns the true ENU frame into the computed one (a drift enters phi' with a minus
    sign).
    """
    figure_format(plot)
    check_paths([plot, report], [scenario_file])
    doc = _base_document(scenario_file, example)
    _apply_list_options(doc, {
        "accel_bias_ug": accel_bias_ug, "gyro_drift_deg_h": gyro_drift_deg_h,
        "initial_velocity_m_s": initial_velocity_m_s,
        "initial_position_arcsec": initial_position_arcsec,
        "initial_attitude_arcsec": initial_attitude_arcsec})
    _apply_options(doc, "site", (("latitude_deg", latitude), ("radius_m", radius),
                                 ("gravity_m_s2", gravity), ("coriolis", coriolis)))
    _apply_options(doc, "run", (("hours", hours), ("step_s", step)))
    if "latitude_deg" not in doc["site"]:
        raise click.UsageError("give --latitude DEG (or --scenario FILE, or --example)")
    # The INS numerics, scipy and the report (matplotlib) load only when the command runs.
    from inertest.ins.analysis import analyse
    from inertest.ins.covariance import RandomSources
    from inertest.ins.error_model import SIGN_CONVENTION, STATES
    from inertest.ins.scenario import scenario_from_mapping
    from inertest.io.atomic import write_text
    from inertest.report.html import page
    from inertest.report.ins_errors import (
        DISPLAY_UNITS,
        final_rows,
        ins_error_sections,
        periods_rows,
        responses_figure,
    )

    scenario = scenario_from_mapping(doc, source=str(scenario_file or "command line"))
    for opt, value in (("--gyro-arw-deg-sqrt-h", gyro_arw_deg_sqrt_h),
                       ("--accel-vrw-m-s-sqrt-h", accel_vrw_m_s_sqrt_h),
                       ("--gyro-rrw-deg-h-sqrt-h", gyro_rrw_deg_h_sqrt_h)):
        if not (math.isfinite(value) and value >= 0):
            raise click.BadParameter(f"must be a non-negative noise density, got {value}",
                                     param_hint=opt)
    randoms = RandomSources(
        gyro_arw=gyro_arw_deg_sqrt_h * DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S,
        accel_vrw=accel_vrw_m_s_sqrt_h * M_PER_S_PER_SQRT_H_TO_M_PER_S_PER_SQRT_S,
        gyro_rrw=gyro_rrw_deg_h_sqrt_h * DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S,
    )
    result = analyse(scenario, randoms)
    if result.linear_model.message:
        click.echo(f"warning: {result.linear_model.message}", err=True)
    resp, periods, sigma = result.responses, result.periods, result.sigma
    table = None
    if (closed_forms or report) and not as_json and scenario.site.earth_rate_rad_s > 0:
        table = _closed_form_table(scenario, resp)
    if plot is not None:
        fig = responses_figure(resp, sigma=sigma, title=scenario.name)
        save_figure(fig, plot)
    if report is not None:
        html = page("INS error propagation", ins_error_sections(
            resp, periods, closed_form_table=table, sigma=sigma), subtitle=scenario.name,
            identity=input_identity([scenario_file], source=(
                f"built-in example: {scenario.name}" if example else None if scenario_file
                else "scenario from the command's options")))
        write_text(report, html)
    if as_json:
        echo_json(result.to_dict())
        return
    click.echo(f"sign convention: {SIGN_CONVENTION}")
    print_table("characteristic periods (eigenvalues of A)", ["period", "value", "closed form"],
                periods_rows(periods))
    print_table(f"errors at t = {resp.t[-1] / 3600:g} h",
                ["source", *(f"{st} [{DISPLAY_UNITS[st][0]}]" for st in STATES)],
                final_rows(resp))
    if sigma is not None:
        print_table(f"1-sigma from the random sources at t = {resp.t[-1] / 3600:g} h",
                    [f"{st} [{DISPLAY_UNITS[st][0]}]" for st in STATES],
                    [[format_number(float(sigma[-1, i] * DISPLAY_UNITS[st][1]), digits=2)
                      for i, st in enumerate(STATES)]])
    if table is not None and closed_forms:
        print_table("constant + secular parts (final value theorem; fitted = from the solution)",
                    ["state", "source", "constant", "secular [1/s]", "value", "fitted"], table)
    for path in (plot, report):
        if path is not None:
            click.echo(f"written: {path}")


def _base_document(scenario_file: Path | None, example: bool) -> dict[str, Any]:
    if scenario_file is not None and example:
        raise click.UsageError("give either --scenario FILE or --example, not both")
    from inertest.io.plan_file import read_toml

    if scenario_file is not None:
        doc = read_toml(scenario_file, "scenario")
        return {k: (dict(v) if isinstance(v, dict) else v) for k, v in doc.items()}
    if example:
        from inertest.ins.scenario import seed_scenario

        sc = seed_scenario()
        return _document_of(sc)
    return {}


def _document_of(sc: InsScenario) -> dict[str, Any]:
    """The engineering-unit document that rebuilds ``sc`` (so options can override it)."""
    return {
        "name": sc.name,
        "site": {"latitude_deg": math.degrees(sc.site.latitude_rad), "radius_m": sc.site.radius_m,
                 "gravity_m_s2": sc.site.gravity_m_s2,
                 "earth_rate_rad_s": sc.site.earth_rate_rad_s, "coriolis": sc.site.coriolis},
        "run": {"hours": sc.duration_s / 3600, "step_s": sc.step_s},
        "errors": {"accel_bias_m_s2": sc.u[:2].tolist(), "gyro_drift_rad_s": sc.u[2:].tolist(),
                   "initial_velocity_m_s": sc.x0[:2].tolist(),
                   "initial_position_rad": sc.x0[2:4].tolist(),
                   "initial_attitude_rad": sc.x0[4:].tolist()},
    }


def _closed_form_table(scenario: InsScenario, resp: SourceResponses) -> list[list[str]]:
    # Imported here: sympy takes ~1 s to import, and every inertest command imports this module.
    from inertest.errors import import_extra

    import_extra("sympy", "the closed forms of the constant and secular errors (--closed-forms, "
                          "--report)")
    from inertest.ins.closed_forms import closed_forms, fit_constant_and_secular
    from inertest.ins.propagation import characteristic_periods
    from inertest.report.ins_errors import closed_form_rows

    forms = closed_forms(coriolis=scenario.site.coriolis)
    mags = np.concatenate([scenario.u, scenario.x0])
    c0, c1 = forms.evaluate(scenario.site, mags)
    periods = characteristic_periods(scenario.site)
    # The modal fit separates the constant from the Earth-rate term only over ~a full period.
    fitted = None
    if resp.t[-1] - resp.t[0] >= 0.99 * periods.earth_s:
        fitted = fit_constant_and_secular(scenario.site, resp.t, resp.per_source)
    return closed_form_rows(forms, c0, c1, fitted, resp.active)


def _apply_list_options(doc: dict, lists: dict[str, str | None]) -> None:
    """The comma-list options override the scenario's errors of the same quantity."""
    errors = doc.setdefault("errors", {})
    for opt, text in lists.items():
        if text is None:
            continue
        quantity, unit, count = _LIST_OPTIONS[opt]
        values = parse_float_list(text, name="--" + opt.replace("_", "-"), count=count)
        for key in [k for k in errors if k.startswith(quantity + "_")]:
            del errors[key]
        errors[f"{quantity}_{unit}"] = values


def _apply_options(doc: dict, table: str, options: tuple[tuple[str, object], ...]) -> None:
    """The options given override the scenario's keys of ``table``."""
    t = doc.setdefault(table, {})
    for key, value in options:
        if value is not None:
            t[key] = value
