"""Self-contained HTML: figures embedded as base64 PNG, no network needed to view a report."""

from __future__ import annotations

import base64
import hashlib
import html
import io
import math
import re
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
       padding: 0 1em; overflow-wrap: break-word; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 1.6em; border-bottom: 1px solid #aaa; }
.tw { container-type: inline-size; margin: 0.6em 0; }
table { border-collapse: collapse; max-width: 100%; }
caption { caption-side: top; text-align: left; font-style: italic; padding: 0.2em 0; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right;
         overflow-wrap: normal; word-break: normal; hyphens: manual; }
td { white-space: nowrap; } td.w { white-space: normal; overflow-wrap: break-word; }
td.x, td .p { white-space: normal; overflow-wrap: anywhere; } .nw { white-space: nowrap; }
th { background: #eee; } td.l, th.l { text-align: left; }
.note { background: #fff8e0; border-left: 4px solid #e0b000; padding: 0.4em 0.8em; }
.warning { background: #fde8e8; border-left: 6px solid #c00000; padding: 0.4em 0.8em;
           font-weight: bold; }
figure { margin: 0.8em 0; max-width: 100%; }
img { max-width: 100%; height: auto; } code, pre { background: #f3f3f3; }
figcaption { font-style: italic; }
pre { padding: 0.5em; font-size: 0.85em; max-width: 100%; white-space: pre-wrap;
      overflow-wrap: anywhere; }
.sign table { width: 100%; } .sign td { height: 2.4em; }
.closing { break-inside: avoid; page-break-inside: avoid; }
.end { border-top: 2px solid #444; margin-top: 2em; padding-top: 0.4em; font-weight: bold; }
@page { size: A4; margin: 16mm 14mm 16mm 14mm; }
@media print {
  body { max-width: none; margin: 0; padding: 0; font-size: 9pt; }
  h2 { break-after: avoid; page-break-after: avoid; }
  caption { break-after: avoid; }
  figure, tr { break-inside: avoid; page-break-inside: avoid; }
  figcaption { break-before: avoid; }
  .tw { font-size: 8pt; }
  th, td { padding: 0.15em 0.35em; }
  img { max-height: 230mm; }
}
"""

#: Estimated width of one character of table text, in ``ch`` (digits are 1 ch; letters of a
#: proportional font average a little less, capitals more): the stacked layout is chosen from
#: this estimate, so it errs on the wide side.
_CH_PER_CHAR = 1.08
#: Width of a cell's padding and borders [ch].
_CELL_PAD_CH = 2.6
#: A cell of free text narrower than this (in characters) is kept on one line.
_WRAP_FROM = 40


#: The stacked layout of a table (``{p}`` is the table's selector): each row a card, its name
#: on top and its cells side by side as far as they fit, each cell its column's name above
#: its value (the value kept on one line).
_STACKED = (
    "{p}, {p} caption, {p} tbody {{ display: block; }} "
    "{p} thead {{ display: none; }} "
    "{p} tr {{ display: flex; flex-wrap: wrap; gap: 0.1em 1.2em; border: 1px solid #bbb; "
    "margin: 0 0 0.4em 0; padding: 0 0 0.2em 0; break-inside: avoid; }} "
    "{p} td {{ display: block; flex: 0 1 auto; border: none; text-align: left; "
    "padding: 0.1em 0.6em; }} "
    "{p} td:first-child {{ flex: 1 1 100%; background: #eee; font-weight: bold; "
    "white-space: normal; }} "
    "{p} td:not(:first-child)::before {{ content: attr(data-label); display: block; "
    "white-space: normal; font-style: italic; font-size: 0.85em; color: #555; }}"
)


def _stack_rules(body: str) -> str:
    """Container queries that stack each table where it is narrower than its least width.

    A table ``<div class="tw mN">`` needs about ``N`` ch: its cells never break inside a word
    (numbers stay whole), so it has a least width. Where its container is narrower (a phone,
    an A4 page), its rows are printed one below the other as ``column: value`` lines instead,
    so no number is ever split and no column hidden behind a scroll bar.
    """
    widths = sorted({int(m) for m in re.findall(r'class="tw m(\d+)"', body)})
    return "\n".join(f"@container (max-width: {n}ch) {{ {_STACKED.format(p=f'.m{n} table')} }}"
                     for n in widths)


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
    """An HTML table that never splits a number and never hides a column.

    The first ``left_columns`` columns are left-aligned (names). Cells that are floats are
    printed by :func:`inertest.report.rounding.format_number` to four significant digits, with
    round-off next to the column's largest value printed as 0; text cells are printed as given
    (values with uncertainties come rounded by :func:`~inertest.report.rounding.
    round_to_uncertainty`). A ``caption`` stays with its table when printed.

    Cells break between words only (``value ± std`` stays together), headers too. The table's
    least width is estimated from its longest words; where the page is narrower (a phone, an A4
    page), the rows are stacked, each cell as ``column: value`` (:func:`page` adds the rules).
    """
    cols = max([len(header), *(len(r) for r in rows)])
    scales = [table_scale([float(r[i]) for r in rows  # type: ignore[arg-type]
                           if i < len(r) and _is_float(r[i])])
              for i in range(cols)]
    labels = [str(header[i]) if i < len(header) else "" for i in range(cols)]

    def text(i: int, v: object) -> str:
        return format_number(v, scale=scales[i]) if _is_float(v) else str(v)  # type: ignore[arg-type]

    texts = [[text(i, v) for i, v in enumerate(r)] for r in rows]
    least = [max(_longest_word(labels[i]), *(_least_chars(r[i]) for r in texts if i < len(r)))
             for i in range(cols)]
    width = math.ceil(sum(_CH_PER_CHAR * n + _CELL_PAD_CH for n in least) / 5.0) * 5

    def cell(tag: str, i: int, v: str) -> str:
        kind = _cell_kind(v) if tag == "td" else ""
        cls = " ".join(c for c in ("l" if i < left_columns else "", kind) if c)
        attr = f' class="{cls}"' if cls else ""
        if tag == "td":
            attr += f' data-label="{html.escape(labels[i])}"'
        return f"<{tag}{attr}>{_escape_cell(v, kind)}</{tag}>"

    head = "".join(cell("th", i, h) for i, h in enumerate(labels))
    body = "".join("<tr>" + "".join(cell("td", i, v) for i, v in enumerate(r)) + "</tr>"
                   for r in texts)
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return (f'<div class="tw m{width}"><table>{cap}<thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table></div>")


#: Cells that may break anywhere: a hash or a path (never a number).
_BREAKABLE = re.compile(r"^(?:[0-9a-f]{40,}|\S*[/\\]\S{30,})$")


def _cell_kind(v: str) -> str:
    """``"x"`` for a hash or a long path, ``"w"`` for long free text, else ``""`` (one line)."""
    if _BREAKABLE.match(v):
        return "x"
    return "w" if len(v) > _WRAP_FROM else ""


def _least_chars(v: str) -> int:
    """Characters of a cell's least width: whole on one line, or its longest word."""
    kind = _cell_kind(v)
    if kind == "x":
        return 16
    return _longest_word(v) if kind == "w" else len(v)


def _longest_word(v: str) -> int:
    return max((len(w) for w in _glued(v).split()), default=0)


def _glued(v: str) -> str:
    """``v`` with value, ``±`` and uncertainty (or ``<`` and bound) held by no-break spaces."""
    v = v.replace(" ± ", "\u00a0±\u00a0")
    return "<\u00a0" + v[2:] if v.startswith("< ") else v


#: A word a browser could break inside when its cell wraps, which must stay whole: a number or
#: date with a hyphen or sign inside (``-6.2e-11``, ``2026-11-16``, ``517-1974``), an option
#: (``--rate``); not a path (``/data/run 3/x.csv`` may break where it must).
_WHOLE = re.compile(r"(?<!\S)(?:[^\s/]*\d[^\s/]*[-+][^\s/]*|[^\s/]*[-+][^\s/]*\d[^\s/]*"
                    r"|--?[A-Za-z][^\s/]*)(?!\S)")


#: A long path in a wrapping cell: it may break anywhere (a narrow page has no room for it).
_PATH = re.compile(r"(?<!\S)[^\s<>]*/[^\s<>]{20,}(?!\S)")


def _escape_cell(v: str, kind: str = "") -> str:
    """The cell's text as HTML; in a wrapping cell every number is kept on one line."""
    text = html.escape(_glued(v))
    if kind != "w":
        return text
    text = _WHOLE.sub(lambda m: f'<span class="nw">{m.group()}</span>', text)
    return _PATH.sub(lambda m: f'<span class="p">{m.group()}</span>', text)


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


@dataclass(frozen=True)
class Approval:
    """Who performed, reviewed and approved a report, and when (ISO/IEC 17025 7.8.2.1 o).

    A name or date left empty is printed as a blank to be filled in and signed by hand.
    """

    performed_by: str = ""
    performed_on: str = ""
    reviewed_by: str = ""
    reviewed_on: str = ""
    approved_by: str = ""
    approved_on: str = ""

    def rows(self) -> list[list[str]]:
        """``[role, name, date, signature]`` rows (the signature always blank)."""
        return [["performed by", self.performed_by, self.performed_on, ""],
                ["reviewed by", self.reviewed_by, self.reviewed_on, ""],
                ["approved by", self.approved_by, self.approved_on, ""]]

    def to_dict(self) -> dict[str, str | None]:
        """JSON form: each field, ``None`` where it is to be filled in by hand."""
        return {k: (getattr(self, k) or None) for k in (
            "performed_by", "performed_on", "reviewed_by", "reviewed_on", "approved_by",
            "approved_on")}


def approval_section(approval: Approval) -> Section:
    """The signature block: performed, reviewed and approved by, with dates."""
    return Section("Approval", ['<div class="sign">' + table_html(
        ["", "name", "date", "signature"], approval.rows(), left_columns=4,
        caption="Signatures (blank: to be filled in by hand)") + "</div>"])


#: Identity rows every report has; absent ones are printed as not stated, with the option.
_REQUIRED_IDENTITY = (("serial", "--serial"), ("site", "--site"), ("operator", "--operator"))


def report_id_of(*parts: object) -> str:
    """A report id derived from what identifies the report (``"R-"`` + 10 hex digits).

    The same inputs give the same id; a stored run uses its run id instead, a certificate
    its number.
    """
    text = "\x1f".join(str(p) for p in parts)
    return "R-" + hashlib.sha256(text.encode("utf-8")).hexdigest()[:10].upper()


def page(title: str, sections: Sequence[Section], *, subtitle: str = "",
         identity: Sequence[Sequence[object]] | None = (), report_id: str | None = None,
         serial: str | None = None, approval: Approval | None = None,
         statement: str = "") -> str:
    """A complete HTML document with the given sections, laid out as a certificate.

    Every printed page carries the report id, the serial and "page x of y" (CSS page margin
    boxes, ISO/IEC 17025:2017 7.8.2.1); the report closes with the approval block and a line
    saying that it ends there. Wide tables are stacked where the page is narrow
    (:func:`table_html`).

    Parameters
    ----------
    identity : sequence of [item, value], or None
        Rows of an "Identity" section put first, after the report's kind, its id, the time it
        was generated (UTC) and the software version (the command, input files and their
        SHA-256, ...); serial, site and operator are added as "not stated" when absent. None
        when the sections state the identity themselves (the per-fit page).
    report_id : str, optional
        Run id or certificate number; by default derived from the title and identity rows
        (:func:`report_id_of`).
    serial : str, optional
        The instrument's serial (default: the identity's ``serial`` row).
    approval : Approval, optional
        The signature block (default: performed by the identity's operator, the rest blank).
    statement : str, optional
        A sentence printed above the signatures (a certificate's "The results relate only to
        the item tested.", ISO/IEC 17025:2017 7.8.2.1 k).
    """
    sub = f"<p>{html.escape(subtitle)}</p>" if subtitle else ""
    given = {str(r[0]): str(r[1]) for r in identity or ()}
    if report_id is None:
        report_id = report_id_of(title, *(f"{k}={v}" for k, v in given.items()))
    if serial is None:
        serial = given.get("serial", "")
    if identity is not None:
        rows = [["report", title], ["report id", report_id],
                ["generated (UTC)", f"{datetime.now(UTC):%Y-%m-%d %H:%M}"],
                ["software", f"inertest {software_version()}"], *identity]
        rows += [[k, f"not stated (give {opt})"] for k, opt in _REQUIRED_IDENTITY
                 if k not in given]
        sections = [Section("Identity", [table_html(["item", "value"], rows, left_columns=2,
                                                    caption="What, when and with what")]),
                    *sections]
    if approval is None:
        op = given.get("operator", "")
        approval = Approval(performed_by="" if op.startswith("not stated") else op)
    body = "".join(
        f"<section><h2>{html.escape(s.title)}</h2>{''.join(s.parts)}</section>" for s in sections
    )
    sign = approval_section(approval)
    # the signatures and the end of the report are printed together, on the last page
    body += (f'<section class="closing"><h2>{sign.title}</h2>{"".join(sign.parts)}'
             f'{paragraph(statement) if statement else ""}'
             f'<p class="end">End of report {html.escape(report_id)}'
             f"{' (serial ' + html.escape(serial) + ')' if serial else ''}: nothing follows."
             "</p></section>")
    style = _CSS + _page_boxes(report_id, serial, title) + _stack_rules(body)
    return (
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<title>{html.escape(title)}</title><style>{style}</style></head>"
        f"<body><h1>{html.escape(title)}</h1>{sub}{body}</body></html>"
    )


def _css_string(text: str) -> str:
    """``text`` as a CSS string literal (quotes, backslashes and line ends escaped)."""
    out = text.replace("\\", "\\\\").replace('"', '\\"')
    out = re.sub(r"[\x00-\x1f\x7f<>]", lambda m: f"\\{ord(m.group()):x} ", out)
    return f'"{out}"'


def _page_boxes(report_id: str, serial: str, title: str) -> str:
    """The ``@page`` margin boxes: report id and serial at the top, page x of y at the foot."""
    short = title if len(title) <= 70 else title[:67] + "..."
    font = "font: 7.5pt system-ui, sans-serif; color: #444;"
    return (
        "@page { "
        f"@top-left {{ content: {_css_string('Report ' + report_id)}; {font} }} "
        f"@top-right {{ content: {_css_string('Serial ' + (serial or 'not stated'))}; {font} }} "
        f"@bottom-left {{ content: {_css_string(short)}; {font} }} "
        f'@bottom-right {{ content: "page " counter(page) " of " counter(pages); {font} }} }}\n'
    )


def software_version() -> str:
    """The installed inertest version (``"unknown"`` when not installed)."""
    from importlib import metadata

    try:
        return metadata.version("inertest")
    except metadata.PackageNotFoundError:
        return "unknown"
