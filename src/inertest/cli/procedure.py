"""``inertest simulate`` and ``inertest fit``: any procedure of a plan file."""

from __future__ import annotations

from collections.abc import Mapping
from datetime import datetime
from pathlib import Path

import click

from inertest.cli import safe_line
from inertest.cli._common import (
    DATA_PATH,
    REAL,
    check_paths,
    command_line,
    echo_json,
    print_identity,
    print_table,
    recording_options,
)

# The fit machinery is imported inside the commands: `inertest fit --help` stays within 2x of
# `python -c "import numpy"` (issue 18).
_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


@click.command()
@click.argument("plan", type=_FILE)
@click.option("--truth", type=_FILE, required=True,
              help="TOML of true coefficients in deg/h, deg/h/g, deg/h/g^2.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Data file to write (.csv or .parquet).")
@click.option("--noise", type=REAL, default=0.0, show_default=True,
              help="White noise per reading, in the plan's output unit.")
@click.option("--seed", type=int, default=None, help="Random seed for the noise.")
def simulate(plan: Path, truth: Path, output: Path, noise: float, seed: int | None) -> None:
    """Simulate the test in PLAN on a virtual instrument with coefficients TRUTH."""
    from inertest.api import load_plan
    from inertest.api import simulate as api_simulate
    from inertest.io.data_file import write_table
    from inertest.io.plan_file import load_truth

    check_paths([output], [plan, truth])
    p = load_plan(plan)
    data = api_simulate(p, load_truth(truth), noise=noise, rng=seed)
    write_table(output, data)
    n = len(next(iter(data.values())))
    click.echo(f"wrote {n} readings ({p.kind}, output in {p.instrument.output_unit}) to {output}")


@click.command()
@click.argument("plan", type=_FILE)
@click.argument("data", type=DATA_PATH)
@recording_options
@click.option("--sigma", type=REAL, default=None,
              help="Known noise per reading in the output unit (default: from the residuals).")
@click.option("--noise-model", default=None,
              help="Noise model of the instrument: auto, white, position-offsets, random-walk or "
              "flicker (default: the plan's [procedure] noise_model, else auto).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (result envelope).")
@click.option("--report", "report_dir", type=click.Path(file_okay=True, path_type=Path),
              default=None, help="Write the self-contained HTML report into this folder (a new "
              "folder or an earlier inertest report).")
@click.option("--pdf", is_flag=True, help="Also write report.pdf (needs Chromium).")
@click.option("--no-store", is_flag=True, help="Do not store the run in the history database.")
@click.option("--db", default=None, help="History database URL or SQLite path (default: "
              "$INERTEST_DB or ~/.local/share/inertest/history.db).")
@click.option("--tested-at", type=click.DateTime(formats=["%Y-%m-%d", "%Y-%m-%dT%H:%M:%S",
              "%Y-%m-%d %H:%M:%S"]), default=None,
              help="When the test was performed (UTC). Overrides the plan's [test] date, and "
              "says so; default: the plan's [test] date, else now. For filing older data.")
@click.option("--allow-duplicate", is_flag=True,
              help="File a data file that is already stored for this instrument and procedure.")
@click.option("--equipment", "equipment", type=_FILE, default=None,
              help="Lab equipment file (TOML): identities, calibration due dates and Type-B "
              "uncertainties of the equipment the plan's [test] table names; adds the "
              "uncertainty budget (Type A and Type B, k, U).")
@click.option("--spec", "spec", type=_FILE, default=None,
              help="Instrument specification (TOML, see examples/specs): a verdict per limited "
              "quantity under its ILAC-G8 decision rule, with the uncertainty budget.")
