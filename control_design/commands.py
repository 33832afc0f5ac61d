"""``manip design``: joint-loop design from the command line (``manip track`` is :mod:`closed_loop.commands`).

``manip design ROBOT --controller KIND [--bandwidth RAD_S] [--damping Z | --phase-margin DEG] [--rate HZ] --out DIR``
writes ``DIR/design.json`` (per joint: decoupled model, gains, crossover,
margins continuous and sampled, bandwidth, step metrics, coupling rejection;
torque limits and the rules used) and ``DIR/bode_<joint>.png``,
``DIR/step_<joint>.png``.

Bad input raises a ``ValueError`` subclass; ``workbench.cli.main`` prints it as
one line and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from model.robot import load_robot

from .decentralised import DEFAULT_BANDWIDTH
from .design import CONTROLLER_KINDS, DEFAULT_RATE_HZ, RobotDesign, design_robot
from .errors import DesignSpecError, UnknownControllerError
from .plots import bode_plot, step_plot
from .responses import bode_response, step_response

__all__ = ["add_spec_args", "controller_kind", "finite_or_fail", "out_dir", "register", "run_design", "save_design_plots", "write_json"]

_KINDS_TEXT = "{" + ",".join(CONTROLLER_KINDS) + "}"


def controller_kind(value: str) -> str:
    if value not in CONTROLLER_KINDS:
        raise UnknownControllerError(f"--controller: expected one of {', '.join(CONTROLLER_KINDS)}, got {value!r}")
    return value


def finite_or_fail(value: float | None, flag: str, positive: bool = True) -> None:
    if value is None:
        return
    if not math.isfinite(value) or (positive and value <= 0):
        raise DesignSpecError(f"{flag}: expected a {'positive ' if positive else ''}finite number, got {value!r}")


def out_dir(path: str) -> Path:
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise DesignSpecError(f"--out: expected a directory, got the file {str(out)!r}")
    out.mkdir(parents=True, exist_ok=True)
    return out


def add_spec_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("robot", help="built-in robot name or TOML file")
    p.add_argument("--controller", default="pd", metavar=_KINDS_TEXT,
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


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` as indented JSON; NaN or infinity is refused (not valid JSON)."""
    path.write_text(json.dumps(data, indent=2, allow_nan=False) + "\n")


def save_design_plots(design: RobotDesign, out: Path, prefix: str = "") -> list[Path]:
    """Write ``{prefix}bode_<joint>.png`` and ``{prefix}step_<joint>.png`` (continuous and sampled loop) per joint."""
    assert design.reports is not None
    paths = []
    for loop, rep in zip(design.loops, design.reports):
        name = rep.name.replace("/", "_")
        title = f"{design.robot.name} {name}: {design.kind}, {design.bandwidth:g} rad/s"
        for kind, fig in (("bode", bode_plot([bode_response(loop), bode_response(loop, discrete=True)], title)),
                          ("step", step_plot([step_response(loop), step_response(loop, discrete=True)], title))):
            paths.append(out / f"{prefix}{kind}_{name}.png")
            fig.savefig(paths[-1], dpi=110)
            plt.close(fig)
    return paths


def run_design(args: argparse.Namespace) -> int:
    """``manip design``: design, analyse, write design.json and the Bode / step PNGs."""
    kind = controller_kind(args.controller)
    finite_or_fail(args.rate, "--rate")
    robot = load_robot(args.robot)
    design = design_robot(robot, kind, args.bandwidth, args.damping, phase_margin=args.phase_margin, rate_hz=args.rate)
    out = out_dir(args.out)
    write_json(out / "design.json", design.to_dict())
    assert design.reports is not None
    print(f"{robot.name}: {kind} at {args.bandwidth:g} rad/s, {args.rate:g} Hz "
          f"({'computed-torque outer loops, 1/s^2 and 1/s' if kind == 'ct' else 'motor-side gains, N m/rad and N m s/rad'})")
    print(f"{'joint':<10} {'Kp':>11} {'Kd':>11} {'w_c':>8} {'PM':>6} {'PM_d':>6} {'GM_d dB':>8} {'w_bw':>7} {'OS %':>6} {'t_s':>7}")
    for rep in design.reports:
        gm_db = 20 * math.log10(rep.gain_margin_d) if math.isfinite(rep.gain_margin_d) else math.inf
        print(f"{rep.name:<10} {rep.Kp_m:>11.4g} {rep.Kd_m:>11.4g} {rep.crossover:>8.2f} {rep.phase_margin:>6.1f} "
              f"{rep.phase_margin_d:>6.1f} {gm_db:>8.1f} {rep.bandwidth:>7.2f} {rep.overshoot:>6.1f} {rep.settling_time:>7.4f}")
    save_design_plots(design, out)
    print(f"wrote {out / 'design.json'} and {2 * robot.n} PNG files")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``design`` sub-command to ``manip``'s sub-parsers."""
    p = subparsers.add_parser("design", help="design joint loops (decentralised or computed torque): margins, Bode, steps")
    add_spec_args(p)
    p.set_defaults(func=run_design)
