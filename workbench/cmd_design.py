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

from .args import add_no_plots, add_spec_args, controller_kind, finite_or_fail
from .formatting import format_table
from .outputs import check_out_dir, out_dir, save_figure, write_json

if TYPE_CHECKING:
    from control_design.design import RobotDesign

__all__ = ["DESIGN_HEADER", "design_rows", "register", "run_design", "save_design_plots"]


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
    print(format_table(DESIGN_HEADER, design_rows(design)))
    lim = design.model.limits
    print(format_table(["motor", "joint", "tau_max [N m]", "limit from"],
                       [[k + 1, rep.name, float(lim.tau_m_max[k]), lim.provenance(k, detail=True)]
                        for k, rep in enumerate(design.reports)]))
    if args.no_plots:
        print(f"wrote {out / 'design.json'} (--no-plots: no PNG files)")
        return 0
    save_design_plots(design, out)
    print(f"wrote {out / 'design.json'} and {2 * robot.n} PNG files")
    return 0


#: Columns of :func:`design_rows` (``_d``: the sampled loop at the control rate, zero-order hold and delay).
DESIGN_HEADER = ("joint", "Kp", "Kd", "w_c [rad/s]", "PM [deg]", "PM_d [deg]", "GM_d [dB]", "w_bw [rad/s]",
                 "rise [s]", "OS [%]", "t_s [s]")


def design_rows(design: RobotDesign) -> list[list[object]]:
    """One row per joint (:data:`DESIGN_HEADER`): gains, crossover, margins, bandwidth and step metrics."""
    assert design.reports is not None
    rows: list[list[object]] = []
    for rep in design.reports:
        gm = rep.gain_margin_d
        rows.append([rep.name, rep.Kp_m, rep.Kd_m, rep.crossover, rep.phase_margin, rep.phase_margin_d,
                     20 * math.log10(gm) if math.isfinite(gm) else "inf", rep.bandwidth, rep.rise_time,
                     rep.overshoot, rep.settling_time])
    return rows


def register(subparsers: Any, full: bool = True) -> None:
    """Add the ``design`` sub-command to ``manip``'s sub-parsers (``full=False``: its name and help only)."""
    p = subparsers.add_parser("design", help="design joint loops (decentralised or computed torque): margins, Bode, steps")
    p.set_defaults(func=run_design)
    if full:
        add_spec_args(p)
        add_no_plots(p)