def fit(
    plan: Path, data: Path, topic: str | None, layout: Path | None, sigma: float | None,
    noise_model: str | None, as_json: bool,
    report_dir: Path | None,
    pdf: bool, no_store: bool, db: str | None, tested_at: datetime | None,
    allow_duplicate: bool, equipment: Path | None, spec: Path | None,
) -> None:
    """Identify the coefficients of the test in PLAN from the readings in DATA.

    The run is stored in the history database unless --no-store; with --report, the report
    includes the instrument's history. Fit, report and store are one transaction: when any
    step fails, nothing is stored or written. With --equipment or --spec the uncertainty
    budget (GUM: Type A of the fit, Type B of the equipment and site gravity, k, U) is in the
    terminal, JSON, report and stored run; with --spec also a verdict per limited quantity.
    The exit status does not depend on the verdicts: read "overall" in the JSON.
    """
    if pdf and report_dir is None:
        raise click.UsageError("--pdf needs --report DIR")
    from inertest.app.run import run

    out = run(plan, data, sigma=sigma, store=False if no_store else (db or True),
              report_dir=report_dir, pdf=pdf, tested_at=tested_at,
              allow_duplicate=allow_duplicate, equipment=equipment, spec=spec,
              noise_model=noise_model, command=command_line(), topic=topic,
              layout=layout)
    for w in out.warnings:
        click.echo(f"warning: {safe_line(w)}", err=True)
    if as_json:
        echo_json(out.to_dict())
        return
    doc = out.to_dict()
    print_identity(doc, warn=False)
    print_result(out.result)
    print_conformance(doc)
    if out.stored_run is not None:
        serial = out.plan.instrument.serial if out.plan is not None else ""
        filed = "" if out.filed_at is None else f", filed {out.filed_at:%Y-%m-%d %H:%M:%S} UTC"
        click.echo(safe_line(f"stored run {out.stored_run} of {serial} in {out.database}{filed}"))
    if out.report is not None:
        click.echo(safe_line(f"report: {out.report} (report id {out.report_id})"))


def print_conformance(doc: Mapping[str, object]) -> None:
    """Terminal tables of the envelope's uncertainty budget and verdicts (when present)."""
    from inertest.report.conformance import (
        VERDICT_HEADER,
        budget_notes,
        budget_table,
        verdict_notes,
        verdict_rows,
    )

    budget, conf = doc.get("uncertainty_budget"), doc.get("conformance")
    if isinstance(budget, Mapping):
        print_table("uncertainty budget (each in the quantity's unit)", *budget_table(budget))
        for n in budget_notes(budget):
            click.echo(safe_line(n))
    if isinstance(conf, Mapping):
        print_table(f"verdicts against {conf.get('spec')} (overall: {conf.get('overall')})",
                    VERDICT_HEADER, verdict_rows(conf))
        for n in verdict_notes(conf):
            click.echo(safe_line(n))
        click.echo(safe_line(f"decision rule: {conf.get('rule')}"))


def print_result(result, truth: Mapping[str, float] | None = None) -> None:
    """Terminal table of a procedure's result, then what the test could not determine."""
    ident = result.identification
    from inertest.report.identification import coefficient_rows, noise_model_text

    header, rows = coefficient_rows(ident, truth)
    print_table(f"{result.procedure}: what the data determine", header, rows)
    click.echo(safe_line(noise_model_text(ident)))
    if ident.checks is not None and not ident.checks.fits:
        click.echo(safe_line(f"model check: {ident.checks.verdict} (see the warning above)"))
    for s in ident.not_separable:
        click.echo(f"not determined: {s}")
    for line in headline_checks(result):
        click.echo(safe_line(line))


def headline_checks(result) -> list[str]:  # noqa: ANN001 - any procedure result
    """The orientation-free fit's own checks, one line each (also in the JSON's ``result``).

    How many static attitudes the detector found, |a| - g over them before and after the
    calibration, and how far the calibrated gyros carry gravity from one attitude to the next.
    """
    summary = getattr(result, "summary", None)
    intervals = getattr(result, "intervals", None)
    if not callable(summary) or intervals is None:
        return []
    s = summary()
    det = getattr(result, "detection", None)
    factor = f", detector threshold {det.threshold_factor:g} x the initial variance" if (
        det is not None) else ""
    norm, carry = s["gravity_norm_rms"], s["gravity_transport_rms"]
    return [
        f"attitudes found: {len(intervals)} static intervals{factor}",
        f"|a| - g over the attitudes (RMS): {norm['before']:.4g} {norm['unit']} raw -> "
        f"{norm['after']:.4g} {norm['unit']} calibrated",
        f"gravity carried by the gyros between attitudes (RMS angle error): "
        f"{carry['before']:.4g} {carry['unit']} raw -> {carry['after']:.4g} {carry['unit']} "
        "calibrated",
    ]
