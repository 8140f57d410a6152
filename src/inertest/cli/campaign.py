"""``inertest campaign MANIFEST``: an acceptance campaign, one certificate for the series."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import click

from inertest.cli import safe_line
from inertest.cli._common import command_line, echo_json, print_table


@click.command()
@click.argument("manifest", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--report", "report_dir", type=click.Path(file_okay=True, path_type=Path),
              default=None, help="Write the series certificate (index.html, certificate.json) "
              "into this folder (a new folder or an earlier inertest report).")
@click.option("--no-store", is_flag=True, help="Do not file the campaign in the history "
              "database.")
@click.option("--db", default=None, help="History database URL or SQLite path (default: "
              "$INERTEST_DB or ~/.local/share/inertest/history.db).")
@click.option("--allow-duplicate", is_flag=True,
              help="File data that is already stored for the unit and procedure.")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Local worker processes for the fits.")
@click.option("--tested-at", type=click.DateTime(formats=["%Y-%m-%d", "%Y-%m-%dT%H:%M:%S"]),
              default=None, help="Overrides every plan's [test] date (UTC), and says so.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (the campaign's "
              "envelope, each test's envelope inside).")
def campaign(manifest: Path, report_dir: Path | None, no_store: bool, db: str | None,
             allow_duplicate: bool, workers: int, tested_at: datetime | None,
             as_json: bool) -> None:
    """Run every test of the campaign in MANIFEST, judge every clause of its specification.

    The tests are fitted through the batch machinery; each clause a test verifies gets its
    verdict under the spec's decision rule, with the expanded uncertainty of the test's budget.
    The series is filed in the history database as one campaign (each run its own record)
    unless --no-store, and --report writes one certificate covering the series. All or
    nothing: when any step fails, nothing is stored or written. The exit status does not
    depend on the verdicts (read "overall" in the JSON).
    """
    from inertest.app.acceptance import run_campaign

    out = run_campaign(manifest, store=False if no_store else (db or True),
                       report_dir=report_dir, workers=workers, allow_duplicate=allow_duplicate,
                       tested_at=tested_at, command=command_line())
    if as_json:
        echo_json(out.to_dict())
        return
    c = out.campaign
    click.echo(safe_line(f"{c.title}: unit {c.serial} ({c.unit_type or 'type not stated'}), "
                         f"specification {c.spec.name} ({c.spec.decision_rule} rule)"))
    rows = []
    for t in out.tests:
        o = t.outcome
        rows.append([t.test.name, "planned (no data)" if o is None else o.result.kind,
                     "-" if o is None else str(o.tested_at.date()),
                     ", ".join(t.test.verifies) or "-"])
    print_table("tests", ["test", "procedure", "tested", "verifies"], rows)
    from inertest.report.acceptance import CLAUSE_HEADER, clause_rows

    doc = out.to_dict()
    print_table(f"clauses of {c.spec.name}", CLAUSE_HEADER, clause_rows(doc))
    for m in out.messages:
        click.echo(safe_line(f"note: {m}"))
    click.echo(safe_line(f"overall verdict: {out.overall}"
                         + ("" if out.complete else " (the series is incomplete)")))
    if out.campaign_uuid is not None:
        runs = sum(t.outcome is not None for t in out.tests)
        click.echo(safe_line(f"stored campaign {out.campaign_uuid} ({runs} runs) in "
                             f"{out.database}"))
    if out.report is not None:
        click.echo(safe_line(f"certificate: {out.report} (report id {out.report_id})"))
