"""Every text drawn in a figure is plain text: ``$`` never starts mathtext (issue 34).

A file name, serial, study label or scenario name holding ``$\\frac{1}{0$`` stopped the
drawing with a mathtext parse error. The check uses matplotlib's own decision of what is math
(``Text._preprocess_math``), so it tests what is drawn, not our escaping.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from inertest.report.figure_text import escape_mathtext, finish_figure, plain_figure_text  # noqa: E402

HOSTILE = [r"gyro $\frac{1}{0$ run", "$x$", "cost $5", r"a\$b", "$$", r"\$x\$", "plain"]


def _drawn(text: Text) -> tuple[str, bool]:
    """What matplotlib draws for ``text``: (string, whether as math)."""
    return text._preprocess_math(text.get_text())


@pytest.mark.parametrize("label", HOSTILE)
def test_every_user_text_is_drawn_as_written(label):
    fig, (ax, bx) = plt.subplots(1, 2)
    ax.plot([1, 2], [1, 2], label=label)
    ax.set_title(label)
    ax.set_xlabel(label)
    ax.set_ylabel(label)
    ax.legend(title=label)
    ax.annotate(label, (1, 1))
    bx.set_xticks([0, 1], [label, "b"])
    fig.suptitle(label)
    finish_figure(fig)
    fig.savefig(io.BytesIO(), format="png")  # would raise on a mathtext parse error
    texts = [ax.title, ax.xaxis.label, ax.yaxis.label, ax.get_legend().get_title(),
             *ax.get_legend().get_texts(), ax.texts[0], fig.texts[0]]
    for t in texts:
        assert _drawn(t) == (label, False), (t, t.get_text())
    tick = bx.xaxis.get_major_ticks()[0].label1
    fig.canvas.draw()
    assert _drawn(tick) == (label, False)
    plt.close(fig)


def test_escaping_twice_changes_nothing_and_number_ticks_stay_math():
    fig, ax = plt.subplots()
    ax.loglog([1e-3, 1e3], [1, 10])
    ax.set_title("a $b")
    plain_figure_text(fig)
    plain_figure_text(fig)
    assert ax.title.get_text() == escape_mathtext("a $b") == r"a \$b"
    fig.canvas.draw()
    ticks = [t for t in ax.xaxis.get_major_ticks() if t.label1.get_text()]
    assert ticks and all(_drawn(t.label1)[1] for t in ticks)  # 10^k of the log axis
    plt.close(fig)


def test_every_figure_of_the_report_package_goes_through_the_helper():
    """A figure builder lays itself out with finish_figure (which escapes first)."""
    root = Path(__file__).resolve().parents[2] / "src" / "inertest" / "report"
    for path in sorted(root.glob("*.py")):
        if path.name == "figure_text.py":
            continue
        src = path.read_text()
        assert "tight_layout(" not in src, f"{path.name}: use finish_figure(fig)"
        builders = len(re.findall(r"plt\.(?:subplots|figure)\(", src))
        helpers = len(re.findall(r"(?:finish_figure|plain_figure_text)\(fig\)", src))
        assert helpers >= builders, f"{path.name}: {builders} figures, {helpers} escaped"
