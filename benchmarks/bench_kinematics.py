"""Speed of the compiled kinematics against the Robotics Toolbox and Pinocchio, in one run on the same configurations.

Run as ``python -m benchmarks.bench_kinematics`` (``-N`` sets the batch size, ``-K`` the single calls).
For each robot it prints microseconds per single call and nanoseconds per configuration in a
batch, the agreement with each peer and the ratios:

* ours: ``Robot.fkine`` / ``Robot.jacob0`` (compiled C, one point) and ``fkine_batch`` /
  ``jacob0_batch`` (one C call for N points); also the CasADi evaluation of the same Functions
  (what ``fkine`` cost before it was compiled);
* the Robotics Toolbox: ``DHRobot.fkine(q)`` and ``jacob0(q)`` (its C extension) per call, and its
  batch ``fkine(Q)`` (an SE3 of N poses); ``jacob0`` has no batch form, so a Python loop;
* Pinocchio: ``forwardKinematics`` + ``updateFramePlacements`` (tool pose) and
  ``computeJointJacobians`` + ``getFrameJacobian`` per call, a Python loop for a batch.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from benchmarks._timing import best_time
from model import InertiaConsistencyWarning, load_robot

__all__ = ["main"]


def say(text: str) -> None:
    print(text, flush=True)


def _per_call(run, K: int) -> float:
    """Best time of one call, s, from K calls in a loop (best of 3 loops)."""
    def loop():
        for _ in range(K):
            run()
    return best_time(loop) / K


def compare(name: str, N: int, K: int, peer_states: int) -> None:
    import pinocchio as pin

    from tests.support.references import pinocchio_model, rtb_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot(name)
    n = robot.n
    info = robot.compiled_kinematics.compile()
    say(f"\n== {name} (n = {n}): kinematics library {'loaded from cache' if info.cached else 'built'} "
        f"in {info.seconds_total:.2f} s ==")
    rng = np.random.default_rng(2026)
    Q = rng.uniform(-2.0, 2.0, (N, n))
    q = Q[0]
    rtb = rtb_robot(robot.description)
    pmodel = pinocchio_model(robot.description, armature=False)
    data = pmodel.createData()
    tool = pmodel.getFrameId("tool")
    sym = robot.kinematics

    def pin_fkine(qk):
        pin.forwardKinematics(pmodel, data, qk)
        pin.updateFramePlacements(pmodel, data)
        return data.oMf[tool].homogeneous

    def pin_jacob0(qk):
        pin.computeJointJacobians(pmodel, data, qk)
        pin.updateFramePlacements(pmodel, data)
        return pin.getFrameJacobian(pmodel, data, tool, pin.LOCAL_WORLD_ALIGNED)

    single = {
        "fkine": {
            "ours": lambda: robot.fkine(q),
            "casadi": lambda: np.array(sym.fkine(q)),
            "rtb": lambda: rtb.fkine(q).A,
            "pinocchio": lambda: pin_fkine(q),
        },
        "jacob0": {
            "ours": lambda: robot.jacob0(q),
            "casadi": lambda: np.array(sym.jacob0(q)),
            "rtb": lambda: rtb.jacob0(q),
            "pinocchio": lambda: pin_jacob0(q),
        },
    }
    say(f"single call, us (best of 3 loops of {K}); agreement with ours (max abs diff)")
    for fn, runs in single.items():
        times = {k: _per_call(r, K) for k, r in runs.items()}
        ours = runs["ours"]()
        diffs = {k: float(np.abs(np.asarray(r()) - ours).max()) for k, r in runs.items() if k != "ours"}
        say(f"  {fn:7s} ours {times['ours'] * 1e6:6.2f}   casadi {times['casadi'] * 1e6:6.2f} "
            f"(x{times['casadi'] / times['ours']:.1f})   rtb {times['rtb'] * 1e6:6.2f} (x{times['rtb'] / times['ours']:.1f})"
            f"   pinocchio {times['pinocchio'] * 1e6:6.2f} (x{times['pinocchio'] / times['ours']:.1f})"
            f"   diff: " + ", ".join(f"{k} {v:.1e}" for k, v in diffs.items()))

    M = min(N, peer_states)
    say(f"batch, ns per configuration (ours on N = {N}, peers on {M}); ratio = peer / ours")
    t_fk = best_time(lambda: robot.fkine_batch(Q))
    t_j = best_time(lambda: robot.jacob0_batch(Q))
    T_ours, J_ours = robot.fkine_batch(Q[:M]), robot.jacob0_batch(Q[:M])
    t_rtb_fk = best_time(lambda: rtb.fkine(Q[:M]), repeat=1)
    T_rtb = np.array([X.A for X in rtb.fkine(Q[:M])])
    t_rtb_j = best_time(lambda: [rtb.jacob0(qk) for qk in Q[:M]], repeat=1)
    J_rtb = np.array([rtb.jacob0(qk) for qk in Q[:M]])
    t_pin_fk = best_time(lambda: [pin_fkine(qk) for qk in Q[:M]], repeat=1)
    t_pin_j = best_time(lambda: [pin_jacob0(qk).copy() for qk in Q[:M]], repeat=1)
    J_pin = np.array([pin_jacob0(qk).copy() for qk in Q[:M]])
    T_pin = np.array([pin_fkine(qk).copy() for qk in Q[:M]])
    per = lambda t, count: t / count * 1e9  # noqa: E731
    say(f"  fkine_batch  ours {per(t_fk, N):8.1f}   rtb fkine(Q) {per(t_rtb_fk, M):9.1f} (x{per(t_rtb_fk, M) / per(t_fk, N):.0f})"
        f"   pinocchio loop {per(t_pin_fk, M):9.1f} (x{per(t_pin_fk, M) / per(t_fk, N):.0f})"
        f"   diff: rtb {np.abs(T_ours - T_rtb).max():.1e}, pinocchio {np.abs(T_ours - T_pin).max():.1e}")
    say(f"  jacob0_batch ours {per(t_j, N):8.1f}   rtb loop     {per(t_rtb_j, M):9.1f} (x{per(t_rtb_j, M) / per(t_j, N):.0f})"
        f"   pinocchio loop {per(t_pin_j, M):9.1f} (x{per(t_pin_j, M) / per(t_j, N):.0f})"
        f"   diff: rtb {np.abs(J_ours - J_rtb).max():.1e}, pinocchio {np.abs(J_ours - J_pin).max():.1e}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-N", type=int, default=100_000, help="configurations per batch (default 100000)")
    parser.add_argument("-K", type=int, default=5_000, help="single calls per timing loop (default 5000)")
    parser.add_argument("--peer-states", type=int, default=10_000, help="configurations given to the peers (default 10000)")
    args = parser.parse_args(argv)
    for name in ("scara", "puma560", "ur5"):
        compare(name, args.N, args.K, args.peer_states)
    return 0


if __name__ == "__main__":
    main()
