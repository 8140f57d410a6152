"""``inertest lot``: lot statistics of the units in the history database."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from inertest.cli import safe_line
from inertest.cli._common import (
    FiniteFloatRange,
    check_paths,
    echo_json,
    input_identity,
    print_table,
)


@click.command()
@click.option("--db", default=None, help="History database URL or SQLite path (default: "
              "$INERTEST_DB or ~/.local/share/inertest/history.db).")
@click.option("--procedure", default=None,
              help="Only runs of this procedure kind (default: every procedure).")
@click.option("--type", "unit_type", default=None,
              help="Only units filed by an acceptance campaign of this unit type.")
@click.option("--spec", "spec", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=None, help="Specification: process capability against its limits.")
@click.option("--level", type=FiniteFloatRange(min=0, max=1, min_open=True, max_open=True),
              default=0.01, show_default=True,
              help="Level at which a unit stands out, for the lot (Bonferroni).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--report", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the lot report as a self-contained HTML file.")
def lot(db: str | None, procedure: str | None, unit_type: str | None, spec: Path | None,
        level: float, as_json: bool, report: Path | None) -> None:
    """Lot statistics of many units of one type from their stored runs.

    Per procedure and quantity: mean, observed spread, the measurement's share of it, the
    unit-to-unit spread with the measurement removed, process capability (Cp, Cpk with 95 %
    intervals) against --spec, and the units that stand out. The latest run of each unit and
    procedure stands for it.
    """
    from inertest.errors import InputError
    from inertest.quality.conformance import read_spec
    from inertest.quality.lot import lot_statistics
    from inertest.results import envelope
    from inertest.store import HistoryStore
    from inertest.store.campaigns import campaigns

    spec_doc = read_spec(spec) if spec is not None else None
    store = HistoryStore(db)
    check_paths([report], [store.path, spec])
    try:
        serials = store.serials()
        clause_procedures: dict[str, set[str]] | None = None
        if unit_type is not None:
            found = campaigns(store, unit_type=unit_type)
            typed = {c.serial for c in found}
            clause_procedures = {}
            for c in found:   # which procedure verifies which clause, from the campaigns
                for t in (c.document.get("result") or {}).get("tests") or []:
                    kind = (t.get("result") or {}).get("kind")
                    for cid in t.get("verifies") or []:
                        if kind:
                            clause_procedures.setdefault(cid, set()).add(kind)
            if not typed:
                known = sorted({c.unit_type for c in campaigns(store)})
                raise InputError(f"no campaign of unit type {unit_type!r} in "
                                 f"{store.display_url}; known types: "
                                 f"{', '.join(known) or 'none (file campaigns first)'}")
            serials = [s for s in serials if s in typed]
        docs = []
        for s in serials:
            docs += [_dated(r) for r in store.runs(s) if procedure in (None, r.procedure)]
    finally:
        store.close()
    if not docs:
        what = f"runs of {procedure}" if procedure else "runs"
        raise InputError(f"no {what} stored in {store.display_url}; check --db and "
                         "--procedure, or file some runs first")
    stats = lot_statistics(docs, spec_doc, level=level,
                           clause_procedures=None if clause_procedures is None else {
                               k: sorted(v) for k, v in clause_procedures.items()})
    title = f"Lot report: {unit_type or 'units'} ({len(stats.serials)} units)"
    if report is not None:
        from inertest.io.atomic import write_text
        from inertest.report.lot import lot_page

        write_text(report, lot_page(stats, title=title, identity=input_identity(
            [spec], serial=f"lot of {len(stats.serials)} units (listed in the tables)") + [
            ["database", store.display_url], ["procedure", procedure or "every procedure"],
            ["unit type", unit_type or "not selected"]]))
    if as_json:
        echo_json(envelope("lot", result=stats.to_dict(), messages=stats.notes))
        return
    from inertest.report.lot import (
        CAPABILITY_HEADER,
        SUMMARY_HEADER,
        capability_rows,
        summary_rows,
    )

    print_table(title, SUMMARY_HEADER, summary_rows(stats))
    caps = capability_rows(stats)
    if caps:
        print_table(f"capability against {stats.spec_name}", CAPABILITY_HEADER, caps)
    for n in stats.notes:
        click.echo(safe_line(f"note: {n}"))
    click.echo("observed std: measurement noise included; unit-to-unit std: measurement "
               "removed (random effects)")
    if report is not None:
        click.echo(safe_line(f"report: {report}"))


def _dated(run: Any) -> dict[str, Any]:
    """The stored envelope with the run's test date in its test block.

    A run whose plan names no test identity has no test block: its date is the store's
    ``tested_at`` column (the lot's values printed ``tested_at: null``; an independent
    review found it).
    """
    doc = dict(run.result)
    test = doc.get("test")
    if not isinstance(test, dict) or not test.get("tested_at"):
        doc["test"] = {**(test if isinstance(test, dict) else {}),
                       "tested_at": run.tested_at.isoformat(timespec="seconds")}
    return doc
