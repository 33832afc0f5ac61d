"""``manip export-urdf``: the model sub-command that writes a robot as URDF."""

from __future__ import annotations

import argparse

__all__ = ["register"]


def _cmd_export_urdf(args: argparse.Namespace) -> int:
    from .description import load_description
    from .urdf_export import export_urdf

    for path in export_urdf(load_description(args.robot), args.output, args.toml):
        print(f"wrote {path}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``export-urdf`` to the CLI's sub-command parsers."""
    p = subparsers.add_parser("export-urdf", help="write a robot as URDF (inertials, limits; Pinocchio reads it)")
    p.add_argument("robot", help="built-in name, TOML or URDF file")
    p.add_argument("-o", "--output", required=True, metavar="FILE.urdf", help="the URDF to write (atomically)")
    p.add_argument("--toml", metavar="FILE.toml",
                   help="also write a robot TOML pointing at the URDF with what URDF cannot hold (gravity, rest, motor data)")
    p.set_defaults(func=_cmd_export_urdf)
