"""Self-contained HTML: figures embedded as base64 PNG, no network needed to view a report."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import TYPE_CHECKING

import numpy as np

from inertest.report.rounding import format_number, table_scale

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_CSS = """
* { box-sizing: border-box; }
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 70em; color: #222;
       padding: 0 1em; overflow-wrap: anywhere; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 1.6em; border-bottom: 1px solid #aaa; }
.tw { max-width: 100%; overflow-x: auto; margin: 0.6em 0; break-inside: avoid; }
table { border-collapse: collapse; }
caption { caption-side: top; text-align: left; font-style: italic; padding: 0.2em 0;
          break-after: avoid; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
td { white-space: nowrap; overflow-wrap: normal; } td.w { white-space: normal; }
th { background: #eee; } td.l, th.l { text-align: left; }
.note { background: #fff8e0; border-left: 4px solid #e0b000; padding: 0.4em 0.8em; }
.warning { background: #fde8e8; border-left: 6px solid #c00000; padding: 0.4em 0.8em;
           font-weight: bold; }
figure { margin: 0.8em 0; max-width: 100%; break-inside: avoid; }
img { max-width: 100%; height: auto; } code, pre { background: #f3f3f3; }
figcaption { font-style: italic; break-before: avoid; }
pre { padding: 0.5em; overflow-x: auto; font-size: 0.85em; max-width: 100%; }
@page { size: A4; margin: 15mm; }
@media print {
  body { max-width: none; margin: 0; padding: 0; font-size: 9pt; }
  h2 { break-after: avoid; page-break-after: avoid; }
  figure, .tw, table { break-inside: avoid; page-break-inside: avoid; }
  .tw { overflow: visible; }
  table { width: 100%; table-layout: fixed; font-size: 8pt; }
  th, td { padding: 0.15em 0.3em; white-space: normal; overflow-wrap: anywhere; }
  pre { white-space: pre-wrap; }
  img { max-height: 240mm; }
}
"""


def figure_to_data_uri(fig: Figure, *, dpi: int = 110) -> str:
    """Render ``fig`` to PNG and return it as a ``data:`` URI; the figure is closed."""
    import matplotlib.pyplot as plt

    from inertest.report.figure_text import plain_figure_text

    plain_figure_text(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def figure_html(fig: Figure, caption: str = "") -> str:
    """An ``<figure>`` element with ``fig`` embedded (its caption kept with it when printed)."""
    cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    src = figure_to_data_uri(fig)
    return f'<figure><img src="{src}" alt="{html.escape(caption or "figure")}">{cap}</figure>'


def table_html(
    header: Sequence[str], rows: Sequence[Sequence[object]], *, left_columns: int = 1,
    caption: str = "",
) -> str:
    """An HTML table in its own scroll box (a wide table never widens the page).

    The first ``left_columns`` columns are left-aligned (names). Cells that are floats are
    printed by :func:`inertest.report.rounding.format_number` to four significant digits, with
    round-off next to the column's largest value printed as 0; text cells are printed as given
    (values with uncertainties come rounded by :func:`~inertest.report.rounding.
    round_to_uncertainty`). A ``caption`` stays with its table when printed.
    """
    cols = max([len(header), *(len(r) for r in rows)])
    scales = [table_scale([r[i] for r in rows if i < len(r) and _is_float(r[i])])
              for i in range(cols)]

    def text(i: int, v: object) -> str:
        return format_number(v, scale=scales[i]) if _is_float(v) else str(v)  # type: ignore[arg-type]

    def cell(tag: str, i: int, v: str) -> str:
        wide = tag == "td" and len(v) > 60
        cls = " ".join(c for c in ("l" if i < left_columns else "", "w" if wide else "") if c)
        attr = f' class="{cls}"' if cls else ""
        return f"<{tag}{attr}>{html.escape(v)}</{tag}>"

    head = "".join(cell("th", i, str(h)) for i, h in enumerate(header))
    body = "".join(
        "<tr>" + "".join(cell("td", i, text(i, v)) for i, v in enumerate(r)) + "</tr>"
        for r in rows
    )
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return (f'<div class="tw"><table>{cap}<thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table></div>")


def _is_float(v: object) -> bool:
    return isinstance(v, float | np.floating)


def paragraph(text: str, *, note: bool = False) -> str:
    """A paragraph of escaped text; ``note=True`` highlights it."""
    cls = ' class="note"' if note else ""
    return f"<p{cls}>{html.escape(text)}</p>"


def warning(text: str) -> str:
    """A paragraph of escaped text highlighted as a warning (a result not to be trusted)."""
    return f'<p class="warning" role="alert">{html.escape(text)}</p>'


def preformatted(text: str) -> str:
    """A ``<pre>`` block of escaped text (plans, file listings)."""
    return f"<pre>{html.escape(text)}</pre>"


@dataclass
class Section:
    """One titled section of a report: a list of HTML fragments."""

    title: str
    parts: list[str] = field(default_factory=list)


def page(title: str, sections: Sequence[Section], *, subtitle: str = "",
         identity: Sequence[Sequence[object]] | None = ()) -> str:
    """A complete HTML document with the given sections.

    Parameters
    ----------
    identity : sequence of [item, value], or None
        Rows of an "Identity" section put first, after the report's kind, the time it was
        generated (UTC) and the software version (input files, their SHA-256, the site, ...).
        None when the sections state the identity themselves (the per-fit page).
    """
    sub = f"<p>{html.escape(subtitle)}</p>" if subtitle else ""
    if identity is not None:
        rows = [["report", title],
                ["generated (UTC)", f"{datetime.now(UTC):%Y-%m-%d %H:%M}"],
                ["software", f"inertest {software_version()}"], *identity]
        sections = [Section("Identity", [table_html(["item", "value"], rows, left_columns=2,
                                                    caption="What, when and with what")]),
                    *sections]
    body = "".join(
        f"<section><h2>{html.escape(s.title)}</h2>{''.join(s.parts)}</section>" for s in sections
    )
    return (
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head>"
        f"<body><h1>{html.escape(title)}</h1>{sub}{body}</body></html>"
    )


def software_version() -> str:
    """The installed inertest version (``"unknown"`` when not installed)."""
    from importlib import metadata

    try:
        return metadata.version("inertest")
    except metadata.PackageNotFoundError:
        return "unknown"
