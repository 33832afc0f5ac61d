"""The workbench's expected errors: one base class, split by cause.

Every error the workbench raises on purpose (a bad robot file, an impossible
design request, a diverged simulation, a missing C compiler) subclasses
:class:`WorkbenchError`; the command line prints these as one line with exit
status 2. Anything else is a bug and keeps its traceback.

Each class also subclasses the builtin that says what went wrong, so callers
may catch ``ValueError`` for bad input as before:

* :class:`InputError` (``ValueError``): the user's input is invalid.
* :class:`NumericalError` (``ArithmeticError``): a computation left finite numbers.
* :class:`ToolchainError` (``RuntimeError``): an external tool (compiler, libcosim) failed.
"""

from __future__ import annotations

__all__ = ["InputError", "NumericalError", "ToolchainError", "WorkbenchError"]


class WorkbenchError(Exception):
    """Base class of every expected error of the workbench; its message is one line for the user."""


class InputError(WorkbenchError, ValueError):
    """The input (file, field, argument) is invalid; the message names it, the value and what was expected."""


class NumericalError(WorkbenchError, ArithmeticError):
    """A numerical computation failed (diverged, left finite numbers); not a fault of the input's form."""


class ToolchainError(WorkbenchError, RuntimeError):
    """An external tool the workbench drives (C compiler, libcosim, FMU build) failed or is missing."""
