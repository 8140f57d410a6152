"""``inertest nav-simulate`` and ``inertest nav-calibrate``: navigation-mode gyro-triad calibration.

Both take a ``gyro-triad-rotation`` plan (site, instrument, rotations, table rate). The iteration
starts from a calibration JSON, e.g. the output of ``inertest fit PLAN DATA --json`` of the
360-degree rotation test.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np

from inertest.cli._common import (
    DATA_PATH,
    REAL,
    check_paths,
    echo_json,
    print_table,
    recording_options,
)
from inertest.errors import InputError, PlanError
from inertest.plan import Plan
from inertest.report.rounding import format_number, round_to_uncertainty

if TYPE_CHECKING:
    from inertest.models.triad import TriadCalibration

_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


def _rotation_plan(path: Path) -> Plan:
    from inertest.api import load_plan
    from inertest.procedures.gyro_triad_rotation import KIND as ROTATION_KIND

    p = load_plan(path)
    if p.kind != ROTATION_KIND:
        raise PlanError(
            f'navigation-mode calibration needs a plan of kind "{ROTATION_KIND}" (its rotations '
            f'and table rate), got "{p.kind}"'
        )
    return p


@click.command("nav-simulate")
@click.argument("plan", type=_FILE)
@click.option("--truth", type=_FILE, required=True,
              help="TOML of the triad's K_x..K_z, M_ij [urad], B_x..B_z [deg/h].")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Time-series data file to write (.csv or .parquet).")
@click.option("--rate-hz", type=REAL, default=100.0, show_default=True,
              help="Sample rate of the counts.")
@click.option("--rest-s", type=REAL, default=5.0, show_default=True,
              help="Time at rest before and after each turn [s].")
@click.option("--noise", type=REAL, default=0.0, show_default=True,
              help="White noise of each sample's count, in the plan's output unit (x s).")
@click.option("--seed", type=int, default=None, help="Random seed for the noise.")
def nav_simulate(plan: Path, truth: Path, output: Path, rate_hz: float, rest_s: float,
                 noise: float, seed: int | None) -> None:
    """Simulate navigation-mode turns of PLAN (each rotation, each direction) sample by sample."""
    # The procedures, scipy and the report load only when a command runs (fast --help).
    from inertest.equipment.rate_table import axis_index, triad_attitude
    from inertest.io.data_file import write_table
    from inertest.io.plan_file import load_truth
    from inertest.models.rate_gyro import raw_rate_per_si, triad_from_truth
    from inertest.procedures import navigation_calibration as nav

    check_paths([output], [plan, truth])
    p = _rotation_plan(plan)
    if not rate_hz > 0 or not rest_s >= 0 or not noise >= 0:
        raise InputError("--rate-hz must be positive, --rest-s and --noise non-negative")
    spec = p.procedure
    per_si = raw_rate_per_si(p.instrument.output_unit)
    A, b = triad_from_truth(load_truth(truth), p.instrument.output_unit)
    turns, attitudes = [], []
    for r in spec.rotations:
        for d in spec.directions:
            turns.append((f"{r.attitude} {r.axis}{'+' if d > 0 else '-'}",
                          triad_attitude(r.attitude), axis_index(r.axis), d))
            attitudes.append(r.attitude)
    records = nav.simulate_segments(turns, spec.profile, forward=A, offset=b,
                                    latitude_rad=p.site.latitude_rad, rest_s=rest_s,
                                    sample_rate_hz=rate_hz, noise=noise / per_si, rng=seed)
    cols = nav.records_to_columns(records, attitudes, raw_per_si=per_si)
    write_table(output, cols)
    click.echo(f"wrote {len(records)} turns, {cols['time_s'].size} samples at {rate_hz:g} Hz "
               f"to {output}")


def _initial_calibration(path: Path, plan: Plan) -> TriadCalibration:
    from inertest.io.calibration_file import load_calibration
    from inertest.models.rate_gyro import raw_rate_unit
    from inertest.procedures.gyro_triad_rotation import KIND as ROTATION_KIND

    gyro = load_calibration(path, what="initial calibration").gyroscope
    if gyro is None:
        raise InputError(f'initial calibration {path} has no "gyroscope" block; use the output '
                         f"of inertest fit --json of a {ROTATION_KIND} test")
    want = raw_rate_unit(plan.instrument.output_unit)
    if gyro.raw_unit != want or gyro.unit != "rad/s":
        raise InputError(
            f"initial calibration {path} maps {gyro.raw_unit} to {gyro.unit}, but this plan's raw "
            f"rate is in {want} and the calibrated rate must be rad/s"
        )
    return gyro


@click.command("nav-calibrate")
@click.argument("plan", type=_FILE)
@click.argument("data", type=DATA_PATH)
@recording_options
@click.option("--initial", type=_FILE, required=True,
              help="JSON with the starting calibration (inertest fit --json output, or "
                   '{"gyroscope": {...}}).')
@click.option("--check-interval", type=REAL, default=1.0, show_default=True,
              help="Spacing of the attitude comparisons [s].")
@click.option("--no-bias", is_flag=True, help="Keep the initial bias (correct K and M only).")
@click.option("--max-iterations", type=int, default=10, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Write index.html with the convergence figure into this folder.")
def nav_calibrate(plan: Path, data: Path, topic: str | None, layout: Path | None,
                  initial: Path, check_interval: float, no_bias: bool,
                  max_iterations: int, as_json: bool, report_dir: Path | None) -> None:
    """Refine the gyro calibration by navigating through the 360-degree turns in DATA."""
    from inertest.api import load_data
    from inertest.io.atomic import target_directory
    from inertest.procedures import navigation_calibration as nav
    from inertest.report.gyro_triad import navigation_page

    check_paths([report_dir], [plan, data, initial])
    p = _rotation_plan(plan)
    if max_iterations < 1:
        raise InputError("--max-iterations must be at least 1")
    result = nav.calibrate(p, load_data(data, topic, layout=layout),
                           _initial_calibration(initial, p),
                           check_interval_s=check_interval, estimate_bias=not no_bias,
                           max_iterations=max_iterations)
    if report_dir is not None:
        html = navigation_page(result)
        with target_directory(report_dir, inputs=[plan, data, initial]) as tmp:
            (tmp / "index.html").write_text(html, encoding="utf-8")
    if as_json:
        echo_json(result.to_dict())
        return
    rows = [[h.iteration, format_number(float(h.attitude_error_rms_arcsec)),
             ", ".join(format_number(float(v)) for v in h.scale_correction_ppm),
             format_number(float(np.max(np.abs(h.misalignment_correction_urad))))]
            for h in result.iteration.history]
    print_table("navigation-mode iterations", ["iteration", "attitude error rms [arcsec]",
                                               "dK x, y, z [ppm]", "max |dM| [urad]"], rows)
    print_table("calibration after the iteration", ["quantity", "value", "std", "unit"],
                [[e.name, *round_to_uncertainty(e.value, e.std), e.unit]
                 for e in result.coefficients.values()])
    for note in result.identification.not_separable:
        click.echo(f"note: {note}")
    click.echo("converged" if result.iteration.converged else
               f"not converged after {max_iterations} iterations")
    if report_dir is not None:
        click.echo(f"report: {report_dir / 'index.html'}")
