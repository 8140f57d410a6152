"""Small pieces shared by the sub-commands: JSON output and console tables."""

from __future__ import annotations

import json
from collections.abc import Sequence

import click
from rich.console import Console
from rich.markup import escape
from rich.table import Table


def echo_json(obj: object) -> None:
    """Print ``obj`` as one JSON document on stdout."""
    click.echo(json.dumps(obj, indent=2, allow_nan=False))


def print_table(title: str, header: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """Print a table on the terminal (rich); the first column is left-aligned, the rest right."""
    # Escape rich markup: units such as "[deg/h]" would otherwise be read as style tags.
    table = Table(title=escape(title), title_justify="left")
    for i, h in enumerate(header):
        table.add_column(escape(str(h)), justify="left" if i == 0 else "right")
    for r in rows:
        table.add_row(*(escape(str(v)) for v in r))
    # Piped output (files, pytest) gets a wide console instead of 80 columns, so rows don't wrap.
    console = Console(soft_wrap=True)
    if not console.is_terminal:
        console = Console(soft_wrap=True, width=200)
    console.print(table)


def parse_float_list(text: str, *, name: str, count: int | None = None) -> list[float]:
    """Parse ``"1,2,3"`` into floats; raise a click error naming ``name`` when malformed."""
    try:
        values = [float(t) for t in text.split(",") if t.strip() != ""]
    except ValueError:
        raise click.BadParameter(
            f"expected comma-separated numbers, got {text!r}", param_hint=name
        ) from None
    if count is not None and len(values) != count:
        raise click.BadParameter(
            f"expected {count} comma-separated numbers, got {len(values)} in {text!r}",
            param_hint=name,
        )
    return values
