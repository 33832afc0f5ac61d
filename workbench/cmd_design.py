"""``manip design``: joint-loop design from the command line.

``manip design ROBOT --controller KIND [--bandwidth RAD_S] [--damping Z | --phase-margin DEG] [--rate HZ] --out DIR``
writes ``DIR/design.json`` (per joint: decoupled model, gains, crossover,
margins continuous and sampled, bandwidth, step metrics, coupling rejection;
torque limits and the rules used) and ``DIR/bode_<joint>.png``,
``DIR/step_<joint>.png``. ``--out`` is checked before the design starts.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .args import add_spec_args, controller_kind, finite_or_fail
from .outputs import check_out_dir, out_dir, save_figure, write_json

if TYPE_CHECKING:
    from control_design.design import RobotDesign

__all__ = ["register", "run_design", "save_design_plots"]


def save_design_plots(design: RobotDesign, out: Path, prefix: str = "") -> list[Path]:
    """Write ``{prefix}bode_<joint>.png`` and ``{prefix}step_<joint>.png`` (continuous and sampled loop) per joint."""
    from control_design.plots import bode_plot, step_plot
    from control_design.responses import bode_response, step_response

    assert design.reports is not None
    paths = []
    for loop, rep in zip(design.loops, design.reports):
        name = rep.name.replace("/", "_")
        title = f"{design.robot.name} {name}: {design.kind}, {design.bandwidth:g} rad/s"
        for kind, fig in (("bode", bode_plot([bode_response(loop), bode_response(loop, discrete=True)], title)),
                          ("step", step_plot([step_response(loop), step_response(loop, discrete=True)], title))):
            paths.append(save_figure(fig, out / f"{prefix}{kind}_{name}.png"))
    return paths


def run_design(args: argparse.Namespace) -> int:
    """``manip design``: design, analyse, write design.json and the Bode / step PNGs."""
    from control_design.design import design_robot
    from model.robot import load_robot

    kind = controller_kind(args.controller)
    finite_or_fail(args.rate, "--rate")
    check_out_dir(args.out)
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


def register(subparsers: Any, full: bool = True) -> None:
    """Add the ``design`` sub-command to ``manip``'s sub-parsers (``full=False``: its name and help only)."""
    p = subparsers.add_parser("design", help="design joint loops (decentralised or computed torque): margins, Bode, steps")
    p.set_defaults(func=run_design)
    if full:
        add_spec_args(p)
