"""``manip excite`` and ``manip identify``: an excitation trajectory for a robot, and its parameters from a log.

``manip excite ROBOT -o excite.csv`` optimises a Fourier-series excitation
(:mod:`model.identification.excitation`) and writes it as a joint table (``time, q_*, qd_*, qdd_*``,
:mod:`model.joint_table`; ``manip track --trajectory`` reads it) and, unless ``--no-plots``, a figure of
it against its limits beside it (``excite.png``).

``manip identify ROBOT DATA.csv --out DIR`` reads a log ``time, q_<joint>..., [qd_<joint>...],
tau_<joint>...`` (joint names as the robot file has them, joint-side torques, SI units), prepares it
(:mod:`model.identification.signals`), fits it (:mod:`model.identification.identify`) and writes
``DIR/identified.toml`` (a robot file every command takes; a URDF robot also gets ``identified.urdf``),
``DIR/identification.json`` and the plots ``holdout_torques.png`` and ``residual_spectrum.png``. The
console says what was done: the sampling, the cut-off and where it comes from, the samples and equations
used, the condition number and each fit's errors.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any, Sequence

from .args import UsageError, add_no_plots, per_joint_flag
from .formatting import format_table
from .outputs import check_out_dir, out_dir, out_file, save_figure, write_json

__all__ = ["register", "run_excite", "run_identify", "write_identification"]

def _say(command: str):
    return lambda line: print(f"manip {command}: {line}", file=sys.stderr, flush=True)


def _warn(command: str, line: str) -> None:
    print(f"manip {command}: warning: {line}", file=sys.stderr, flush=True)


def run_excite(args: argparse.Namespace) -> int:
    """``manip excite``: optimise an excitation trajectory and write it as a joint-table CSV."""
    from model.identification import Regressor, base_parameters, excitation_limits, optimise_excitation
    from model.joint_table import write_joint_table
    from model.robot import load_robot

    if not (math.isfinite(args.period) and args.period > 0):
        raise UsageError(f"--period: expected a positive number of seconds, got {args.period!r}")
    if not 1 <= args.harmonics <= 50:
        raise UsageError(f"--harmonics: expected a whole number from 1 to 50, got {args.harmonics!r}")
    if args.periods < 1:
        raise UsageError(f"--periods: expected a whole number >= 1, got {args.periods!r}")
    if not (math.isfinite(args.rate) and args.rate > 0) or args.rate * args.period * args.periods > 5_000_000:
        raise UsageError(f"--rate: expected a positive rate giving at most 5,000,000 samples, got {args.rate!r}")
    if not (math.isfinite(args.torque_margin) and 0 < args.torque_margin <= 1):
        raise UsageError(f"--torque-margin: expected a fraction in (0, 1], got {args.torque_margin!r}")
    if args.seed < 0:
        raise UsageError(f"--seed: expected a whole number >= 0, got {args.seed!r}")
    if args.max_iter < 1:
        raise UsageError(f"--max-iter: expected a whole number >= 1, got {args.max_iter!r}")
    path = out_file(args.output, "--output", create=False)
    robot = load_robot(args.robot)
    desc = robot.description
    qd_max = per_joint_flag(args.velocity_limit, desc.n, "--velocity-limit", "rad/s or m/s")
    qdd_max = per_joint_flag(args.acceleration_limit, desc.n, "--acceleration-limit", "rad/s^2 or m/s^2")
    limits = excitation_limits(desc, qd_max, qdd_max, args.torque_margin)
    for note in limits.notes:
        _warn("excite", f"{note} (set --velocity-limit / --acceleration-limit, or the robot file's velocity_limit / acceleration_limit)")
    say = _say("excite")
    reg = Regressor(desc)
    reg.compile(progress=say)
    base = base_parameters(reg)
    say(f"{base.n_base} base parameters; optimising {args.harmonics} harmonics per joint over {args.period:g} s "
        f"with IPOPT (at most {args.max_iter} iterations)")
    result = optimise_excitation(robot, period=args.period, harmonics=args.harmonics, limits=limits,
                                 max_iter=args.max_iter, seed=args.seed, regressor=reg, base=base, progress=say)
    for note in result.notes:
        _warn("excite", note)
    t, q, qd, qdd = result.trajectory.sample(args.rate, args.periods)
    out_file(args.output, "--output")
    write_joint_table(path, t, {"q": q, "qd": qd, "qdd": qdd}, desc.joint_names)
    print(f"{desc.name}: {base.n_base} base parameters; {args.harmonics} harmonics per joint, period {args.period:g} s")
    print(f"condition number of the base regressor: {result.initial_condition_number:.4g} at the start -> "
          f"{result.condition_number:.4g} (IPOPT {result.status}, {result.iterations} iterations, {result.seconds:.1f} s)")
    rows = _excitation_rows(robot, result, q, qd, qdd)
    print(format_table(["joint", "q min", "q max", "box min", "box max", "|qd| max", "limit", "|qdd| max", "limit",
                        "|tau| max", "limit"], rows))
    files = [str(path)]
    if not args.no_plots:
        from .identify_plots import excitation_plot

        png = save_figure(excitation_plot(result, desc.joint_names, [lk.is_revolute for lk in desc.links]),
                          path.with_suffix(".png"))
        files.append(str(png))
    periods = "1 period" if args.periods == 1 else f"{args.periods} periods"
    print(f"wrote {', '.join(files)} ({t.size} samples at {args.rate:g} Hz, {periods} of {args.period:g} s, "
          "starting and ending at rest)")
    return 0


def _excitation_rows(robot: Any, result: Any, q, qd, qdd) -> list[list[Any]]:
    import numpy as np

    desc, lim = robot.description, result.limits
    tau = np.abs(robot.rne_batch(q, qd, qdd)).max(axis=0)
    rows = []
    for j, name in enumerate(desc.joint_names):
        rows.append([name, float(q[:, j].min()), float(q[:, j].max()), float(lim.q_min[j]), float(lim.q_max[j]),
                     float(np.abs(qd[:, j]).max()), float(lim.qd_max[j]), float(np.abs(qdd[:, j]).max()),
                     float(lim.qdd_max[j]), float(tau[j]), float(lim.tau_max[j]) if math.isfinite(lim.tau_max[j]) else "-"])
    return rows


def run_identify(args: argparse.Namespace) -> int:
    """``manip identify``: fit a robot's parameters to a log; write identified.toml, identification.json, plots."""
    from model.identification import Regressor, base_parameters
    from model.identification.identify import identify_log
    from model.joint_table import read_joint_table
    from model.robot import load_robot

    if args.cutoff is not None and not (math.isfinite(args.cutoff) and args.cutoff > 0):
        raise UsageError(f"--cutoff: expected a positive frequency in Hz, got {args.cutoff!r}")
    if args.decimation is not None and args.decimation < 1:
        raise UsageError(f"--decimation: expected a whole number >= 1, got {args.decimation!r}")
    if not (math.isfinite(args.holdout) and 0 <= args.holdout < 0.9):
        raise UsageError(f"--holdout: expected a share from 0 to 0.9 of the samples, got {args.holdout!r}")
    check_out_dir(args.out)
    robot = load_robot(args.robot)
    desc = robot.description
    table = read_joint_table(args.data, desc.joint_names, ("q", "tau"), ("qd",), what="identification data")
    if args.cutoff is not None and args.cutoff >= 0.5 / float(_median_step(table.t)):
        raise UsageError(f"--cutoff: {args.cutoff!r} Hz is not below the data's Nyquist frequency "
                         f"{0.5 / float(_median_step(table.t)):g} Hz")
    say = _say("identify")
    reg = Regressor(desc)
    reg.compile(progress=say)
    base = base_parameters(reg)
    result = identify_log(robot, table, cutoff_hz=args.cutoff, decimation=args.decimation, holdout=args.holdout,
                          regressor=reg, base=base, progress=say)
    _print_identification(args, desc, table, result)
    files = write_identification(result, desc, out_dir(args.out), Path(args.data).name, str(args.data),
                                 plots=not args.no_plots)
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def write_identification(result: Any, desc: Any, out: Path, data_name: str, data_path: str, *,
                         plots: bool = True) -> list[Path]:
    """Write what ``manip identify`` writes into the folder ``out``: the identified robot file(s),
    ``identification.json`` and (``plots``) the two figures. Returns the files."""
    from model.identification import identified_description, write_identified

    identified = identified_description(desc, result.pi, source=f"identified by manip identify from {data_name}")
    files = write_identified(identified, out, header=f"{desc.name} identified by manip identify from {data_name} "
                                                    f"({result.chosen} fit). SI units.")
    data = {"robot": desc.name, "data": data_path, "joints": list(desc.joint_names), **result.to_dict(),
            "robot_file": files[-1].name}
    files.append(write_json(out / "identification.json", data))
    if plots:
        from .identify_plots import holdout_torque_plot, residual_spectrum_plot

        revolute = [lk.is_revolute for lk in desc.links]
        files.append(save_figure(holdout_torque_plot(result, desc.joint_names, revolute), out / "holdout_torques.png"))
        files.append(save_figure(residual_spectrum_plot(result, desc.joint_names, revolute), out / "residual_spectrum.png"))
    return files


