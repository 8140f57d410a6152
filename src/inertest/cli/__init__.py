"""The ``inertest`` command line: parse, call the library, print. No numerics here.

Each sub-command lives in its own module of this package and is registered in
:data:`_COMMANDS`. Errors a user can cause (:class:`inertest.errors.InertestError`, unreadable
files, a full disk, bad options) print one clear line to stderr and give a non-zero exit status,
no traceback. Anything else (a bug) prints one line and the path of a log file holding the
traceback. Database URLs in every message have their password masked, and control characters
(terminal escape codes from a file or a serial) are shown escaped, never sent to the terminal.
"""

from __future__ import annotations

import importlib
import os
import re
import signal
import sys
import tempfile
import time
import traceback
from collections.abc import Sequence
from pathlib import Path

import click

from inertest.errors import InertestError, os_error_message

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
    "campaign": ("inertest.cli.campaign", "campaign",
                 "Run an acceptance campaign: every test of one unit, judged clause by clause."),
    "lot": ("inertest.cli.lot", "lot",
            "Lot statistics of many units: spread, capability, units that stand out."),
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
    "noise": ("inertest.cli.noise", "noise",
              "Noise of every IMU channel: Allan, PSD, IEEE 952 terms, Kalibr imu.yaml."),
    "centrifuge-study": ("inertest.cli.centrifuge", "centrifuge_study",
                         "What the centrifuge's machine errors cost the nine-position test."),
    "plan-check": ("inertest.cli.plan_check", "plan_check",
                   "Can PLAN verify a specification? Predicted U per limit, before testing."),
}

#: Commands that read one table and fit it: numpy's transparent-huge-page advice is turned off
#: for them (``NUMPY_MADVISE_HUGEPAGE=0`` unless the user set it). Their large arrays are
#: allocated once and written once, so the advice buys no TLB reuse, and zeroing fresh 2 MiB
#: pages cost 37 % of the CPU time of a 1e7-row fit on a virtual machine (5.2 -> 4.0 s,
#: benchmarks/bench_fit_csv.py). The Allan commands keep it: their windows reuse freed pages.
_ONE_PASS_COMMANDS = frozenset({"fit", "batch"})

#: Exit status for errors in the user's input (as click uses for usage errors).
EXIT_INPUT_ERROR = 2
#: Exit status for a failure of the machine (full disk, I/O error) rather than of the input.
EXIT_SYSTEM_ERROR = 74  # EX_IOERR of sysexits.h
#: Exit status for a bug in inertest (an unexpected exception; details in the log file).
EXIT_INTERNAL_ERROR = 70  # EX_SOFTWARE of sysexits.h

#: ``scheme://user:password@`` in a URL: the password is replaced by ``***`` in every message.
_URL_PASSWORD = re.compile(r"([A-Za-z][A-Za-z0-9+.\-]*://[^\s:/@]*:)([^\s@/]+)(@)")
#: Control characters other than tab (ESC starts terminal escape sequences).
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


def mask_secrets(text: str) -> str:
    """``text`` with the password of every ``scheme://user:password@host`` URL masked."""
    return _URL_PASSWORD.sub(r"\1***\3", text)


def safe_line(text: str) -> str:
    """One line for the terminal: passwords masked, control characters and newlines escaped."""
    text = mask_secrets(str(text)).replace("\r\n", " ").replace("\n", " ")
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", text)


def _oserror_line(exc: OSError) -> tuple[str, int]:
    """One line naming the problem and the fix for an OSError, and the exit status."""
    line, system = os_error_message(exc)
    return line, EXIT_SYSTEM_ERROR if system else EXIT_INPUT_ERROR


def _log_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "inertest" / "logs"


