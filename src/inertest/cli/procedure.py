"""``inertest simulate`` and ``inertest fit``: any procedure of a plan file."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path

import click

from inertest.api import fit as api_fit
from inertest.api import load_data, load_plan
from inertest.api import simulate as api_simulate
from inertest.cli._common import echo_json, print_table
from inertest.io.atomic import target_directory
from inertest.io.data_file import write_table
from inertest.io.plan_file import load_truth
from inertest.report.html import page
from inertest.report.identification import coefficient_rows
from inertest.report.sections import result_sections

_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


@click.command()
@click.argument("plan", type=_FILE)
@click.option("--truth", type=_FILE, required=True,
              help="TOML of true coefficients in deg/h, deg/h/g, deg/h/g^2.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Data file to write (.csv or .parquet).")
@click.option("--noise", type=float, default=0.0, show_default=True,
              help="White noise per reading, in the plan's output unit.")
@click.option("--seed", type=int, default=None, help="Random seed for the noise.")
def simulate(plan: Path, truth: Path, output: Path, noise: float, seed: int | None) -> None:
    """Simulate the test in PLAN on a virtual instrument with coefficients TRUTH."""
    p = load_plan(plan)
    data = api_simulate(p, load_truth(truth), noise=noise, rng=seed)
    write_table(output, data)
    n = len(next(iter(data.values())))
    click.echo(f"wrote {n} readings ({p.kind}, output in {p.instrument.output_unit}) to {output}")


@click.command()
@click.argument("plan", type=_FILE)
@click.argument("data", type=_FILE)
@click.option("--sigma", type=float, default=None,
              help="Known noise per reading in the output unit (default: from the residuals).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (DESIGN.md layout).")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Write a self-contained HTML report into this folder.")
def fit(
    plan: Path, data: Path, sigma: float | None, as_json: bool, report_dir: Path | None
) -> None:
    """Identify the coefficients of the test in PLAN from the readings in DATA."""
    p = load_plan(plan)
    d = load_data(data)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = api_fit(p, d, sigma=sigma)
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)
    if report_dir is not None:
        html = page(f"inertest: {p.kind} of {p.instrument.serial or 'gyro'}",
                    result_sections(result, title=p.kind),
                    subtitle=f"Plan {plan}, data {data}.")
        with target_directory(report_dir) as tmp:
            (tmp / "index.html").write_text(html, encoding="utf-8")
    if as_json:
        echo_json(result.to_dict())
        return
    print_result(result)
    if report_dir is not None:
        click.echo(f"report: {report_dir / 'index.html'}")


def print_result(result, truth: Mapping[str, float] | None = None) -> None:
    """Terminal table of a procedure's result, then what the test could not determine."""
    ident = result.identification
    header, rows = coefficient_rows(ident, truth)
    print_table(f"{result.procedure}: what the data determine", header, rows)
    if ident.sigma_from_residuals:
        click.echo(f"noise per reading: {ident.noise_sigma:.3g} {ident.noise_unit} "
                   f"(from residuals, {ident.dof} dof)")
    for s in ident.not_separable:
        click.echo(f"not determined: {s}")