def _median_step(t: Sequence[float]) -> float:
    import numpy as np

    return float(np.median(np.diff(np.asarray(t))))


def _print_identification(args: argparse.Namespace, desc: Any, table: Any, result: Any) -> None:
    import numpy as np

    pre = result.preprocessing
    names = desc.joint_names
    units = ["N m" if lk.is_revolute else "N" for lk in desc.links]
    duration = float(table.t[-1] - table.t[0])
    sampling = f"{pre.samples_in} samples at {pre.rate_hz:.6g} Hz over {duration:.6g} s"
    sampling += (f"; time steps vary by up to {100 * pre.jitter:.2g} %: resampled onto a uniform grid (cubic spline)"
                 if pre.resampled else f" (time steps within {100 * pre.jitter:.2g} % of the median)")
    print(f"data: {args.data}: {sampling}")
    if pre.cutoff_source == "spectrum":
        edges = ", ".join("-" if e is None else f"{e:.3g}" for e in pre.band_edges_hz)
        source = f"from the position spectrum (per-joint band edges {edges} Hz, 20 dB above the noise floor)"
    else:
        source = "given (--cutoff)"
    print(f"filter: zero-phase Butterworth low-pass, cut-off {pre.cutoff_hz:.4g} Hz {source}; "
          f"{pre.differentiated} by differentiation")
    kept = pre.rate_hz / pre.decimation
    print(f"samples: {pre.trimmed_s:.3g} s trimmed at each end, every {pre.decimation}. kept ({kept:.4g} Hz): "
          f"{pre.samples_out} samples, {len(result.fit)} to fit and {len(result.holdout)} held out (the last "
          f"{100 * args.holdout:.0f} %)")
    eq = result.equations
    print(f"regression: {result.base.n_base} base parameters, {sum(eq['fit'])} equations "
          f"({sum(eq['at_rest_fit'])} at rest left out), condition number {result.condition_number:.4g}")
    header = ["fit", "rel. error", "rel. error held out"] + [f"RMS {n} [{u}]" for n, u in zip(names, units)]
    rows = [[m, e.relative_error, e.relative_error_holdout, *e.rms_holdout] for m, e in result.errors.items()]
    print(format_table(header, rows))
    wls = result.fits["wls"]
    rows = []
    for k, (name, expr) in enumerate(zip(result.base.base_names, result.base.expressions(4))):
        std = wls.std[k]
        pct = 100 * std / abs(wls.beta[k]) if np.isfinite(std) and wls.beta[k] != 0 else float("nan")
        rows.append([name, float(wls.beta[k]), "fixed" if k in result.fixed else float(std),
                     "-" if not np.isfinite(pct) else float(pct), float(result.fits[result.chosen].beta[k]),
                     expr if len(expr) <= 60 else expr[:57] + "..."])
    print(format_table(["base parameter", "WLS", "std", "std [%]", result.chosen, "= (standard parameters)"], rows))
    cf = result.fits.get("consistent")
    if cf is not None:
        ratios = [0.0 if -1e-12 < r < 0 else r for r in cf.info["pseudo_inertia_eigenvalue_ratio"]]  # rounding of 0
        print(f"consistent fit: IPOPT {cf.info['status']} after {cf.info['iterations']} iterations; every link's "
              f"pseudo-inertia positive semi-definite (smallest / largest eigenvalue per link: "
              f"{', '.join(f'{r:.3g}' for r in ratios)}); friction and rotor inertias >= 0")
    print(f"torque noise per joint (from the residuals): {', '.join(f'{s:.3g}' for s in result.sigma)}")
    _identify_warnings(desc, result)