def write_crash_log(exc: BaseException, argv: Sequence[str] | None) -> Path | None:
    """Write the traceback of an unexpected exception to a log file; return its path."""
    from importlib import metadata

    try:
        version = metadata.version("inertest")
    except metadata.PackageNotFoundError:  # pragma: no cover
        version = "unknown"
    text = (f"inertest {version}, python {sys.version.split()[0]}\n"
            f"argv: {mask_secrets(repr(list(argv) if argv is not None else sys.argv[1:]))}\n\n"
            + mask_secrets("".join(traceback.format_exception(exc))))
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for folder in (_log_dir(), Path(tempfile.gettempdir())):
        try:
            folder.mkdir(parents=True, exist_ok=True)
            fd, name = tempfile.mkstemp(prefix=f"inertest-crash-{stamp}-", suffix=".log",
                                        dir=folder)
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            return Path(name)
        except OSError:
            continue
    return None


def _error(text: str) -> None:
    click.echo(f"error: {safe_line(text)}", err=True)


def _terminate(signum: int, _frame: object) -> None:
    # SIGTERM/SIGHUP unwind like Ctrl-C, so that temporary files and folders are removed.
    raise KeyboardInterrupt


class _LazyGroup(click.Group):
    """A group whose sub-commands are imported on first use (fast start-up and --help)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(_COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        entry = _COMMANDS.get(cmd_name)
        if entry is None:
            return None
        module, attr, _ = entry
        if cmd_name in _ONE_PASS_COMMANDS:  # read by numpy when it is first imported
            os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
        command = getattr(importlib.import_module(module), attr)
        from inertest.cli._common import (  # after this package is ready
            add_identity_options,
            add_overwrite_option,
        )

        add_overwrite_option(command)
        add_identity_options(command)
        return command

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
    """Run the command line with ``argv`` (default ``sys.argv[1:]``) and return the exit status.

    Never raises: every failure is one line on stderr and a non-zero status (2 bad input,
    74 full disk or I/O error, 70 a bug in inertest with the traceback in a log file, 130
    interrupted, 1 a batch with failed runs).
    """
    previous = {}
    if argv is None:  # the real command line: a kill unwinds (temporary files are removed)
        for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
            if sig is not None:
                try:
                    previous[sig] = signal.signal(sig, _terminate)
                except ValueError:  # pragma: no cover - not the main thread
                    pass
    try:
        args = list(argv) if argv is not None else sys.argv[1:]
        cli.main(args=args, standalone_mode=False, obj={"argv": args})
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except (click.Abort, KeyboardInterrupt):
        click.echo("aborted; nothing half-written is left (a batch keeps the runs it had "
                   "filed, each whole)", err=True)
        return 130
    except click.ClickException as exc:
        click.echo(f"error: {safe_line(exc.format_message())}" if not isinstance(
            exc, click.UsageError) else _usage_line(exc), err=True)
        return int(exc.exit_code)
    except InertestError as exc:  # in the command line's words where they differ (options)
        _error(getattr(exc, "cli_message", None) or str(exc))
        return EXIT_INPUT_ERROR
    except OSError as exc:
        line, status = _oserror_line(exc)
        _error(line)
        return status
    except MemoryError:
        command = next((a for a in args if not a.startswith("-")), "") if args else ""
        if command in ("simulate", "plan-check", "nav-simulate", "demo"):
            # the plan asks for the samples: the advice on records does not apply
            _error("out of memory: the plan asks for more samples than this machine holds; "
                   "lower its counts (samples_per_position, duration_s, sample_rate_hz, "
                   "positions, runs)")
        else:
            _error("out of memory; analyse a shorter record or a raw binary file "
                   "(.f32/.f64), which is read in chunks")
        return EXIT_SYSTEM_ERROR
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except Exception as exc:  # a bug: one line, the details in a log file
        log = write_crash_log(exc, argv)
        where = f"; details in {log}" if log is not None else ""
        _error(f"internal error ({type(exc).__name__}: {safe_line(str(exc))[:200]}){where}. "
               "Please report it with that file")
        return EXIT_INTERNAL_ERROR
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0


def _usage_line(exc: click.UsageError) -> str:
    hint = ""
    if exc.ctx is not None:
        hint = f" (see '{exc.ctx.command_path} --help')"
    return f"error: {safe_line(exc.format_message())}{hint}"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
