"""Small pieces shared by the sub-commands: JSON output, console tables, figures, paths."""

from __future__ import annotations

import contextlib
import json
import math
import os
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from inertest.cli import safe_line
from inertest.errors import InputError, OutputPathError
from inertest.io.atomic import check_outputs, target_file

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from rich.console import Console


def echo_json(obj: object) -> None:
    """Print ``obj`` as one JSON document on stdout."""
    click.echo(json.dumps(obj, indent=2, allow_nan=False))


def print_table(title: str, header: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """Print a table on the terminal; never cut a number, whatever the terminal's width.

    The first column is left-aligned, the rest right. Headers may wrap at spaces, cells never:
    when the cells do not fit the width (``$COLUMNS``; 200 when output is piped), the table is
    printed as key/value lines instead (``row name`` then ``  column: value``), so every number
    stays whole.
    """
    # Control characters (terminal escape codes from a serial or a data label) are shown escaped.
    hdr = [safe_line(str(h)) for h in header]
    cells = [[safe_line(str(v)) for v in r] for r in rows]
    console = _console()
    widths = [max([len(c[i]) for c in cells if i < len(c)]
                  + [max((len(w) for w in h.split()), default=0)])
              for i, h in enumerate(hdr)]
    if sum(widths) + 3 * len(widths) + 1 > console.width:
        _print_stacked(title, hdr, cells)
        return
    from rich.markup import escape
    from rich.table import Table

    # Columns as wide as their widest cell; spare width goes to headers that would wrap.
    spare = console.width - (sum(widths) + 3 * len(widths) + 1)
    for i, h in enumerate(hdr):
        extra = min(max(len(h) - widths[i], 0), spare)
        widths[i] += extra
        spare -= extra
    # Escape rich markup: units such as "[deg/h]" would otherwise be read as style tags.
    table = Table(title=escape(safe_line(title)), title_justify="left")
    for i, h in enumerate(hdr):
        table.add_column(escape(h), justify="left" if i == 0 else "right", width=widths[i],
                         overflow="fold")
    for r in cells:
        table.add_row(*(escape(v) for v in r))
    console.print(table)


def _console() -> Console:
    """A console as wide as ``$COLUMNS`` or the terminal; 200 columns for piped output."""
    from rich.console import Console  # rich loads only when a table is printed

    console = Console(soft_wrap=True)
    if not console.is_terminal and not os.environ.get("COLUMNS", "").isdigit():
        console = Console(soft_wrap=True, width=200)
    return console


def _print_stacked(title: str, header: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """A table too wide for the terminal as key/value lines: every value whole on its line."""
    click.echo(safe_line(title))
    if len(header) == 2:  # an item/value table: one "item: value" line each
        for r in rows:
            click.echo(f"  {': '.join(r[:2])}")
        return
    for r in rows:
        click.echo(f"- {r[0]}" if r else "-")
        for h, v in zip(header[1:], r[1:], strict=False):
            click.echo(f"    {h}: {v}")


def print_identity(doc: Mapping[str, Any], *, warn: bool = True) -> None:
    """Who, what, when, where and with what (the envelope's identity), then equipment warnings.

    ``warn=False`` when the overdue calibrations were already printed (``inertest fit``).
    """
    from inertest.report.identity import (
        EQUIPMENT_HEADER,
        equipment_rows,
        equipment_warnings,
        identity_rows,
    )

    print_table("identity of the test", ["item", "value"], identity_rows(doc))
    eq = equipment_rows(doc)
    if eq:
        print_table("equipment used", EQUIPMENT_HEADER, eq)
    for w in equipment_warnings(doc) if warn else ():
        click.echo(f"warning: {safe_line(w)}", err=True)


class FiniteFloat(click.types.FloatParamType):
    """A number option that refuses NaN and infinity (``--sigma nan``, ``-k inf``).

    Python's ``float()`` reads ``nan``, ``inf`` and ``1e999``; none is a usable setting, and
    a NaN compares false with every bound (``-k nan`` switched the outlier flags off). Every
    number option of the command line has this type or :class:`FiniteFloatRange`.
    """

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> float:
        rv = float(super().convert(value, param, ctx))
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number; give a number such as 2.5", param,
                      ctx)
        return rv


class FiniteFloatRange(click.FloatRange):
    """:class:`click.FloatRange` that refuses NaN and infinity first (NaN passes any bound)."""

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> float:
        return float(super().convert(REAL.convert(value, param, ctx), param, ctx))


#: The type of every number option (``type=REAL``).
REAL = FiniteFloat()


def parse_float_list(text: str, *, name: str, count: int | None = None) -> list[float]:
    """Parse ``"1,2,3"`` into finite floats; raise a click error naming ``name`` if malformed."""
    try:
        values = [float(t) for t in text.split(",") if t.strip() != ""]
    except ValueError:
        raise click.BadParameter(
            f"expected comma-separated numbers, got {text!r}", param_hint=name
        ) from None
    if not all(math.isfinite(v) for v in values):
        raise click.BadParameter(
            f"expected finite numbers, got {text!r}; give numbers such as 0.5,1", param_hint=name)
    if count is not None and len(values) != count:
        raise click.BadParameter(
            f"expected {count} comma-separated numbers, got {len(values)} in {text!r}",
            param_hint=name,
        )
    return values


#: Figure formats by file suffix (``--plot``).
FIGURE_FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}


