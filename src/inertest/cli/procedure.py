"""``inertest simulate`` and ``inertest fit``: any procedure of a plan file."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

import click

from inertest.api import fit as api_fit
from inertest.api import load_data, load_plan
from inertest.api import simulate as api_simulate
from inertest.cli._common import echo_json, print_table
from inertest.io.atomic import target_directory
from inertest.io.data_file import file_sha256, write_table
from inertest.io.plan_file import load_truth
from inertest.report.campaign import campaign_page
from inertest.report.identification import coefficient_rows
from inertest.report.pdf import html_to_pdf
from inertest.store import HistoryStore, RunRecord, StoreError
from inertest.store.summary import summarize_runs

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
              default=None, help="Write the self-contained HTML report into this folder.")
@click.option("--pdf", is_flag=True, help="Also write report.pdf (needs Chromium).")
@click.option("--no-store", is_flag=True, help="Do not store the run in the history database.")
@click.option("--db", default=None, help="History database URL or SQLite path (default: "
              "$INERTEST_DB or ~/.local/share/inertest/history.db).")
@click.option("--tested-at", type=click.DateTime(formats=["%Y-%m-%d", "%Y-%m-%dT%H:%M:%S",
              "%Y-%m-%d %H:%M:%S"]), default=None,
              help="When the test was run (UTC; default: now). For filing older data.")
def fit(
    plan: Path, data: Path, sigma: float | None, as_json: bool, report_dir: Path | None,
    pdf: bool, no_store: bool, db: str | None, tested_at: datetime | None,
) -> None:
    """Identify the coefficients of the test in PLAN from the readings in DATA.

    The run is stored in the history database unless --no-store; with --report, the report
    includes the instrument's history.
    """
    p = load_plan(plan)
    d = load_data(data)
    if pdf and report_dir is None:
        raise click.UsageError("--pdf needs --report DIR")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = api_fit(p, d, sigma=sigma)
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)
    when = (tested_at.replace(tzinfo=UTC) if tested_at is not None else datetime.now(UTC))
    plan_text = plan.read_text(encoding="utf-8")
    digest = file_sha256(data)
    version = metadata.version("inertest")
    store = None if no_store else HistoryStore(db)
    try:
        record = None
        history: list = []
        if store is not None:
            record = RunRecord.from_result(
                result.to_dict(), serial=p.instrument.serial, instrument_kind=p.instrument.kind,
                plan_text=plan_text, data_sha256=digest, software_version=version,
                tested_at=when)
        if report_dir is not None:
            if store is not None and record is not None:
                try:
                    earlier = store.runs(p.instrument.serial, procedure=result.procedure)
                except StoreError:
                    earlier = []
                runs = sorted([*earlier, record], key=lambda r: r.tested_at)
                history = summarize_runs(runs)
            html = campaign_page(
                result,
                instrument={"serial": p.instrument.serial or "-", "kind": p.instrument.kind,
                            "output unit": p.instrument.output_unit,
                            "scale factor": p.instrument.scale_factor or "-"},
                site={"latitude [deg]": f"{p.site.latitude_deg:.6f}",
                      "gravity [m/s^2]": f"{p.site.gravity_m_s2:.7f}"},
                plan_text=plan_text,
                data={"file": str(data), "rows": len(next(iter(d.values()))),
                      "columns": ", ".join(d), "sha256": digest},
                tested_at=when, software_version=version, history=history)
            with target_directory(report_dir) as tmp:
                (tmp / "index.html").write_text(html, encoding="utf-8")
                if pdf:
                    html_to_pdf(tmp / "index.html", tmp / "report.pdf")
                # Store last inside the block: a failed store leaves no report, and a failed
                # report leaves no stored run.
                if store is not None and record is not None:
                    store.add(record)
        elif store is not None and record is not None:
            store.add(record)
    finally:
        if store is not None:
            store.close()
    if as_json:
        echo_json(result.to_dict())
        return
    print_result(result)
    if store is not None:
        click.echo(f"stored run of {p.instrument.serial} in {store.url}")
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
