"""Self-contained HTML: figures embedded as base64 PNG, no network needed to view a report."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 70em; color: #222; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 1.6em; border-bottom: 1px solid #aaa; }
table { border-collapse: collapse; margin: 0.6em 0; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
th { background: #eee; } td.l, th.l { text-align: left; }
.note { background: #fff8e0; border-left: 4px solid #e0b000; padding: 0.4em 0.8em; }
img { max-width: 100%; } code, pre { background: #f3f3f3; }
pre { padding: 0.5em; overflow-x: auto; font-size: 0.85em; }
@media print {
  body { max-width: none; margin: 1cm; font-size: 10pt; }
  h2 { page-break-after: avoid; } figure, table { page-break-inside: avoid; }
  pre { white-space: pre-wrap; }
}
"""


def figure_to_data_uri(fig: Figure, *, dpi: int = 110) -> str:
    """Render ``fig`` to PNG and return it as a ``data:`` URI; the figure is closed."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def figure_html(fig: Figure, caption: str = "") -> str:
    """An ``<figure>`` element with ``fig`` embedded."""
    cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    src = figure_to_data_uri(fig)
    return f'<figure><img src="{src}" alt="{html.escape(caption)}">{cap}</figure>'


def table_html(
    header: Sequence[str], rows: Sequence[Sequence[object]], *, left_columns: int = 1
) -> str:
    """An HTML table; the first ``left_columns`` columns are left-aligned (names)."""

    def cell(tag: str, i: int, v: object) -> str:
        cls = ' class="l"' if i < left_columns else ""
        return f"<{tag}{cls}>{html.escape(str(v))}</{tag}>"

    head = "".join(cell("th", i, h) for i, h in enumerate(header))
    body = "".join(
        "<tr>" + "".join(cell("td", i, v) for i, v in enumerate(r)) + "</tr>" for r in rows
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def paragraph(text: str, *, note: bool = False) -> str:
    """A paragraph of escaped text; ``note=True`` highlights it."""
    cls = ' class="note"' if note else ""
    return f"<p{cls}>{html.escape(text)}</p>"


def preformatted(text: str) -> str:
    """A ``<pre>`` block of escaped text (plans, file listings)."""
    return f"<pre>{html.escape(text)}</pre>"


@dataclass
class Section:
    """One titled section of a report: a list of HTML fragments."""

    title: str
    parts: list[str] = field(default_factory=list)


def page(title: str, sections: Sequence[Section], *, subtitle: str = "") -> str:
    """A complete HTML document with the given sections."""
    sub = f"<p>{html.escape(subtitle)}</p>" if subtitle else ""
    body = "".join(
        f"<section><h2>{html.escape(s.title)}</h2>{''.join(s.parts)}</section>" for s in sections
    )
    return (
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head>"
        f"<body><h1>{html.escape(title)}</h1>{sub}{body}</body></html>"
    )
