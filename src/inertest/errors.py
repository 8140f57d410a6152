"""Exceptions raised by inertest.

Every error a user can cause (a bad plan, a bad data file, a test that cannot determine what was
asked) is an :class:`InertestError`. Its message names the problem, what was received and how to
fix it; the command line prints the message and exits non-zero without a traceback.
"""

from __future__ import annotations


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
