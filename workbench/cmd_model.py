"""``manip robots``, ``info``, ``build`` and ``export-urdf``: the model sub-commands.

``robots`` and ``info`` read descriptions only; the compiled dynamics and the
URDF writer are imported inside the commands that use them.
"""

from __future__ import annotations

import argparse
import sys

from .outputs import out_file

__all__ = ["register"]


def _cmd_robots(args: argparse.Namespace) -> int:
    from model.description import BUILTIN_ROBOTS
    from model.loading import load_description

    from .formatting import format_table

    names = list(BUILTIN_ROBOTS)
    if args.all:  # the example-robot-data arms too; without the robots extra one line says how to get them
        from model.example_robots import collection_dir, erd_names

        collection_dir()
        names += erd_names()
    rows = []
    for name in names:
        desc = load_description(name)
        rows.append([name, desc.n, desc.joint_types, desc.description])
    print(format_table(["robot", "joints", "types", "description"], rows))
    return 0


def _cmd_info(args: argparse.Namespace) -> int:
    from model.loading import load_description

    from .formatting import format_info

    print(format_info(load_description(args.robot)))
    return 0


def _cmd_build(args: argparse.Namespace) -> int:
    from model.robot import load_robot

    from .formatting import format_build

    robot = load_robot(args.robot, motor_model=args.motor_model)
    info = robot.dynamics.compile(force=args.force, progress=lambda event: print(f"manip build: {event}", file=sys.stderr, flush=True))
    print(f"{robot.name} ({args.motor_model} motors): {format_build(info)}")
    print(f"{robot.name}: {robot.dynamics.functions.formulations}")
    return 0


def _cmd_export_urdf(args: argparse.Namespace) -> int:
    from model.loading import load_description
    from model.urdf_export import export_urdf

    out_file(args.output, "--output")
    if args.toml is not None:
        out_file(args.toml, "--toml")
    for path in export_urdf(load_description(args.robot), args.output, args.toml):
        print(f"wrote {path}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``robots``, ``info``, ``build`` and ``export-urdf`` to the CLI's sub-command parsers."""
    p = subparsers.add_parser("robots", help="list the built-in robots (--all: and the example-robot-data arms)")
    p.add_argument("--all", action="store_true",
                   help="also the arms of the example-robot-data collection (erd:NAME; the robots extra)")
    p.set_defaults(func=_cmd_robots)
    p = subparsers.add_parser("info", help="print a robot's DH table, inertial and motor data")
    p.add_argument("robot", help="built-in name, erd:NAME (manip robots --all), TOML or URDF file")
    p.set_defaults(func=_cmd_info)
    p = subparsers.add_parser("build", help="generate, compile and cache a robot's dynamics C; report the build time")
    p.add_argument("robot", help="built-in name or TOML file")
    p.add_argument("--motor-model", choices=("reflected", "full"), default="reflected", help="default reflected")
    p.add_argument("--force", action="store_true", help="generate and compile again even when the cache has it")
    p.set_defaults(func=_cmd_build)
    p = subparsers.add_parser("export-urdf", help="write a robot as URDF (inertials, limits; Pinocchio reads it)")
    p.add_argument("robot", help="built-in name, TOML or URDF file")
    p.add_argument("-o", "--output", required=True, metavar="FILE.urdf", help="the URDF to write (atomically)")
    p.add_argument("--toml", metavar="FILE.toml",
                   help="also write a robot TOML pointing at the URDF with what URDF cannot hold (gravity, rest, motor data)")
    p.set_defaults(func=_cmd_export_urdf)