def _identify_warnings(desc: Any, result: Any) -> None:
    import numpy as np

    eq = result.equations
    pre = result.preprocessing
    if pre is not None and pre.jitter > 5:
        _warn("identify", f"a time step is {1 + pre.jitter:.3g} times the median: the log has gaps, which the "
                          "resampling bridges with a cubic spline (split the log if they are long)")
    for j, name in enumerate(desc.joint_names):
        total = eq["fit"][j] + eq["at_rest_fit"][j]
        if total and eq["at_rest_fit"][j] > 0.5 * total:
            _warn("identify", f"joint {name} is at rest (below {result.v_rest[j]:.3g}) in {eq['at_rest_fit'][j]} of "
                              f"{total} fit samples: its friction and the parameters only it moves are poorly excited")
    if result.fixed:
        names = ", ".join(result.base.base_names[k] for k in result.fixed)
        _warn("identify", f"the data do not excite {len(result.fixed)} base parameters; they keep the robot file's "
                          f"values: {names}")
    cons, wls = result.errors.get("consistent"), result.errors["wls"]
    if cons is not None and cons.relative_error > 1.1 * wls.relative_error + 1e-12:
        _warn("identify", f"the consistent fit's error {cons.relative_error:.3g} is more than 10 % above the least-squares "
                          f"{wls.relative_error:.3g}: the least-squares parameters are not those of any rigid arm "
                          "(unmodelled dynamics, or a torque of the wrong sign or joint)")
    if wls.relative_error > 0.1:
        _warn("identify", f"the least-squares fit leaves {100 * wls.relative_error:.3g} % of the torque unexplained: check "
                          "that the torques are joint-side, in N m, and in the robot file's joint order and sign")
    if not np.isfinite(result.condition_number) or result.condition_number > 1e4:
        _warn("identify", f"the base regressor's condition number {result.condition_number:.3g} is large: the log does "
                          "not excite every base parameter well (manip excite designs one that does)")


