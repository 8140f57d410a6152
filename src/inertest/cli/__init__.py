"""The ``inertest`` command line: parse, call the library, print. No numerics here.

Each sub-command lives in its own module of this package and is registered in
:data:`_COMMANDS`. Errors a user can cause (:class:`inertest.errors.InertestError`, unreadable
files, bad options) print one clear line to stderr and give a non-zero exit status, no traceback.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

import click

from inertest.errors import InertestError

#: name: (module, attribute, one-line help) of each sub-command, in the order of the docs. The
#: module is imported only when its command runs (or its own --help is asked), so that
#: ``inertest --help`` and every command start without loading plotting, databases, numba or
#: scikit-learn.
_COMMANDS: dict[str, tuple[str, str, str]] = {
    "demo": ("inertest.cli.demo", "demo", "Simulate, fit and report the example campaign."),
    "simulate": ("inertest.cli.procedure", "simulate",
                 "Simulate the test in PLAN on a virtual instrument."),
    "fit": ("inertest.cli.procedure", "fit",
            "Identify the coefficients of the test in PLAN from DATA; report and store."),
    "batch": ("inertest.cli.batch", "batch",
              "Fit, report and store many (plan, data) pairs listed in a manifest."),
    "history": ("inertest.cli.history", "history",
                "An instrument's coefficients over its stored runs."),
    "modulation": ("inertest.cli.modulation", "modulation",
                   "Rotation modulation of drift: a gyro's stator or a whole IMU."),
    "ins-errors": ("inertest.cli.ins_errors", "ins_errors",
                   "Error propagation of a local-level INS on a static base."),
    "nav-simulate": ("inertest.cli.gyro_calibration", "nav_simulate",
                     "Simulate navigation-mode turns of a gyro triad."),
    "nav-calibrate": ("inertest.cli.gyro_calibration", "nav_calibrate",
                      "Refine a gyro-triad calibration by navigating through turns."),
    "apply": ("inertest.cli.apply", "apply", "Apply a triad calibration to a raw recording."),
    "thermal": ("inertest.cli.thermal", "thermal",
                "Scale factor and bias against temperature: fit and simulate."),
    "allan": ("inertest.cli.allan", "allan",
              "Allan-family deviations and IEEE 952 noise terms of a recording."),
    "centrifuge-study": ("inertest.cli.centrifuge", "centrifuge_study",
                         "What the centrifuge's machine errors cost the nine-position test."),
}

#: Exit status for errors in the user's input (as click uses for usage errors).
EXIT_INPUT_ERROR = 2


class _LazyGroup(click.Group):
    """A group whose sub-commands are imported on first use (fast start-up and --help)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(_COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        entry = _COMMANDS.get(cmd_name)
        if entry is None:
            return None
        module, attr, _ = entry
        return getattr(importlib.import_module(module), attr)  # type: ignore[no-any-return]

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, short) for name, (_, _, short) in _COMMANDS.items()]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="inertest")
def cli() -> None:
    """Test and calibrate inertial instruments: plan, simulate, fit, report.

    SI inside; every number printed carries its unit. See README.md for the conventions.
    """


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``) and return the exit status."""
    try:
        cli.main(args=list(argv) if argv is not None else None, standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.Abort:
        click.echo("aborted", err=True)
        return 1
    except click.ClickException as exc:
        exc.show()
        return int(exc.exit_code)
    except InertestError as exc:
        click.echo(f"error: {exc}", err=True)
        return EXIT_INPUT_ERROR
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        where = getattr(exc, "filename", None) or ""
        click.echo(f"error: cannot use file {where!s}: {exc.strerror or exc}", err=True)
        return EXIT_INPUT_ERROR
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
