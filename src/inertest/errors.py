"""Exceptions raised by inertest.

Every error a user can cause (a bad plan, a bad data file, a test that cannot determine what was
asked) is an :class:`InertestError`. Its message names the problem, what was received and how to
fix it; the command line prints the message and exits non-zero without a traceback.
"""

from __future__ import annotations

import errno
import os


class InertestError(Exception):
    """Base class of the errors that a user's input can cause."""


class InputError(InertestError, ValueError):
    """A parameter, plan entry or data column has a value that cannot be used."""


class UnitError(InputError):
    """A unit string is not known, or does not fit the quantity."""


class PlanError(InputError):
    """A test plan is incomplete or inconsistent."""


class DataError(InputError):
    """A data file is missing columns, has NaN, or does not match the plan."""


class OutputPathError(InputError):
    """An output path would overwrite or delete something inertest did not write, or an input."""


class IdentifiabilityError(InertestError, ValueError):
    """The data cannot determine anything that was asked for (e.g. too few positions)."""


class InertestWarning(UserWarning):
    """Something in the input is usable but not as the procedure recommends (e.g. spacing)."""


#: What the name of every temporary inertest writes beside an output contains
#: (:func:`inertest.io.atomic.target_file`): a message names the output's folder instead.
TEMP_MARK = ".inertest-tmp-"


def os_error_message(exc: OSError) -> tuple[str, bool]:
    """One line naming the problem and the fix for an OSError; True when the machine failed.

    False means the user's path is at fault (missing, a folder, no permission); True a full
    disk, a read-only file system or an I/O error. The command line and the batch's per-run
    errors print the same line.
    """
    where = exc.filename if exc.filename is not None else ""
    if exc.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", -1)):
        what = "disk full" if exc.errno == errno.ENOSPC else "disk quota exceeded"
        return (f"{what} at {where or 'the output'}: nothing was written; free space or choose "
                "another output folder", True)
    if TEMP_MARK in str(where):  # our temporary beside an output: name its folder
        where = os.path.dirname(str(where)) or "."
    if isinstance(exc, PermissionError):
        return (f"cannot write in or read {where!s}: permission denied; choose another "
                "output folder or fix its permissions", False)
    if isinstance(exc, IsADirectoryError):
        return f"{where!s} is a folder; give a file path", False
    if isinstance(exc, NotADirectoryError):
        return (f"cannot use {where!s}: a part of that path is a file, not a folder (or a "
                "link to nothing); give a path whose folders exist", False)
    if isinstance(exc, FileExistsError):
        return (f"cannot use {where!s}: a file of that name is in the way of a folder; give "
                "another path", False)
    if isinstance(exc, FileNotFoundError):
        return f"{where!s} does not exist; check the path", False
    if exc.errno == errno.EROFS:
        return f"cannot write {where}: read-only file system; choose another output folder", True
    reason = exc.strerror or str(exc) or type(exc).__name__
    return f"input/output error{' at ' + str(where) if where else ''}: {reason}", True


def error_message(exc: InertestError | OSError) -> str:
    """The one-line message of an error a user or the machine caused (see above)."""
    return os_error_message(exc)[0] if isinstance(exc, OSError) else str(exc)


class MissingExtraError(InertestError, ImportError):
    """An optional part of inertest is used whose packages are not installed."""


#: Optional packages -> the extra of ``pip install 'inertest[EXTRA]'`` that installs them.
EXTRAS: dict[str, str] = {
    "rosbags": "ros",
    "pyulog": "px4",
    "nptdms": "tdms",
    "h5py": "hdf5",
    "psycopg": "postgres",
    "sklearn": "neural",
    "sympy": "symbolic",
    "pandas": "pandas",
}


def import_extra(module: str, what: str) -> object:
    """Import an optional package, or raise :class:`MissingExtraError` naming the install.

    Parameters
    ----------
    module : str
        The package (a key of :data:`EXTRAS`, or a sub-module of one).
    what : str
        What needs it, for the message (``"reading ROS bags"``).
    """
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        top = module.split(".")[0]
        extra = EXTRAS.get(top)
        hint = (f"pip install 'inertest[{extra}]'" if extra is not None
                else f"pip install {top}")
        raise MissingExtraError(f"{what} needs the package {top!r}, which is not installed: "
                                f"{hint}") from None