def figure_format(path: Path | None, option: str = "--plot") -> str | None:
    """The figure format of ``path`` by suffix; a clear error before any work if unknown."""
    if path is None:
        return None
    fmt = FIGURE_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise InputError(f"{option} {path}: unknown figure format {path.suffix or '(none)'!r}; "
                         "name it .png, .svg or .pdf")
    return fmt


def save_figure(fig: Figure, path: Path, *, dpi: int = 110, fmt: str | None = None) -> None:
    """Write ``fig`` to ``path`` (format by suffix, or ``fmt``) atomically and close it.

    Its texts are drawn as written (:func:`inertest.report.figure_text.plain_figure_text`).
    """
    import matplotlib.pyplot as plt

    from inertest.report.figure_text import plain_figure_text

    fmt = fmt or figure_format(path)
    try:
        plain_figure_text(fig)
        with target_file(path) as tmp:
            fig.savefig(tmp, format=fmt, dpi=dpi, bbox_inches="tight")
    finally:
        plt.close(fig)


_OVERWRITE = "inertest.overwrite"


def _remember_overwrite(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    ctx.meta[_OVERWRITE] = bool(value)


def add_overwrite_option(command: click.Command) -> None:
    """Give ``command`` (and a group's sub-commands) the ``--overwrite`` flag, once."""
    if isinstance(command, click.Group):
        for sub in command.commands.values():
            add_overwrite_option(sub)
        return
    if any(p.name == "overwrite" for p in command.params):
        return
    command.params.append(click.Option(
        ["--overwrite"], is_flag=True, expose_value=False, callback=_remember_overwrite,
        help="Replace output files that already exist (refused otherwise)."))


def check_paths(outputs: Iterable[Path | None], inputs: Iterable[Path | None]) -> None:
    """Refuse, before any work, an output that is an input (or holds one), or two equal outputs.

    Symlinks are resolved (:func:`inertest.io.atomic.check_outputs`). An output FILE that
    already exists is the user's until proven otherwise: it is replaced only with
    ``--overwrite``. (Report folders are checked by their manifest instead.)
    """
    outs = [o for o in outputs if o is not None]
    check_outputs(outs, [i for i in inputs if i is not None])
    ctx = click.get_current_context(silent=True)
    overwrite = bool(ctx is not None and ctx.meta.get(_OVERWRITE))
    for o in outs:
        if (o.is_symlink() or o.is_file()) and not overwrite:
            raise OutputPathError(f"output {o} already exists; give a new path, or --overwrite "
                                  "to replace it")
    seen: dict[Path, Path] = {}
    for o in outs:
        key = o.resolve()
        if key in seen:
            raise OutputPathError(f"two outputs are the same file {o}; give each its own path")
        seen[key] = o


_IDENTITY = "inertest.identity"
#: The identity options every analysis report has (``--serial``, ``--site``, ``--operator``).
IDENTITY_OPTIONS = (
    ("serial", "Serial number of the instrument whose data these are (in the report)."),
    ("site", "Where the data were recorded, e.g. 'Lab 2, 48.15 N' (in the report)."),
    ("operator", "Who recorded or analysed the data (in the report: performed by)."),
)


def _remember_identity(ctx: click.Context, param: click.Parameter, value: str | None) -> None:
    if value is not None and param.name is not None:
        ctx.meta.setdefault(_IDENTITY, {})[param.name.removeprefix("id_")] = value


def add_identity_options(command: click.Command) -> None:
    """Give a report-writing analysis command ``--serial``, ``--site`` and ``--operator``, once.

    Only commands with a ``--report`` and without a plan (whose ``[instrument]`` and ``[test]``
    state the identity) get them; an option the command has already is left alone. The values
    go to :func:`input_identity`.
    """
    if isinstance(command, click.Group):
        for sub in command.commands.values():
            add_identity_options(sub)
        return
    names = {p.name for p in command.params}
    if not names & {"report", "report_dir"} or names & {"plan", "examples_dir", "manifest"}:
        return  # a plan (or the demo's or a campaign's plans) states the identity
    for name, doc in IDENTITY_OPTIONS:
        if name in names or f"id_{name}" in names:
            continue
        command.params.append(click.Option(
            [f"--{name}", f"id_{name}"], default=None, expose_value=False,
            callback=_remember_identity, help=doc))


def command_line() -> str:
    """The command as typed (``inertest allan data.npy --rate 50 ...``), for the report.

    From the arguments :func:`inertest.cli.main` was given; rebuilt from the parsed options
    when the command runs some other way.
    """
    import shlex

    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return "inertest"
    obj = ctx.find_root().obj
    if isinstance(obj, Mapping) and obj.get("argv") is not None:
        return shlex.join(["inertest", *map(str, obj["argv"])])
    words = [ctx.command_path]
    for prm in ctx.command.params:
        if prm.name is None:
            continue
        v = ctx.params.get(prm.name)
        if isinstance(prm, click.Argument):
            words += [str(x) for x in (v if isinstance(v, tuple) else (v,)) if x is not None]
            continue
        if not isinstance(prm, click.Option) or v is None or v is False or v == prm.default \
                or v == ():
            continue
        flag = max(prm.opts, key=len)
        words += [flag] if v is True else [flag, *map(str, v if isinstance(v, tuple) else (v,))]
    return shlex.join(words)


def input_identity(
    files: Iterable[str | os.PathLike[str] | None] = (), *, source: str | None = None,
    serial: str | None = None, test: Mapping[str, Any] | None = None,
    site: str | None = None, operator: str | None = None,
) -> list[list[str]]:
    """Identity rows of an analysis page: enough to reproduce it and to know whose it is.

    Each input file by the path given and its SHA-256 (or ``source`` for an input that is not
    a file: ``"simulated, seed 3"``, ``"built-in example"``), the exact command
    (:func:`command_line`) and the working folder it ran in, and the serial, site and operator
    (``--serial``, ``--site``, ``--operator``; or ``serial``, ``site``, ``operator`` and the
    ``test`` block from a plan or a stored run; "not stated" otherwise,
    :func:`inertest.report.html.page`).
    """
    from inertest.io.data_file import file_sha256
    from inertest.report.identity import test_date_text

    rows: list[list[str]] = []
    for f in files:
        if f is None:
            continue
        p = Path(f)
        rows += [["input file", str(p)], [f"SHA-256 of {p.name}", file_sha256(p)]]
    if source:
        rows.append(["input", source])
    rows.append(["command", command_line()])
    rows.append(["working folder", str(Path.cwd())])
    ctx = click.get_current_context(silent=True)
    given = dict(ctx.meta.get(_IDENTITY, {})) if ctx is not None else {}
    for key, value in (("serial", serial), ("site", site), ("operator", operator)):
        if value:
            given.setdefault(key, str(value))
    if test:
        if test.get("operator"):
            given.setdefault("operator", str(test["operator"]))
        rows.append(["test date", test_date_text(test)])
        if test.get("filed_at"):
            rows.append(["filed at (UTC)", str(test["filed_at"]).replace("T", " ")[:19]])
    rows += [[k, given[k]] for k, _ in IDENTITY_OPTIONS if given.get(k)]
    return rows


#: A DATA argument: a data file, or a ROS 2 bag folder (one holding metadata.yaml).
DATA_PATH = click.Path(exists=True, path_type=Path)


def recording_options(f: Any) -> Any:
    """``--topic`` and ``--layout``, the options of a DATA argument that is a recording."""
    f = click.option(
        "--layout", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
        help="TOML layout of a binary record (size, field offsets, types, scales, units).")(f)
    return click.option(
        "--topic", default=None,
        help="ROS topic, PX4 ULog message (name or name:N) or TDMS group (default: the IMU "
             "topic, found by its type, or the only one).")(f)


@contextlib.contextmanager
def progress_bar(label: str) -> Iterator[Callable[[str, int, int | None], None]]:
    """A progress bar on stderr (terminals only): yields ``tick(stage, done, total)``.

    Nothing is drawn until a stage has taken a second, so short runs print nothing extra.
    """
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeRemainingColumn,
    )

    console = Console(stderr=True)
    tasks: dict[str, Any] = {}
    with Progress(TextColumn(f"{label}: {{task.description}}"), BarColumn(),
                  TaskProgressColumn(), TimeRemainingColumn(), console=console,
                  transient=True, disable=not console.is_terminal) as bar:

        def tick(stage: str, done: int, total: int | None) -> None:
            if stage not in tasks:
                tasks[stage] = bar.add_task(stage, total=total)
            bar.update(tasks[stage], completed=done, total=total)

        yield tick
