"""``manip export-ssp`` and ``manip validate-ssp``: the closed loop as an SSP 1.0 file (:mod:`closed_loop.ssp_loop`)."""

from __future__ import annotations

import argparse
import math
import re
import sys
from typing import Any

from .args import UsageError, controller_kind, finite_or_fail
from .formatting import format_table
from .outputs import out_file

__all__ = ["register", "parse_variant"]


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def parse_variant(text: str) -> Any:
    """``--variant NAME=VALUE[,NAME=VALUE...]`` (plant parameters, e.g. ``payload_mass=2``) as a
    :class:`~closed_loop.ssp_loop.LoopVariant` named by the text itself, every character but letters, digits and
    ``_.=+-`` made ``_`` (it names files in the SSP: ``viscous_friction[1]=0.01,payload_mass=1`` is
    ``viscous_friction_1_=0.01_payload_mass=1``)."""
    from closed_loop.ssp_loop import LoopVariant

    values: dict[str, float] = {}
    for item in text.replace(" ", "").split(","):
        name, sep, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not sep or not name or not math.isfinite(number):
            raise UsageError(f"--variant: expected NAME=VALUE[,NAME=VALUE...] with finite values, got {text!r}")
        if name in values:
            raise UsageError(f"--variant: {name!r} given twice in {text!r}")
        values[name] = number
    return LoopVariant(re.sub(r"[^A-Za-z0-9_.=+-]", "_", text.replace(" ", "")), values)


def _cmd_export(args: argparse.Namespace) -> int:
    from closed_loop.ssp_loop import LoopSpec, export_loop_ssp, loop_parts, variant_plant
    from model.robot import load_robot

    kind = controller_kind(args.controller)
    for flag, value in (("--bandwidth", args.bandwidth), ("--damping", args.damping),
                        ("--phase-margin", args.phase_margin), ("--rate", args.rate),
                        ("--segment-time", args.segment_time)):
        finite_or_fail(value, flag)
    target = out_file(args.output, "--output", create=False)
    if target.suffix != ".ssp":
        raise UsageError(f"--output: expected a file name ending in .ssp, got {args.output!r}")
    variants = tuple(parse_variant(v) for v in args.variant or ())
    robot = load_robot(args.robot)
    for v in variants:
        variant_plant(robot, v.values)  # an unknown parameter or a bad value: refused before the build
    spec = LoopSpec(kind=kind, bandwidth=args.bandwidth, damping=args.damping, phase_margin=args.phase_margin,
                    rate_hz=args.rate, task=args.task, segment_time=args.segment_time, variants=variants,
                    waypoints=args.waypoints, trajectory=args.trajectory)
    controller, trajectory = loop_parts(robot, spec)
    out_file(args.output, "--output")
    path = export_loop_ssp(robot, controller, trajectory, target, variants=variants, notes=spec, say=_say)
    print(f"wrote {path} ({kind} at {controller.rate_hz:g} Hz on {robot.name}; parameter sets: nominal"
          + "".join(f", {v.name}" for v in variants) + ")")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from closed_loop.ssp_loop import SSP_TOLERANCE, validate_loop_ssp

    checks = validate_loop_ssp(args.ssp, say=_say)
    rows = [[c.variant, c.importer, c.samples, f"{c.max_error:.3g}", f"{c.from_nominal:.3g}",
             "ok" if c.ok else "FAIL"] for c in checks]
    print(format_table(["parameter set", "importer", "instants", "max |q - compiled|", "max |q - nominal|", ""],
                       rows))
    ok = all(c.ok for c in checks)
    print(f"{'all runs within' if ok else 'some runs outside'} {SSP_TOLERANCE:g} of the compiled closed loop "
          "(rad or m, at every control instant)")
    return 0 if ok else 1


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``export-ssp`` and ``validate-ssp`` to the CLI's sub-command parsers."""
    p = subparsers.add_parser("export-ssp", help="export the closed loop (plant FMU, controller FMU with its "
                                                 "reference, parameter variants) as an SSP 1.0 file")
    p.add_argument("robot", help="built-in robot name or TOML file")
    p.add_argument("--controller", default="pd", metavar="KIND",
                   help="pd, pd-g, pd-ff, pid or ct (default pd)")
    p.add_argument("--bandwidth", type=float, default=None, metavar="RAD_S", help="closed-loop bandwidth, rad/s")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--damping", type=float, default=None, metavar="Z", help="damping ratio (default 0.7)")
    g.add_argument("--phase-margin", type=float, default=None, metavar="DEG", help="phase margin instead, deg")
    p.add_argument("--rate", type=float, default=None, metavar="HZ", help="control rate, Hz (default 1000)")
    src = p.add_mutually_exclusive_group()  # the reference options of manip track
    src.add_argument("--task", default=None, help="a [[tasks]] entry of the robot file or 'tour' (default: the "
                                                  "file's first task, else tour)")
    src.add_argument("--waypoints", default=None, metavar="FILE", help="TOML or CSV joint waypoint file")
    src.add_argument("--trajectory", default=None, metavar="FILE.csv",
                     help="trajectory file: time, q_<joint>.., qd_<joint>.., qdd_<joint>.. (manip retime, manip "
                          "excite); a copy goes into the SSP")
    p.add_argument("--segment-time", type=float, default=None, metavar="S", help="duration of every segment, s")
    p.add_argument("--variant", action="append", default=None, metavar="NAME=VALUE[,...]",
                   help="a plant parameter set besides the nominal one, e.g. payload_mass=2 (repeatable)")
    p.add_argument("-o", "--output", required=True, metavar="FILE.ssp", help="the SSP to write")
    p.set_defaults(func=_cmd_export)

    p = subparsers.add_parser("validate-ssp", help="run a closed-loop SSP in libcosim and FMPy, every parameter "
                                                   "set, and compare with the compiled closed loop")
    p.add_argument("ssp", help="the SSP written by manip export-ssp")
    p.set_defaults(func=_cmd_validate)
