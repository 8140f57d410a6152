"""``inertest centrifuge-study``: what each dual-axis centrifuge error costs (issue 5)."""

from __future__ import annotations

from pathlib import Path

import click

from inertest.cli._common import check_paths, echo_json, input_identity, print_table
from inertest.errors import PlanError
from inertest.io.atomic import write_text
from inertest.io.plan_file import read_toml


@click.command("centrifuge-study")
@click.argument("plan_file", metavar="PLAN", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object (coefficients in deg/h per g^k).")
@click.option("--report", type=click.Path(dir_okay=False, path_type=Path),
              help="Write a self-contained HTML report (tables and figures).")
@click.option("--monte-carlo", "monte_carlo", type=int, default=None,
              help="Monte Carlo repetitions confirming the uncertainties (overrides the plan's "
                   "[monte_carlo] runs; 0 = none).")
def centrifuge_study(plan_file: Path, as_json: bool, report: Path | None,
                     monte_carlo: int | None) -> None:
    """Uncertainty, error transfer and compensation of the nine-position centrifuge test.

    PLAN is a TOML file (see examples/centrifuge/study.toml): site, machine, noise, true
    coefficients and one [errors.KEY] table per machine error studied alone.
    """
    # The study, the procedure and the report (scipy, numba, matplotlib) load only here, so
    # that --help starts at once.
    from inertest.procedures.centrifuge_nine_position import fit_inputs
    from inertest.report.centrifuge_study import (
        UNCERTAINTY_HEADER,
        error_header,
        error_rows,
        study_page,
        uncertainty_rows,
    )
    from inertest.studies import centrifuge_study as cs

    if monte_carlo is not None and (monte_carlo < 0 or monte_carlo == 1):
        raise click.BadParameter("give 0 (no Monte Carlo) or at least 2 repetitions",
                                 param_hint="--monte-carlo")
    check_paths([report], [plan_file])
    doc = read_toml(plan_file, "study plan")
    if not doc:
        raise PlanError(f"study plan {plan_file} is empty; give at least [site] and one "
                        "[errors.KEY] table (see examples/centrifuge/study.toml)")
    plan = cs.plan_from_mapping(doc, source=str(plan_file))
    result = cs.run_study(plan, fit_inputs, monte_carlo_runs=monte_carlo)
    if report is not None:
        write_text(report, study_page(result, identity=input_identity(
            [plan_file], source="simulated from the study plan (white noise; Monte Carlo seed "
                                f"{plan.seed})")))
    if as_json:
        echo_json(result.to_dict())
        return
    print_table("coefficient uncertainty (1 sigma)", UNCERTAINTY_HEADER, uncertainty_rows(result))
    print_table("identification error, ideal regressors (estimate - truth)",
                error_header(result), error_rows(result))
    print_table("after compensation (error model + measured dgamma)", error_header(result),
                error_rows(result, compensated=True))
    for note in result.notes:
        click.echo(f"- {note}")
    if report is not None:
        click.echo(f"report: {report}")
