"""``manip workspace``: the reachable workspace of a robot's tool point as a figure, from the command line.

``manip workspace ROBOT -o ws.png [--samples N] [--seed S]`` samples the joint
space within the limits (:mod:`model.workspace`), prints the radius and
height ranges, and writes the figure (3-D samples, top view x-y, side view r-z
with their envelopes) atomically. The output path is checked before the work.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from .args import bounded_int
from .outputs import out_file, save_figure

__all__ = ["register", "run_workspace"]


def run_workspace(args: argparse.Namespace) -> int:
    """``manip workspace``: sample, summarise, draw."""
    from model.robot import load_robot
    from model.workspace import reachable_workspace

    from .workspace import workspace_figure, workspace_summary

    target = out_file(args.output, "--output", create=False)
    robot = load_robot(args.robot)
    print(f"manip workspace: sampling {args.samples} joint vectors of {robot.name}", file=sys.stderr, flush=True)
    ws = reachable_workspace(robot, samples=args.samples, seed=args.seed)
    out_file(target, "--output")
    save_figure(workspace_figure(ws, robot), target)
    for line in workspace_summary(ws):
        print(f"{robot.name}: {line}")
    print(f"wrote {target}")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``workspace`` sub-command to ``manip``'s sub-parsers."""
    p = subparsers.add_parser("workspace", help="the reachable workspace of the tool point: figure with its sections")
    p.add_argument("robot", help="built-in name, TOML or URDF file")
    p.add_argument("-o", "--output", required=True, metavar="FILE.png", help="the figure to write (PNG, atomically)")
    p.add_argument("--samples", type=bounded_int(100, 5_000_000, "a number of samples"), default=200_000, metavar="N", help="joint samples (default 200000)")
    p.add_argument("--seed", type=bounded_int(0, 2**63 - 1, "a seed"), default=0, metavar="S",
                   help="random seed, a whole number >= 0 (default 0)")
    p.set_defaults(func=run_workspace)
