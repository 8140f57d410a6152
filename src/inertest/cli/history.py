"""``inertest history SERIAL``: an instrument's coefficients over its stored runs."""

from __future__ import annotations

from pathlib import Path

import click

from inertest.cli._common import echo_json, print_table
from inertest.io.atomic import target_file
from inertest.report.history import history_figure
from inertest.report.identification import fmt
from inertest.store import HistoryStore
from inertest.store.summary import summarize_runs


@click.command()
@click.argument("serial")
@click.option("--coefficient", "names", multiple=True,
              help="Only this coefficient or combination (repeatable).")
@click.option("--procedure", default=None, help="Only runs of this procedure kind.")
@click.option("--db", default=None, help="Database URL or SQLite path (default: $INERTEST_DB or "
              "~/.local/share/inertest/history.db).")
@click.option("-k", "k", type=float, default=3.0, show_default=True,
              help="Flag runs more than k predicted sigma from the others.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the history figure (PNG, SVG or PDF by suffix).")
def history(serial: str, names: tuple[str, ...], procedure: str | None, db: str | None,
            k: float, as_json: bool, plot: Path | None) -> None:
    """Runs of instrument SERIAL in time order: mean, repeatability, trend, outliers."""
    store = HistoryStore(db)
    try:
        runs = store.runs(serial, procedure=procedure)
    finally:
        store.close()
    summaries = summarize_runs(runs, names=names or None, k=k)
    if plot is not None:
        fig = history_figure([h for h, _ in summaries], [t for _, t in summaries])
        with target_file(plot) as tmp:
            fig.savefig(tmp, format=plot.suffix.lstrip(".") or "png", dpi=120,
                        bbox_inches="tight")
    if as_json:
        echo_json({
            "serial": serial,
            "runs": [{"tested_at": r.tested_at.isoformat(), "procedure": r.procedure,
                      "run_uuid": r.run_uuid, "software_version": r.software_version,
                      "data_sha256": r.data_sha256} for r in runs],
            "quantities": [h.to_dict() for h, _ in summaries],
        })
        return
    click.echo(f"{serial}: {len(runs)} run(s) from {runs[0].tested_at:%Y-%m-%d %H:%M} to "
               f"{runs[-1].tested_at:%Y-%m-%d %H:%M} UTC")
    rows = []
    for h, _ in summaries:
        rep = "-" if h.repeatability is None else f"{h.repeatability:.3g}"
        trend = ("-" if h.trend_per_day is None
                 else fmt(h.trend_per_day * 30.0, (h.trend_std_per_day or 0) * 30.0))
        flagged = ", ".join(str(i + 1) for i in range(h.values.size) if h.flagged[i]) or "-"
        rows.append([h.name, h.unit, h.values.size, f"{h.mean:.6g}", rep, trend, flagged])
    print_table(f"history of {serial}",
                ["quantity", "unit", "runs", "mean", "repeatability (1σ)",
                 "trend per 30 days", f"runs > {k:g}σ"], rows)
    for h, _ in summaries[:1]:
        for m in h.messages:
            click.echo(f"note: {m}")
    if plot is not None:
        click.echo(f"figure: {plot}")
