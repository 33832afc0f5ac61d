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

An error about one parameter of a function names it in the field :attr:`WorkbenchError.parameter`
(the library's name, e.g. ``"link_mass_scale"``), not only in its text: ``str(error)`` is
``"link_mass_scale: expected a factor > 0, got 0.0"`` and :attr:`WorkbenchError.detail` the text
after the name, so that the command line can put the flag the user typed in its place
(``--mass-scale: expected ...``) without reading the message.

>>> err = InputError("expected a factor > 0, got 0.0", parameter="link_mass_scale")
>>> str(err), err.parameter, err.detail
('link_mass_scale: expected a factor > 0, got 0.0', 'link_mass_scale', 'expected a factor > 0, got 0.0')
"""

from __future__ import annotations

import difflib
from typing import Any, Iterable, Sequence

__all__ = ["InputError", "NumericalError", "SingularDynamicsError", "ToolchainError", "WorkbenchError", "closest",
           "did_you_mean"]


class WorkbenchError(Exception):
    """Base class of every expected error of the workbench; its message is one line for the user.

    Parameters
    ----------
    *args
        The message (what is wrong, the value, what was expected), as for any exception.
    parameter
        The parameter of the library call the error concerns (``"bandwidth"``), or None. When given,
        the message does not repeat it: ``str(error)`` puts it in front.
    """

    def __init__(self, *args: object, parameter: str | None = None) -> None:
        super().__init__(*args)
        self.parameter = parameter

    @property
    def detail(self) -> str:
        """The message without the parameter name in front (the whole message when there is none)."""
        return super().__str__()

    def __str__(self) -> str:
        parameter = getattr(self, "parameter", None)  # a subclass may skip this __init__
        return f"{parameter}: {self.detail}" if parameter else self.detail


class InputError(WorkbenchError, ValueError):
    """The input (file, field, argument) is invalid; the message names it, the value and what was expected.

    One error may carry several independent problems of the same input (every mistake of a
    robot file, as FMPy's validation reports every problem of an FMU): :attr:`problems` holds
    one complete one-line message per problem, and the message is a count line followed by
    them, one per line. Build such an error with :meth:`collected`.
    """

    def __init__(self, *args: object, problems: Sequence[str] = (), parameter: str | None = None) -> None:
        super().__init__(*args, parameter=parameter)
        self._problems = tuple(problems)

    @property
    def problems(self) -> tuple[str, ...]:
        """Every problem, one complete one-line message each; the message itself when there is one."""
        return getattr(self, "_problems", ()) or (str(self),)  # a subclass may skip this __init__

    @classmethod
    def collected(cls, problems: Sequence[str], where: str) -> "InputError":
        """One error for ``problems`` (at least one) of the input ``where``; a single problem is its own message."""
        problems = tuple(problems)
        if len(problems) == 1:
            return cls(problems[0], problems=problems)
        return cls("\n".join((f"{where}: {len(problems)} problems", *problems)), problems=problems)

    def __reduce__(self) -> tuple[Any, ...]:  # keep the problems through pickling (worker processes)
        return (_rebuild, (type(self), self.args, getattr(self, "_problems", ())), dict(self.__dict__))


class NumericalError(WorkbenchError, ArithmeticError):
    """A numerical computation failed (diverged, left finite numbers); not a fault of the input's form."""


class SingularDynamicsError(NumericalError):
    """The joint-space inertia matrix B(q) is singular at a configuration: the accelerations are undefined.

    Attributes
    ----------
    joint
        The 1-based joint the null direction of B moves most.
    q
        The configuration (n values), rad or m.
    """

    def __init__(self, message: str, joint: int = 0, q: Any = ()) -> None:
        super().__init__(message)
        self.joint = int(joint)
        self.q = tuple(float(v) for v in q)

    def __reduce__(self) -> tuple[Any, ...]:  # through pickling (sweep workers) with its fields
        return (type(self), (str(self), self.joint, self.q))


class ToolchainError(WorkbenchError, RuntimeError):
    """An external tool the workbench drives (C compiler, libcosim, FMU build) failed or is missing."""


def _rebuild(cls: type[InputError], args: tuple[object, ...], problems: tuple[str, ...]) -> InputError:
    return cls(*args, problems=problems) if problems else cls(*args)


def closest(word: str, known: Iterable[str]) -> str | None:
    """The entry of ``known`` most like ``word`` (a misspelt key: ``"alpah"`` -> ``"alpha"``), None if none is close.

    Close means a :class:`difflib.SequenceMatcher` ratio of at least 0.6 (difflib's default:
    one swapped or missing letter in a five-letter key is 0.8, an unrelated key is below 0.5).
    """
    found = difflib.get_close_matches(word, list(known), n=1)
    return found[0] if found else None


def did_you_mean(word: str, known: Iterable[str]) -> str:
    """``"; did you mean 'alpha'?"`` for the :func:`closest` entry of ``known``, or ``""`` if none is close."""
    guess = closest(word, known)
    return f"; did you mean {guess!r}?" if guess is not None else ""
