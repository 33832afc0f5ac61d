"""Cost of one retime against toppra and a direct IPOPT transcription, in one run on the same path, grid and limits.

Run as ``python -m benchmarks.bench_retime`` (``--grid`` sets the grid intervals, ``--repeat`` the timed runs).

* The case the issue names: the Franka ``panda`` (7 joints, read from its URDF), its generic tour through one
  C2 spline (no stop), 1000 grid intervals, the motor torque limits of the design (the robot file's
  ``torque_limit``: 87 and 12 N m), the published joint speed limits (2.175 and 2.61 rad/s) and acceleration
  limits (15, 7.5, 10, 12.5, 15, 20, 20 rad/s^2); no friction (panda has none), so all three solve the same
  problem exactly.
* ours: :func:`model.retime.retime_path` (the constraint coefficients from three compiled ``rne_batch`` calls,
  the maximal velocity curve, the backward and forward passes).
* toppra 0.6 (TOPP-RA by its authors; its Cython ``seidel`` LP solver, ``Interpolation`` scheme), handed our
  path: its torque constraint calls our compiled ``rne`` once per grid point and coefficient (3 x 1001 calls),
  which is part of its cost as of ours.
* IPOPT (through CasADi): the same discretised problem written directly (``tests.support.topp_references``),
  started from 70 % of our solution.
* With viscous friction (``puma560``, its tour, straight segments, 1000 intervals): ours against IPOPT only
  (toppra's torque constraint has no term in sd).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from benchmarks._timing import best_time

__all__ = ["main"]

PANDA_VELOCITY = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]
PANDA_ACCELERATION = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]


def say(text: str) -> None:
    print(text, flush=True)


def _case(name: str, blend: bool, **limits):
    from model.retime import blended_path, straight_path
    from tests.support.topp_references import builtin, design_limits, reference_waypoints

    robot = builtin(name)
    W = reference_waypoints(robot)
    path = blended_path(W, robot.qlim) if blend else straight_path(W)
    return robot, path, design_limits(robot, **limits)


def _ipopt(motion) -> tuple[float, float]:
    from tests.support.topp_references import ipopt_duration

    start = time.perf_counter()
    T = sum(ipopt_duration(pc, 0.7 * sol.sd)[0] for pc, sol in zip(motion.constraints, motion.segments))
    return T, time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.bench_retime", description=__doc__.splitlines()[0])
    p.add_argument("--grid", type=int, default=1000, help="grid intervals (default 1000)")
    p.add_argument("--repeat", type=int, default=5, help="timed runs, best kept (default 5)")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    import toppra

    from model.retime import retime_path
    from tests.support.topp_references import toppra_durations

    robot, path, lim = _case("panda", True, velocity_limit=PANDA_VELOCITY, acceleration_limit=PANDA_ACCELERATION)
    motion = retime_path(robot, path, lim, args.grid)  # warm: compiled dynamics loaded, imports done
    toppra_durations(robot, motion)
    ours = best_time(lambda: retime_path(robot, path, lim, args.grid), args.repeat)
    solve_only = min(retime_path(robot, path, lim, args.grid).solve_time for _ in range(args.repeat))
    grid = path.segments[0]
    from model.retime import path_constraints

    coeffs = best_time(lambda: path_constraints(robot, grid, motion.segments[0].s, lim), args.repeat)
    peer = best_time(lambda: toppra_durations(robot, motion), args.repeat)
    T_peer, _ = toppra_durations(robot, motion)
    T_ipopt, t_ipopt = _ipopt(motion)
    say(f"panda (n = 7), tour through a C2 spline, {args.grid} grid intervals, torque + speed + acceleration limits:")
    say(f"  duration: ours {motion.duration:.9f} s, toppra {T_peer:.9f} s ({motion.duration / T_peer - 1:+.2e}), "
        f"IPOPT {T_ipopt:.9f} s ({motion.duration / T_ipopt - 1:+.2e})")
    say(f"  ours {1e3 * ours:.1f} ms (coefficients {1e3 * coeffs:.1f} ms), toppra {1e3 * peer:.1f} ms "
        f"(x{peer / ours:.2f} of ours), IPOPT {1e3 * t_ipopt:.0f} ms (x{t_ipopt / ours:.1f}); solve_time "
        f"{1e3 * solve_only:.1f} ms")
    robot, path, lim = _case("puma560", False)
    motion = retime_path(robot, path, lim, args.grid)
    ours = best_time(lambda: retime_path(robot, path, lim, args.grid), args.repeat)
    T_ipopt, t_ipopt = _ipopt(motion)
    say(f"puma560 (n = 6, viscous and Coulomb friction), tour on {len(path.segments)} straight segments, "
        f"{args.grid} grid intervals, torque limits:")
    say(f"  duration: ours {motion.duration:.9f} s, IPOPT {T_ipopt:.9f} s ({motion.duration / T_ipopt - 1:+.2e}); "
        f"ours {1e3 * ours:.1f} ms, IPOPT {1e3 * t_ipopt:.0f} ms (x{t_ipopt / ours:.1f})")
    say(f"  (toppra {getattr(toppra, '__version__', '0.6')}, numpy {np.__version__})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
