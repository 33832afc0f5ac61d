"""``manip design`` and ``manip track``: joint-loop design and closed-loop tracking from the command line.

``manip design ROBOT --controller KIND [--bandwidth RAD_S] [--damping Z | --phase-margin DEG] [--rate HZ] --out DIR``
writes ``DIR/design.json`` (per joint: decoupled model, gains, crossover,
margins continuous and sampled, bandwidth, step metrics, coupling rejection;
torque limits and the rules used) and ``DIR/bode_<joint>.png``,
``DIR/step_<joint>.png``.

``manip track ROBOT --controller KIND [--task pick-and-place | --waypoints FILE] [--segment-time S] [--rate HZ]
[--payload KG] --out DIR`` simulates the closed loop on the nonlinear model and
writes ``DIR/metrics.json`` and ``DIR/tracking_error.png``, ``DIR/torques.png``,
``DIR/joints.png``; progress goes to stderr. With a plant/model mismatch
(``--payload``, ``--friction-scale``, ``--mass-scale``) the same controller also
runs on the exact plant and ``metrics.json`` reports both and their ratio.

Bad input raises a ``ValueError`` subclass; ``workbench.cli.main`` prints it as
one line and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from model.robot import load_robot

from .computed_torque import ModelMismatch, plant_with_mismatch
from .decentralised import DEFAULT_BANDWIDTH
from .design import CONTROLLER_KINDS, DEFAULT_RATE_HZ, RobotDesign, design_robot
from .errors import DesignSpecError, UnknownControllerError
from .plots import bode_plot, joint_plot, step_plot, torque_plot, tracking_error_plot
from .reference import check_trajectory_limits, task_trajectory
from .responses import bode_response, step_response
from .simulate import ProgressLine, TrackingResult, simulate_tracking

__all__ = ["register", "run_design", "run_track", "save_design_plots", "save_tracking_plots", "write_json"]

_KINDS_TEXT = "{" + ",".join(CONTROLLER_KINDS) + "}"


def _controller(value: str) -> str:
    if value not in CONTROLLER_KINDS:
        raise UnknownControllerError(f"--controller: expected one of {', '.join(CONTROLLER_KINDS)}, got {value!r}")
    return value


def _finite(value: float | None, flag: str, positive: bool = True) -> None:
    if value is None:
        return
    if not math.isfinite(value) or (positive and value <= 0):
        raise DesignSpecError(f"{flag}: expected a {'positive ' if positive else ''}finite number, got {value!r}")


def _out_dir(path: str) -> Path:
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise DesignSpecError(f"--out: expected a directory, got the file {str(out)!r}")
    out.mkdir(parents=True, exist_ok=True)
    return out


def _add_spec_args(p: argparse.ArgumentParser) -> None:
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


def save_tracking_plots(result: TrackingResult, out: Path, prefix: str = "") -> list[Path]:
    """Write ``{prefix}tracking_error.png``, ``{prefix}torques.png`` and ``{prefix}joints.png``."""
    paths = []
    for name, plot in (("tracking_error", tracking_error_plot), ("torques", torque_plot), ("joints", joint_plot)):
        fig = plot(result)
        paths.append(out / f"{prefix}{name}.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths


def run_design(args: argparse.Namespace) -> int:
    """``manip design``: design, analyse, write design.json and the Bode / step PNGs."""
    kind = _controller(args.controller)
    _finite(args.rate, "--rate")
    robot = load_robot(args.robot)
    design = design_robot(robot, kind, args.bandwidth, args.damping, phase_margin=args.phase_margin, rate_hz=args.rate)
    out = _out_dir(args.out)
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


def run_track(args: argparse.Namespace) -> int:
    """``manip track``: simulate the closed loop along a task, write metrics.json and plots."""
    kind = _controller(args.controller)
    _finite(args.rate, "--rate")
    _finite(args.segment_time, "--segment-time")
    if args.payload is not None and not (math.isfinite(args.payload) and args.payload >= 0):
        raise DesignSpecError(f"--payload: expected a mass >= 0 kg, got {args.payload!r}")
    robot = load_robot(args.robot)
    traj = task_trajectory(robot, args.task, args.waypoints, args.segment_time)
    check_trajectory_limits(robot, traj)
    design = design_robot(robot, kind, args.bandwidth, args.damping, phase_margin=args.phase_margin, rate_hz=args.rate,
                          analyse=False)
    mismatch = ModelMismatch(payload_mass=args.payload or 0.0, friction_scale=args.friction_scale,
                             link_mass_scale=args.mass_scale)
    plant = robot if mismatch.is_exact else plant_with_mismatch(robot, mismatch)
    controller = design.controller(args.rate, saturate=not args.no_saturation)
    result = simulate_tracking(plant, controller, traj, progress=ProgressLine("track", sys.stderr))
    met = result.metrics()
    out = _out_dir(args.out)
    data = met.to_dict()
    data.update({
        "task": str(args.waypoints) if args.waypoints else args.task, "duration_s": float(result.t[-1] - result.t[0]),
        "bandwidth_rad_s": args.bandwidth, "damping": design.damping, "phase_margin_deg": args.phase_margin,
        "plant": mismatch.describe(), "payload_kg": mismatch.payload_mass,
        "tau_m_max": None if result.tau_m_max is None else result.tau_m_max.tolist(), "substeps": result.substeps,
    })
    if not mismatch.is_exact:
        # The effect of the mismatch: the same controller on the exact plant, for comparison.
        nominal = simulate_tracking(robot, design.controller(args.rate, saturate=not args.no_saturation), traj,
                                    progress=ProgressLine("track (exact plant)", sys.stderr)).metrics()
        data["exact_plant"] = {"rms_error": nominal.rms_error.tolist(), "max_error": nominal.max_error.tolist(),
                               "peak_motor_torque": nominal.peak_motor_torque.tolist()}
        data["max_error_ratio"] = [float(a / b) if b > 0 else None for a, b in zip(met.max_error, nominal.max_error)]
    write_json(out / "metrics.json", data)
    save_tracking_plots(result, out)
    print(f"{robot.name}: {kind} at {args.rate:g} Hz, {mismatch.describe()}, {result.t[-1] - result.t[0]:g} s "
          f"simulated in {met.wall_time:.2f} s")
    print(f"{'joint':<10} {'unit':<4} {'RMS error':>11} {'max error':>11} {'peak tau_m':>11} {'peak qd_m':>10}")
    for j, name in enumerate(met.joints):
        print(f"{name:<10} {met.units[j]:<4} {met.rms_error[j]:>11.3e} {met.max_error[j]:>11.3e} "
              f"{met.peak_motor_torque[j]:>11.4g} {met.peak_motor_velocity[j]:>10.4g}")
    if "max_error_ratio" in data:
        ratios = ", ".join("-" if r is None else f"{r:.3g}" for r in data["max_error_ratio"])
        print(f"max error / max error on the exact plant: {ratios}")
    print(f"wrote {out / 'metrics.json'} and 3 PNG files")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``design`` and ``track`` sub-commands to ``manip``'s sub-parsers."""
    p = subparsers.add_parser("design", help="design joint loops (decentralised or computed torque): margins, Bode, steps")
    _add_spec_args(p)
    p.set_defaults(func=run_design)

    p = subparsers.add_parser("track", help="simulate closed-loop tracking of a task on the nonlinear model")
    _add_spec_args(p)
    src = p.add_mutually_exclusive_group()
    src.add_argument("--task", default="pick-and-place", help="built-in task (default pick-and-place)")
    src.add_argument("--waypoints", default=None, metavar="FILE", help="TOML or CSV joint waypoint file")
    p.add_argument("--segment-time", type=float, default=None, metavar="S", help="duration of every segment, s (default 3)")
    p.add_argument("--payload", type=float, default=None, metavar="KG",
                   help="payload on the simulated arm only (unknown to the controller), kg")
    p.add_argument("--friction-scale", type=float, default=1.0, metavar="X", help="plant friction = X times the model's")
    p.add_argument("--mass-scale", type=float, default=1.0, metavar="X", help="plant link masses = X times the model's")
    p.add_argument("--no-saturation", action="store_true", help="do not clip motor torques at their limits")
    p.set_defaults(func=run_track)
