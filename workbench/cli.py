"""``manip``: the workbench's command line.

The sub-commands live in ``workbench/cmd_*.py`` (``register(subparsers)`` each);
this module assembles them and owns the outcome: an expected error
(:class:`model.errors.WorkbenchError`) is printed as one line with exit status
2 (an input error with several problems as a count line and one line per
problem), the library parameter it concerns (its ``parameter`` field) named by
the flag the user typed (:data:`workbench.args.FLAG_OF`); a value argparse
refuses as one line too (exit status 2); Ctrl-C as one line with exit status
130; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from typing import Sequence

from model.errors import InputError, WorkbenchError
from model.version import __version__

from . import cmd_design, cmd_fmu, cmd_model, cmd_sweep, cmd_track
from . import cmd_teach, cmd_workspace  # teach page and workspace figure
from . import cmd_identify  # excitation and identification
from . import cmd_retime  # time-optimal retiming
from . import cmd_ssp  # the closed loop as an SSP
from .args import ArgumentsError, OneLineParser, UsageError, add_no_plots, in_flag_terms
from .outputs import check_out_dir

__all__ = ["main", "build_parser", "one_line", "error_lines", "UsageError", "EXIT_USAGE", "EXIT_INTERRUPTED", "EXIT_BROKEN_PIPE",
           "MAX_PROBLEM_LINES"]

#: Exit status of an expected error (bad input, failed build): argparse's own.
EXIT_USAGE = 2
#: Exit status after Ctrl-C (128 + SIGINT), as a shell reports it.
EXIT_INTERRUPTED = 130
#: Exit status when the reader of stdout went away (128 + SIGPIPE), as a shell reports it.
EXIT_BROKEN_PIPE = 141
#: Most problems of one error printed, one line each (a robot file of 32 links can hold hundreds).
MAX_PROBLEM_LINES = 50


def _cmd_demo(args: argparse.Namespace) -> int:
    if not (args.bandwidth > 0 and args.rate > 0):
        raise UsageError(f"--bandwidth and --rate: expected positive numbers, got {args.bandwidth!r} and {args.rate!r}")
    check_out_dir(args.out)
    from .demo import run_demo  # heavy: FMU export, simulations, plots

    result = run_demo(args.robot, args.out, bandwidth=args.bandwidth, rate_hz=args.rate, gif=not args.no_gif,
                      plots=not args.no_plots)
    return 0 if result.fmu_ok else 1


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``manip`` parser; with ``only`` a command name, the other commands get their name and help only.

    The design arguments read control_design's defaults (python-control); ``only``
    keeps ``manip robots`` and ``manip info`` from importing it.
    """
    parser = OneLineParser(prog="manip", description="Model, control and export robot manipulators.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    cmd_model.register(sub)
    cmd_design.register(sub, full=only in (None, "design"))
    cmd_track.register(sub, full=only in (None, "track"))
    cmd_fmu.register(sub)
    cmd_ssp.register(sub)
    cmd_teach.register(sub)
    cmd_workspace.register(sub)
    cmd_sweep.register(sub, full=only in (None, "sweep"))
    cmd_retime.register(sub)
    cmd_identify.register(sub)
    p = sub.add_parser("demo", help="the whole workbench end to end on one robot: design, FMU, closed loop, report")
    p.add_argument("--robot", default="scara", help="built-in name or TOML file (default scara)")
    p.add_argument("--out", default="out", help="output folder (default out/)")
    p.add_argument("--bandwidth", type=float, default=50.0, metavar="RAD_S", help="loop bandwidth (default 50 rad/s)")
    p.add_argument("--rate", type=float, default=1000.0, metavar="HZ", help="control rate (default 1000 Hz)")
    p.add_argument("--no-gif", action="store_true", help="skip the animation (its slowest step)")
    add_no_plots(p)
    p.set_defaults(func=_cmd_demo)
    return parser


def one_line(exc: BaseException, limit: int = 400) -> str:
    """The message of ``exc`` on one line: its first line and the first line of any detail that follows.

    A failed compile carries the command and the compiler's output on later lines;
    the first diagnostic is kept, the rest is dropped.
    """
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    if not lines:
        return type(exc).__name__
    text = lines[0].rstrip(":")
    if len(lines) > 1:
        text += f": {lines[1]}"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def error_lines(exc: WorkbenchError, args: argparse.Namespace | None = None) -> list[str]:
    """The lines an expected error prints: :func:`one_line` of it, or with several problems
    (:attr:`model.errors.InputError.problems`) a count line and one complete line per problem.

    With ``args`` (the running command's options), the parameter the error concerns
    (:attr:`~model.errors.WorkbenchError.parameter`) is named by the flag the user typed
    (:func:`~workbench.args.in_flag_terms`).
    """
    text = in_flag_terms(exc, args) if args is not None else str(exc)
    if not isinstance(exc, InputError):
        return [one_line(Exception(text))]
    # an input error is one line per problem, each a whole message: a longer limit keeps the list of
    # known keys and the "did you mean" after it (the default limit is for compiler output)
    problems, limit = exc.problems, 1000
    if len(problems) == 1:
        return [one_line(Exception(text), limit)]
    lines = [one_line(Exception(str(exc).splitlines()[0]), limit)]
    lines += [one_line(Exception(p), limit) for p in problems[:MAX_PROBLEM_LINES]]
    if len(problems) > MAX_PROBLEM_LINES:
        lines.append(f"... and {len(problems) - MAX_PROBLEM_LINES} more problems")
    return lines


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"manip: warning: {message}\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``manip`` console command; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if not a.startswith("-")), "")  # none: `manip --help` lists the commands only
    try:
        args = build_parser(only=command).parse_args(argv)
    except ArgumentsError as exc:  # argparse's refusal, as one line (its usage is behind --help)
        print(f"{exc.prog}: error: {exc.detail} (see {exc.prog} --help)", file=sys.stderr)
        return EXIT_USAGE
    previous = warnings.formatwarning
    warnings.formatwarning = _one_line_warning
    try:
        return int(args.func(args) or 0)
    except WorkbenchError as exc:
        for line in error_lines(exc, args):
            print(f"manip {args.command}: error: {line}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"manip {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `manip info ur5 | head`: the reader left; stop quietly, as other Unix tools do
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python's final flush of stdout must not raise again
        return EXIT_BROKEN_PIPE
    finally:
        warnings.formatwarning = previous


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