def register(subparsers: Any) -> None:
    """Add ``excite`` and ``identify`` to ``manip``'s sub-parsers."""
    p = subparsers.add_parser("excite", help="an excitation trajectory for identification (Fourier series, IPOPT)")
    p.add_argument("robot", help="built-in name, TOML or URDF file")
    p.add_argument("-o", "--output", required=True, metavar="FILE.csv", help="the trajectory CSV (time, q, qd, qdd)")
    p.add_argument("--period", type=float, default=10.0, metavar="S", help="period of the series, s (default 10)")
    p.add_argument("--harmonics", type=int, default=5, metavar="L", help="harmonics per joint (default 5)")
    p.add_argument("--periods", type=int, default=1, metavar="K", help="periods written to the CSV (default 1)")
    p.add_argument("--rate", type=float, default=1000.0, metavar="HZ", help="sampling rate of the CSV (default 1000)")
    p.add_argument("--velocity-limit", default=None, metavar="V[,V...]",
                   help="joint speed limits, rad/s or m/s: one for all joints or one per joint (default: the robot "
                        "file's velocity_limit, else 1 rad/s, 0.25 m/s)")
    p.add_argument("--acceleration-limit", default=None, metavar="A[,A...]",
                   help="joint acceleration limits, rad/s^2 or m/s^2 (default: the robot file's acceleration_limit, "
                        "else 4 rad/s^2, 1 m/s^2)")
    p.add_argument("--torque-margin", type=float, default=0.9, metavar="X",
                   help="share of each motor's rated torque the excitation may use (default 0.9)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random start (default 0)")
    p.add_argument("--max-iter", type=int, default=300, metavar="N", help="IPOPT iterations at most (default 300)")
    add_no_plots(p)
    p.set_defaults(func=run_excite)
    p = subparsers.add_parser("identify", help="a robot's dynamic parameters from a log of q and tau")
    p.add_argument("robot", help="built-in name, TOML or URDF file")
    p.add_argument("data", help="CSV: time, q_<joint>..., [qd_<joint>...], tau_<joint>... (SI, joint-side torques)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")
    p.add_argument("--cutoff", type=float, default=None, metavar="HZ",
                   help="low-pass cut-off, Hz (default: from the spectrum of the positions)")
    p.add_argument("--decimation", type=int, default=None, metavar="D",
                   help="keep every D-th sample after filtering (default: rate / (2.5 x cut-off))")
    p.add_argument("--holdout", type=float, default=0.3, metavar="X",
                   help="share of the samples, at the end, held out for validation (default 0.3)")
    add_no_plots(p)
    p.set_defaults(func=run_identify)
