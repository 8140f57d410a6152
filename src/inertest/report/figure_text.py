r"""Every text drawn in a figure as plain text: ``$`` escaped for matplotlib's mathtext.

File names, serials, study labels, scenario names, units and column names reach figure titles,
axis labels, legends and category tick labels. matplotlib reads a text with an even number of
unescaped ``$`` as math (mathtext), and an unbalanced ``\frac{1}{0`` there stops the drawing
with a parse error. :func:`plain_figure_text` escapes every ``$`` of those texts (``\$`` is
drawn as a dollar sign) just before a figure is rendered; the texts the tick formatters write
(numbers, ``10^-3`` of a log axis) are left as they are.
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Texts already escaped, with what they were set to, and the escaping tick formatters (a
#: figure saved twice is not escaped twice).
_DONE: weakref.WeakKeyDictionary[Any, object] = weakref.WeakKeyDictionary()


def escape_mathtext(text: str) -> str:
    """``text`` with every ``$`` escaped, so that matplotlib draws it as written."""
    return text.replace("$", r"\$")


def plain_figure_text(fig: Figure) -> None:
    """Escape every user-facing text of ``fig``: titles, labels, legends, notes, tick names.

    Texts are escaped in place; tick labels given as names (``set_xticks(x, names)``,
    categories) get a formatter that escapes what it writes. Numeric tick labels and offsets
    (whose ``10^k`` is math on purpose) are left alone. Safe to call more than once.
    """
    from matplotlib.axis import Tick
    from matplotlib.text import Text

    formatted: set[Any] = set()  # tick labels and offsets: written by the formatters at draw time
    for tick in fig.findobj(Tick):
        formatted.update((id(tick.label1), id(tick.label2)))
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            formatted.add(id(axis.offsetText))
            _escape_names(axis)
    for text in fig.findobj(Text):
        if id(text) in formatted:
            continue
        s = text.get_text()
        if "$" in s and _DONE.get(text) != s:
            text.set_text(escape_mathtext(s))
            _DONE[text] = text.get_text()


def _escape_names(axis: Any) -> None:
    """Give ``axis`` formatters that escape the tick names they write (not numbers)."""
    from matplotlib.category import StrCategoryFormatter
    from matplotlib.ticker import FixedFormatter, FuncFormatter

    names = (FixedFormatter, FuncFormatter, StrCategoryFormatter)
    for get, put in ((axis.get_major_formatter, axis.set_major_formatter),
                     (axis.get_minor_formatter, axis.set_minor_formatter)):
        fmt = get()
        if not isinstance(fmt, names) or fmt in _DONE:
            continue

        def escaped(x: float, pos: int | None = None, inner: Any = fmt) -> str:
            return escape_mathtext(str(inner(x, pos)))

        wrapper = FuncFormatter(escaped)
        _DONE[wrapper] = True
        put(wrapper)


def finish_figure(fig: Figure) -> Figure:
    """Escape ``fig``'s texts (:func:`plain_figure_text`), then lay it out tightly.

    Every figure of :mod:`inertest.report` ends with this call: the layout measures the texts,
    so they must be plain before it.
    """
    plain_figure_text(fig)
    fig.tight_layout()
    return fig
