"""``manip``: the workbench's command line.

Each package registers its own sub-commands (``register(subparsers)`` in its
``commands`` module); this module only assembles them and turns expected
errors into a one-line message and exit status 2 instead of a traceback.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

import model
from closed_loop.commands import register as register_closed_loop
from control_design.commands import register as register_control
from fmu.commands import register as register_fmu
from model.commands import register as register_model
from model.description import RobotDescriptionError, pose_matrix

__all__ = ["main", "build_parser", "UsageError"]


class UsageError(ValueError):
    """Bad command-line input; printed as one line, exit status 2."""


def _cmd_robots(args: argparse.Namespace) -> int:
    for name in model.BUILTIN_ROBOTS:
        desc = model.load_description(name)
        print(f"{name:<10} {desc.n} joints ({desc.joint_types:<6})  {desc.description}")
    return 0


def format_info(desc: model.RobotDescription) -> str:
    """The DH table (a URDF robot: joint origins and axes) with units, then inertial and motor data, as plain text."""
    deg = 180.0 / np.pi
    lines = [f"{desc.name}: {desc.description}", f"source: {desc.source}" if desc.source else "",
             f"gravity [m/s^2]: {list(desc.gravity)}", f"rest q: {desc.q_rest.tolist()}", ""]
    if desc.convention == "urdf":
        lines += ["URDF joints: origin of joint i in link frame i-1 (xyz, rpy = URDF <origin>), unit axis",
                  f"{'j':>2} {'type':<9} {'xyz [m]':>26} {'rpy [deg]':>24} {'axis':>22} {'qlim':>22}"]
    else:
        lines += [{"standard": "Standard DH, A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)",
                   "modified": "Modified DH, A_i = Rx(alpha) Tx(a) Rz(theta) Tz(d)"}[desc.convention]
                  + "; q adds to theta (R) or d (P)",
                  f"{'j':>2} {'type':<9} {'a [m]':>9} {'alpha [deg]':>11} {'d [m]':>9} {'theta [deg]':>11} {'qlim':>22}"]
    for i, lk in enumerate(desc.links, 1):
        if lk.qlim is None:
            lim = "-"
        elif lk.is_revolute:
            lim = f"[{lk.qlim[0] * deg:.1f}, {lk.qlim[1] * deg:.1f}] deg"
        else:
            lim = f"[{lk.qlim[0]:.3f}, {lk.qlim[1]:.3f}] m"
        if desc.convention == "urdf":
            T = pose_matrix(lk.origin)
            xyz, rpy = T[:3, 3], Rotation.from_matrix(T[:3, :3]).as_euler("xyz") * deg  # R = Rz(y) Ry(p) Rx(r)
            row = [", ".join(f"{v:.{k}f}" for v in np.round(vec, k) + 0.0) for vec, k in ((xyz, 4), (rpy, 2), (lk.axis, 4))]
            lines.append(f"{i:>2} {lk.joint:<9} {'[' + row[0] + ']':>26} {'[' + row[1] + ']':>24} {'[' + row[2] + ']':>22} {lim:>22}")
            continue
        lines.append(f"{i:>2} {lk.joint:<9} {lk.a:>9.4f} {lk.alpha * deg:>11.2f} {lk.d:>9.4f} {lk.theta * deg:>11.2f} {lim:>22}")
    lines += ["", "Inertial data (centre of mass and inertia in frame i, inertia about the centre of mass)",
              f"{'j':>2} {'m [kg]':>8} {'com [m]':>26} {'[Ixx Iyy Izz Ixy Iyz Ixz] [kg m^2]':>44}"]
    for i, lk in enumerate(desc.links, 1):
        com = "[" + ", ".join(f"{c:.4g}" for c in lk.com) + "]"
        inertia = "[" + ", ".join(f"{c:.4g}" for c in lk.inertia) + "]"
        lines.append(f"{i:>2} {lk.mass:>8.4g} {com:>26} {inertia:>44}")
    lines += ["", "Motor data (motor side; motor angle = G q)",
              f"{'j':>2} {'Jm [kg m^2]':>12} {'G':>10} {'B [N m s/rad]':>14} {'Tc+ [N m]':>10} {'Tc- [N m]':>10} {'G^2 Jm':>10}"]
    for i, lk in enumerate(desc.links, 1):
        lines.append(f"{i:>2} {lk.motor_inertia:>12.4g} {lk.gear_ratio:>10.6g} {lk.viscous_friction:>14.4g} "
                     f"{lk.coulomb_friction[0]:>10.4g} {lk.coulomb_friction[1]:>10.4g} {lk.gear_ratio ** 2 * lk.motor_inertia:>10.4g}")
    return "\n".join(line for line in lines)


def _cmd_info(args: argparse.Namespace) -> int:
    print(format_info(model.load_description(args.robot)))
    return 0


def format_build(info) -> str:
    """One line per stage of a :class:`model.codegen.BuildInfo`."""
    if info.cached:
        return f"loaded from the cache in {info.seconds_total:.3f} s: {info.library}"
    levels = " ".join(sorted({u.optimisation for u in info.units}))
    return (f"cold build in {info.seconds_total:.2f} s (symbolic {info.seconds_symbolic:.2f} s, C generation "
            f"{info.seconds_generate:.2f} s, {info.c_bytes / 1e6:.2f} MB; {info.compiler} {' '.join(info.flags)} "
            f"{levels} {info.seconds_compile:.2f} s): {info.library}")


def _cmd_build(args: argparse.Namespace) -> int:
    robot = model.load_robot(args.robot, motor_model=args.motor_model)
    info = robot.dynamics.compile(force=args.force, progress=lambda event: print(f"manip build: {event}", file=sys.stderr, flush=True))
    print(f"{robot.name} ({args.motor_model} motors): {format_build(info)}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from .demo import run_demo  # heavy: FMU export, simulations, plots

    if not (args.bandwidth > 0 and args.rate > 0):
        raise UsageError(f"--bandwidth and --rate: expected positive numbers, got {args.bandwidth!r} and {args.rate!r}")
    result = run_demo(args.robot, args.out, bandwidth=args.bandwidth, rate_hz=args.rate, gif=not args.no_gif)
    return 0 if result.fmu_ok else 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="manip", description="Model, control and export robot manipulators.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("robots", help="list the built-in robots")
    p.set_defaults(func=_cmd_robots)
    p = sub.add_parser("info", help="print a robot's DH table, inertial and motor data")
    p.add_argument("robot", help="built-in name or TOML file")
    p.set_defaults(func=_cmd_info)
    p = sub.add_parser("build", help="generate, compile and cache a robot's dynamics C; report the build time")
    p.add_argument("robot", help="built-in name or TOML file")
    p.add_argument("--motor-model", choices=("reflected", "full"), default="reflected", help="default reflected")
    p.add_argument("--force", action="store_true", help="generate and compile again even when the cache has it")
    p.set_defaults(func=_cmd_build)
    register_model(sub)
    register_control(sub)
    register_closed_loop(sub)
    register_fmu(sub)
    p = sub.add_parser("demo", help="the whole workbench end to end on one robot: design, FMU, closed loop, report")
    p.add_argument("--robot", default="scara", help="built-in name or TOML file (default scara)")
    p.add_argument("--out", default="out", help="output folder (default out/)")
    p.add_argument("--bandwidth", type=float, default=50.0, metavar="RAD_S", help="loop bandwidth (default 50 rad/s)")
    p.add_argument("--rate", type=float, default=1000.0, metavar="HZ", help="control rate (default 1000 Hz)")
    p.add_argument("--no-gif", action="store_true", help="skip the animation (its slowest step)")
    p.set_defaults(func=_cmd_demo)
    return parser


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"manip: warning: {message}\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``manip`` console command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    previous = warnings.formatwarning
    warnings.formatwarning = _one_line_warning
    try:
        return int(args.func(args) or 0)
    except (UsageError, RobotDescriptionError, ValueError, FileNotFoundError) as exc:
        print(f"manip {args.command}: error: {exc}", file=sys.stderr)
        return 2
    finally:
        warnings.formatwarning = previous


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
