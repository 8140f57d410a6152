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

#: (module, attribute) of each sub-command, in the order ``inertest --help`` lists them.
_COMMANDS: list[tuple[str, str]] = [
    ("inertest.cli.demo", "demo"),
    ("inertest.cli.procedure", "simulate"),
    ("inertest.cli.procedure", "fit"),
    ("inertest.cli.history", "history"),
    ("inertest.cli.modulation", "modulation"),
    ("inertest.cli.ins_errors", "ins_errors"),
    ("inertest.cli.gyro_calibration", "nav_simulate"),
    ("inertest.cli.gyro_calibration", "nav_calibrate"),
    ("inertest.cli.apply", "apply"),
    ("inertest.cli.thermal", "thermal"),
    ("inertest.cli.allan", "allan"),
    ("inertest.cli.centrifuge", "centrifuge_study"),
]

#: Exit status for errors in the user's input (as click uses for usage errors).
EXIT_INPUT_ERROR = 2


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="inertest")
def cli() -> None:
    """Test and calibrate inertial instruments: plan, simulate, fit, report.

    SI inside; every number printed carries its unit. See README.md for the conventions.
    """


for _module, _name in _COMMANDS:
    cli.add_command(getattr(importlib.import_module(_module), _name))


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
