"""``inertest history SERIAL``: an instrument's coefficients over its stored runs."""

from __future__ import annotations

from pathlib import Path

import click

from inertest.cli import safe_line
from inertest.cli._common import (
    FiniteFloatRange,
    check_paths,
    echo_json,
    figure_format,
    input_identity,
    print_table,
    save_figure,
)


@click.command()
@click.argument("serial")
@click.option("--coefficient", "names", multiple=True,
              help="Only this coefficient or combination (repeatable).")
@click.option("--procedure", default=None, help="Only runs of this procedure kind.")
@click.option("--db", default=None, help="Database URL or SQLite path (default: $INERTEST_DB or "
              "~/.local/share/inertest/history.db).")
@click.option("-k", "k", type=FiniteFloatRange(min=0, min_open=True), default=3.0,
              show_default=True,
              help="Flag runs more than k predicted sigma from the others.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the history figure (PNG, SVG or PDF by suffix).")
@click.option("--spec", "spec", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=None, help="Instrument specification (TOML): its limits are drawn in the "
              "figure and listed in the table.")
@click.option("--report", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the drift review as a self-contained HTML report (table, figure).")
def history(serial: str, names: tuple[str, ...], procedure: str | None, db: str | None,
            k: float, as_json: bool, plot: Path | None, spec: Path | None,
            report: Path | None) -> None:
    """Runs of instrument SERIAL in time order: mean, repeatability, trend, outliers.

    Runs are dated by their test date (the plan's [test] date or --tested-at of inertest
    fit), not by when they were filed.
    """
    # The database and plotting libraries load only when the command runs.
    from inertest.quality.conformance import read_spec
    from inertest.report.history import (
        date_range_text,
        history_figure,
        history_rows,
        history_sections,
        spec_limits,
    )
    from inertest.store import HistoryStore, check_label
    from inertest.store.summary import instrument_history

    serial = check_label(serial, "serial")
    figure_format(plot)
    limits = spec_limits(read_spec(spec) if spec is not None else None)
    store = HistoryStore(db)
    check_paths([plot, report], [store.path, spec])
    try:
        runs = store.runs(serial, procedure=procedure)
    finally:
        store.close()
    result = instrument_history(runs, serial, names=names or None, k=k)
    summaries = result.summaries
    if plot is not None:
        fig = history_figure([h for h, _ in summaries], [t for _, t in summaries],
                             serial=serial, limits=limits)
        save_figure(fig, plot, dpi=120)
    if report is not None:
        from inertest.io.atomic import write_text
        from inertest.report.html import page

        span = date_range_text([r.tested_at for r in runs])
        write_text(report, page(
            f"Drift review of {serial}",
            history_sections([h for h, _ in summaries], [t for _, t in summaries],
                             serial=serial, limits=limits),
            subtitle=f"{len(runs)} stored runs, {span} (test dates)",
            identity=input_identity([spec], serial=serial) + [
                ["database", store.display_url], ["runs", ", ".join(
                    f"{r.run_uuid} ({r.tested_at:%Y-%m-%d}, {r.procedure})" for r in runs)]]))
    if as_json:
        echo_json(result.to_dict())
        return
    click.echo(safe_line(f"{serial}: {len(runs)} run(s) from {runs[0].tested_at:%Y-%m-%d %H:%M} "
                         f"to {runs[-1].tested_at:%Y-%m-%d %H:%M} UTC"))
    header, rows = history_rows([h for h, _ in summaries], limits=limits)
    print_table(f"history of {serial} ({date_range_text([r.tested_at for r in runs])}, test "
                "dates)", header, rows)
    for h, _ in summaries[:1]:
        for m in h.messages:
            click.echo(f"note: {safe_line(m)}")
    if plot is not None:
        click.echo(f"figure: {plot}")
    if report is not None:
        click.echo(f"report: {report}")
