"""Single calls from Python: ``Robot.rne``/``accel``/``fkine``/... against Pinocchio's Python binding, one run.

Run as ``python -m benchmarks.bench_single_call`` (``--robots`` to choose). Each call is timed as
the best of ``--repeat`` loops of ``--number`` calls on one random state (seed 2028), ours and the
peer's loops interleaved so that both see the same load. Peers (``pinocchio_model`` of
``tests/support/references.py``: the same rigid bodies and armature, no friction):

* ``rne``      vs ``pin.rnea(model, data, q, qd, qdd)`` (ours adds friction);
* ``accel``    vs ``pin.aba(model, data, q, qd, tau)``;
* ``fkine``    vs ``pin.forwardKinematics`` + ``pin.updateFramePlacement`` (the SE3 left in ``data``;
  ours returns a fresh (4, 4) array);
* ``inertia``  vs ``pin.crba`` (upper triangle), ``gravload`` vs ``pin.computeGeneralizedGravity``,
  ``coriolis`` vs ``pin.computeCoriolisMatrix``, ``jacob0`` vs ``pin.computeFrameJacobian``.

The table goes to stdout and ``benchmarks/results/single_call.md``, with the load average.
"""

from __future__ import annotations

import argparse
import os
import sys
import timeit
import warnings
from pathlib import Path

import numpy as np

from model import InertiaConsistencyWarning, load_robot

__all__ = ["main"]

RESULTS = Path(__file__).resolve().parent / "results" / "single_call.md"
DEFAULT_ROBOTS = ("puma560", "ur5", "panda")


def say(text: str) -> None:
    print(text, flush=True)


def _pairs(robot, model, data):
    import pinocchio as pin

    rng = np.random.default_rng(2028)
    q, qd, qdd = rng.uniform(-2.0, 2.0, (3, robot.n))
    tau = robot.rne(q, qd, qdd)
    fid = model.getFrameId("tool")
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

    def fk():
        pin.forwardKinematics(model, data, q)
        return pin.updateFramePlacement(model, data, fid)

    return [
        ("rne", lambda: robot.rne(q, qd, qdd), "rnea", lambda: pin.rnea(model, data, q, qd, qdd)),
        ("accel", lambda: robot.accel(q, qd, tau), "aba", lambda: pin.aba(model, data, q, qd, tau)),
        ("fkine", lambda: robot.fkine(q), "forwardKinematics + updateFramePlacement", fk),
        ("inertia", lambda: robot.inertia(q), "crba", lambda: pin.crba(model, data, q)),
        ("gravload", lambda: robot.gravload(q), "computeGeneralizedGravity",
         lambda: pin.computeGeneralizedGravity(model, data, q)),
        ("coriolis", lambda: robot.coriolis(q, qd), "computeCoriolisMatrix",
         lambda: pin.computeCoriolisMatrix(model, data, q, qd)),
        ("jacob0", lambda: robot.jacob0(q), "computeFrameJacobian",
         lambda: pin.computeFrameJacobian(model, data, q, fid, world)),
    ]


def measure(name: str, number: int, repeat: int) -> list[tuple[str, float, str, float]]:
    """``(ours, us, peer, us)`` per call of robot ``name``."""
    from tests.support.references import pinocchio_model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot(name)
    model = pinocchio_model(robot.description)
    data = model.createData()
    rows = []
    for ours, f_ours, peer, f_peer in _pairs(robot, model, data):
        f_ours(), f_peer()  # compiled, cached and warm
        best_ours = best_peer = float("inf")
        for _ in range(repeat):
            best_ours = min(best_ours, timeit.timeit(f_ours, number=number) / number)
            best_peer = min(best_peer, timeit.timeit(f_peer, number=number) / number)
        rows.append((ours, best_ours * 1e6, peer, best_peer * 1e6))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(DEFAULT_ROBOTS))
    parser.add_argument("--number", type=int, default=20_000, help="calls per timed loop (default 20000)")
    parser.add_argument("--repeat", type=int, default=7, help="timed loops, best kept (default 7)")
    parser.add_argument("--no-write", action="store_true", help=f"do not write {RESULTS.name}")
    args = parser.parse_args(argv)
    import pinocchio

    load_before = os.getloadavg()
    table = ["| robot | ours | us | Pinocchio (Python) | us | Pinocchio / ours |", "|---|---|---|---|---|---|"]
    for name in args.robots:
        for ours, t_ours, peer, t_peer in measure(name, args.number, args.repeat):
            say(f"{name:8s} {ours:9s} {t_ours:6.2f} us   pin.{peer:42s} {t_peer:6.2f} us   x{t_peer / t_ours:.2f}")
            table.append(f"| {name} | `Robot.{ours}` | {t_ours:.2f} | `pin.{peer}` | {t_peer:.2f} | x{t_peer / t_ours:.2f} |")
    load_after = os.getloadavg()
    text = "\n".join([
        "# Single calls from Python against Pinocchio's Python binding",
        "",
        f"`python -m benchmarks.bench_single_call --number {args.number} --repeat {args.repeat}`, Python "
        f"{sys.version.split()[0]}, Pinocchio {pinocchio.__version__}, {os.cpu_count()} CPUs. One random state "
        "per robot (float64 NumPy vectors), best of the loops, ours and Pinocchio's interleaved. Ours through "
        "the compiled single-call path (`model/point_call.py`); Pinocchio's model from the same description "
        "(`tests/support/references.py`, armature included, friction not: our `rne` also adds friction). "
        f"Load average before {tuple(round(x, 2) for x in load_before)}, after "
        f"{tuple(round(x, 2) for x in load_after)} (a shared machine: compare the ratios).",
        "",
        *table,
        "",
    ])
    say("\n" + text)
    if not args.no_write:
        RESULTS.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
