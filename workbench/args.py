"""Command-line arguments shared by the sub-commands: the design specification and number checks.

Bad values raise :class:`UsageError` (or the control-design error naming the
flag); :func:`workbench.cli.main` prints them as one line, exit status 2.
control_design (python-control, matplotlib) is imported inside the functions,
so that commands that do not design start without it.
"""

from __future__ import annotations

import argparse
import math
import re
import socket

from model.errors import InputError, WorkbenchError

__all__ = ["ArgumentsError", "OneLineParser", "UsageError", "FLAG_OF", "add_no_plots", "add_spec_args", "bounded_int", "controller_kind", "finite_or_fail",
           "host_address", "in_flag_terms", "per_joint_flag", "positive_float", "scheduler_address"]

#: The library's parameter names (the ``parameter`` field of :class:`model.errors.WorkbenchError`) and the
#: flag a user of ``manip`` typed for each; :func:`in_flag_terms` applies it at the CLI boundary.
FLAG_OF: dict[str, str] = {
    "bandwidth": "--bandwidth",
    "damping": "--damping",
    "phase_margin": "--phase-margin",
    "rate": "--rate",
    "rate_hz": "--rate",
    "controller": "--controller",
    "kind": "--controller",
    "link_mass_scale": "--mass-scale",
    "friction_scale": "--friction-scale",
    "payload": "--payload",
    "payload_mass": "--payload",
    "segment_time": "--segment-time",
    "t_final": "the task's duration (--segment-time)",
    "t_end": "--horizon",
    "step": "--step",
    "motor_model": "--motor-model",
    "samples": "--samples",
    "seed": "--seed",
    "scheduler": "--scheduler",
}
_FLAG = re.compile(r"--([\w-]+)")


class UsageError(InputError):
    """Bad command-line input (a flag's value, an output path); printed as one line, exit status 2."""


class ArgumentsError(UsageError):
    """argparse refused the command line (an unknown flag, a value of the wrong type); ``prog`` is the command."""

    def __init__(self, message: str, prog: str = "manip") -> None:
        super().__init__(message)
        self.prog = prog


class OneLineParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose refusal is an :class:`ArgumentsError` (one line), not usage + exit."""

    def error(self, message: str):  # type: ignore[override]
        raise ArgumentsError(message, self.prog)


def controller_kind(value: str, extra: tuple[str, ...] = ()) -> str:
    """``value`` if it names a controller kind (or one of the command's ``extra`` kinds), else
    :class:`~control_design.errors.UnknownControllerError`."""
    from control_design.design import CONTROLLER_KINDS
    from control_design.errors import UnknownControllerError

    kinds = CONTROLLER_KINDS + tuple(extra)
    if value not in kinds:
        raise UnknownControllerError(f"--controller: expected one of {', '.join(kinds)}, got {value!r}")
    return value


def in_flag_terms(exc: WorkbenchError, args: argparse.Namespace) -> str:
    """The message of ``exc`` with the parameter it concerns named by the flag of the running command.

    ``exc.parameter`` is looked up in :data:`FLAG_OF`; only a flag that the running command has is put
    in (``args`` holds its options), so ``t_end`` from ``manip validate-fmu`` reads ``--horizon`` and a
    parameter no flag of the command sets keeps its library name (``str(exc)``).
    """
    flag = FLAG_OF.get(exc.parameter or "")
    option = None if flag is None else _FLAG.search(flag)
    if option is None or not hasattr(args, option.group(1).replace("-", "_")):
        return str(exc)
    return f"{flag}: {exc.detail}"


def finite_or_fail(value: float | None, flag: str, positive: bool = True) -> None:
    """Refuse a NaN, an infinity or (with ``positive``) a value <= 0 given to ``flag``; None passes."""
    from control_design.errors import DesignSpecError

    if value is None:
        return
    if not math.isfinite(value) or (positive and value <= 0):
        raise DesignSpecError(f"{flag}: expected a {'positive ' if positive else ''}finite number, got {value!r}")


def positive_float(text: str) -> float:
    """argparse type: a positive finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive finite step in s, got {text!r}")
    return value


def bounded_int(lo: int, hi: int, what: str):
    """argparse type: a whole number from ``lo`` to ``hi`` (``what`` names it in the message, e.g. "a port number")."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"expected {what} {lo}..{hi}, got {text!r}")
        return value

    return parse


def host_address(text: str) -> str:
    """argparse type: a host name or address this machine resolves (``127.0.0.1``, ``::1``, ``localhost``)."""
    if not text.strip() or any(c.isspace() or c == "\0" for c in text):
        raise argparse.ArgumentTypeError(f"expected a host name or address, got {text!r}")
    try:
        socket.getaddrinfo(text, None)
    except (OSError, UnicodeError, ValueError) as exc:  # socket.gaierror is an OSError
        raise argparse.ArgumentTypeError(f"{text!r} is not a host name or address this machine resolves "
                                         f"({getattr(exc, 'strerror', None) or exc})") from None
    return text


def scheduler_address(text: str) -> str:
    """argparse type: a Dask scheduler address, ``tcp://HOST:PORT`` (the protocol defaults to tcp), host resolved."""
    from distributed.comm.addressing import parse_address, parse_host_port

    expected = f"expected a scheduler address tcp://HOST:PORT, got {text!r}"
    if not text.strip() or any(c.isspace() or c == "\0" for c in text):
        raise argparse.ArgumentTypeError(expected)
    try:
        scheme, location = parse_address(text)
        host, port = parse_host_port(location, 8786) if scheme in ("tcp", "tls", "ws", "wss") else ("-", 1)
    except (ValueError, TypeError):
        raise argparse.ArgumentTypeError(expected) from None
    if not (host and 1 <= int(port) <= 65535):
        raise argparse.ArgumentTypeError(expected)
    if host != "-":
        host_address(host)  # its own message: the host does not resolve
    return text


def add_spec_args(p: argparse.ArgumentParser) -> None:
    """The robot and design-specification arguments of ``manip design`` and ``manip track``.

    The defaults are control_design's own, so this imports it (python-control):
    :func:`workbench.cli.build_parser` calls it only for the command being run or for help.
    """
    from control_design.decentralised import DEFAULT_BANDWIDTH
    from control_design.design import CONTROLLER_KINDS, DEFAULT_RATE_HZ

    kinds = "{" + ",".join(CONTROLLER_KINDS) + "}"
    p.add_argument("robot", help="built-in robot name or TOML file")
    p.add_argument("--controller", default="pd", metavar=kinds,
                   help="pd, pd-g (PD + gravity compensation), pid, pd-ff (PD + decoupled feed-forward), "
                        "ct (computed torque); default pd")
    p.add_argument("--bandwidth", type=float, default=DEFAULT_BANDWIDTH, metavar="RAD_S",
                   help=f"closed-loop bandwidth, rad/s (default {DEFAULT_BANDWIDTH:g})")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--damping", type=float, default=None, metavar="Z", help="damping ratio (default 0.7)")
    g.add_argument("--phase-margin", type=float, default=None, metavar="DEG", help="phase margin instead of the damping, deg")
    p.add_argument("--rate", type=float, default=DEFAULT_RATE_HZ, metavar="HZ",
                   help=f"control rate, Hz (default {DEFAULT_RATE_HZ:g}; must be >= 10 x bandwidth in Hz)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")


def add_no_plots(p: argparse.ArgumentParser) -> None:
    """``--no-plots``, for every command that draws: numbers and JSON only, no PNG or GIF (scripted runs)."""
    p.add_argument("--no-plots", action="store_true",
                   help="write no PNG or GIF (numbers and JSON only; drawing is most of a short run's time)")


def per_joint_flag(text: str | None, n: int, flag: str, unit: str) -> list[float] | None:
    """A flag's value ``"V"`` (every joint) or ``"V1,V2,...,Vn"`` as n positive numbers (``inf``: no limit), or None.

    ``--velocity-limit`` and ``--acceleration-limit`` of ``manip retime`` and ``manip excite``."""
    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise UsageError(f"{flag}: expected a number or {n} comma-separated numbers ({unit}), got {text!r}") from None
    if len(values) == 1:
        values *= n
    if len(values) != n:
        raise UsageError(f"{flag}: expected 1 or {n} values (one per joint), got {len(values)} in {text!r}")
    bad = [v for v in values if not v > 0.0]
    if bad:
        raise UsageError(f"{flag}: expected limits > 0 {unit} (inf for none), got {bad[0]!r}")
    return values
