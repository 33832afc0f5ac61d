"""Speed of the compiled dynamics against Pinocchio and the Robotics Toolbox, in one run on the same states.

Run as ``python -m benchmarks.bench_dynamics`` (``--cold`` first measures cold
and cached builds in a fresh cache folder; ``-N`` sets the number of states).
Prints ns per state, the agreement with each peer, the ratios, and a table of
cost versus number of joints for Lagrange- and Newton-Euler-generated code.
Peers: Pinocchio ``rnea``/``aba`` called in a Python loop (rigid bodies from the
same DH data, armature ``G^2 Jm``, friction added outside the loop), and the
Robotics Toolbox's batched ``DHRobot.rne`` (its C extension).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings

import numpy as np

from benchmarks._timing import best_time as time_best
from model import InertiaConsistencyWarning, load_robot
from model.description import BUILTIN_DIR
from model.codegen import build_library
from model.dynamics.core import source_fingerprint

__all__ = ["main", "time_best"]


def say(text: str) -> None:
    print(text, flush=True)


def _load(name: str, motor_model: str = "reflected"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot(name, motor_model=motor_model)


def build_times(names: list[str]) -> None:
    """Cold and cached builds (symbolic + C + compile) in a fresh cache folder."""
    with tempfile.TemporaryDirectory() as tmp:
        old = os.environ.get("MANIP_CACHE_DIR")
        os.environ["MANIP_CACHE_DIR"] = tmp
        try:
            say("\n== build times (fresh cache folder) ==")
            for name in names:
                t0 = time.perf_counter()
                cold = _load(name).dynamics.compile()
                t_cold = time.perf_counter() - t0
                t0 = time.perf_counter()
                warm = _load(name).dynamics.compile()
                t_warm = time.perf_counter() - t0
                say(f"{name:9s} cold {t_cold:6.2f} s (symbolic {cold.seconds_symbolic:.2f}, C {cold.seconds_generate:.2f}, "
                    f"compile {cold.seconds_compile:.2f})   cached {t_warm * 1e3:6.1f} ms (hit: {warm.cached})")
        finally:
            if old is None:
                os.environ.pop("MANIP_CACHE_DIR", None)
            else:
                os.environ["MANIP_CACHE_DIR"] = old


def compare_peers(name: str, N: int, rtb_states: int) -> None:
    """Our batch API against Pinocchio (Python loop) and RTB's batched rne on the same N states."""
    import pinocchio as pin

    from tests.support.references import friction_reference, pinocchio_model, rtb_robot

    robot = _load(name)
    n = robot.n
    say(f"\n== {name} (n = {n}), N = {N} states ==")
    info = robot.dynamics.compile()
    say(f"compiled library {'loaded from cache' if info.cached else 'built'} in {info.seconds_total:.2f} s")
    rng = np.random.default_rng(2024)
    Q, QD, QDD = rng.uniform(-2.0, 2.0, (3, N, n))

    t_rne = time_best(lambda: robot.rne_batch(Q, QD, QDD))
    TAU = robot.rne_batch(Q, QD, QDD)
    t_acc = time_best(lambda: robot.accel_batch(Q, QD, TAU))
    say(f"ours      rne_batch {t_rne / N * 1e9:8.1f} ns/state   accel_batch {t_acc / N * 1e9:8.1f} ns/state")

    model = pinocchio_model(robot.description)
    data = model.createData()
    F = np.array([friction_reference(robot.description, v) for v in QD])

    def pin_rne():
        out = np.empty((N, n))
        for k in range(N):
            out[k] = pin.rnea(model, data, Q[k], QD[k], QDD[k])
        return out + F

    def pin_aba():
        out = np.empty((N, n))
        rhs = TAU - F
        for k in range(N):
            out[k] = pin.aba(model, data, Q[k], QD[k], rhs[k])
        return out

    say("pinocchio rnea loop ...")
    t_pin_rne = time_best(pin_rne, repeat=1)
    err_rne = np.abs(pin_rne() - TAU).max() / max(1.0, np.abs(TAU).max())
    say("pinocchio aba loop ...")
    t_pin_aba = time_best(pin_aba, repeat=1)
    err_aba = np.abs(pin_aba() - QDD).max() / max(1.0, np.abs(QDD).max())
    say(f"pinocchio rnea      {t_pin_rne / N * 1e9:8.1f} ns/state   aba        {t_pin_aba / N * 1e9:8.1f} ns/state"
        f"   (max rel. diff vs ours: rne {err_rne:.1e}, accel {err_aba:.1e})")

    M = min(N, rtb_states)
    say(f"rtb batched rne on {M} states ...")
    rtb = rtb_robot(robot.description)
    t_rtb = time_best(lambda: rtb.rne(Q[:M], QD[:M], QDD[:M]), repeat=1)
    err_rtb = np.abs(rtb.rne(Q[:M], QD[:M], QDD[:M]) - TAU[:M]).max() / max(1.0, np.abs(TAU[:M]).max())
    say(f"rtb rne (batched)   {t_rtb / M * 1e9:8.1f} ns/state   (max rel. diff vs ours: {err_rtb:.1e})")
    say(f"speed-up: rne x{t_pin_rne / t_rne:.1f} vs pinocchio, x{(t_rtb / M) / (t_rne / N):.1f} vs rtb;"
        f" accel x{t_pin_aba / t_acc:.1f} vs pinocchio")


def compare_inertia_gravload(name: str, N: int, peer_states: int) -> None:
    """``inertia_batch`` and ``gravload_batch`` against RTB's batched ``inertia(Q)``/``gravload(Q)`` and Pinocchio loops."""
    import pinocchio as pin

    from tests.support.references import pinocchio_model, rtb_robot, symmetric_from_upper

    robot = _load(name)
    n = robot.n
    rng = np.random.default_rng(2025)
    Q = rng.uniform(-2.0, 2.0, (N, n))
    M = min(N, peer_states)
    say(f"\n== {name}: inertia_batch / gravload_batch, ns per state (ours on N = {N}, peers on {M}) ==")
    t_B = time_best(lambda: robot.inertia_batch(Q))
    t_g = time_best(lambda: robot.gravload_batch(Q))
    B, g = robot.inertia_batch(Q[:M]), robot.gravload_batch(Q[:M])
    rtb = rtb_robot(robot.description)
    t_rtb_B = time_best(lambda: rtb.inertia(Q[:M]), repeat=1)
    t_rtb_g = time_best(lambda: rtb.gravload(Q[:M]), repeat=1)
    err_rtb = max(np.abs(rtb.inertia(Q[:M]) - B).max(), np.abs(rtb.gravload(Q[:M]) - g).max())
    model = pinocchio_model(robot.description)
    data = model.createData()
    t_pin_B = time_best(lambda: [pin.crba(model, data, qk).copy() for qk in Q[:M]], repeat=1)
    t_pin_g = time_best(lambda: [pin.computeGeneralizedGravity(model, data, qk).copy() for qk in Q[:M]], repeat=1)
    err_pin = max(max(np.abs(symmetric_from_upper(pin.crba(model, data, qk)) - Bk).max() for qk, Bk in zip(Q[:M], B)),
                  max(np.abs(pin.computeGeneralizedGravity(model, data, qk) - gk).max() for qk, gk in zip(Q[:M], g)))
    per = lambda t, count: t / count * 1e9  # noqa: E731
    say(f"inertia  ours {per(t_B, N):8.1f}   rtb inertia(Q) {per(t_rtb_B, M):9.1f} (x{per(t_rtb_B, M) / per(t_B, N):.0f})"
        f"   pinocchio crba loop {per(t_pin_B, M):8.1f} (x{per(t_pin_B, M) / per(t_B, N):.1f})")
    say(f"gravload ours {per(t_g, N):8.1f}   rtb gravload(Q) {per(t_rtb_g, M):8.1f} (x{per(t_rtb_g, M) / per(t_g, N):.0f})"
        f"   pinocchio gravity loop {per(t_pin_g, M):5.1f} (x{per(t_pin_g, M) / per(t_g, N):.1f})")
    say(f"max abs diff vs ours: rtb {err_rtb:.1e}, pinocchio {err_pin:.1e}")


def joints_table(N: int) -> None:
    """ns/state of Lagrange- and Newton-Euler-generated rne and accel versus the number of joints."""
    candidates = [("planar2r", 2), ("planar3r", 3), ("scara", 4), ("puma560", 6)]
    rows = []
    say("\n== cost vs number of joints (Lagrange- vs Newton-Euler-generated code) ==")
    for name, n in candidates:
        if not (BUILTIN_DIR / f"{name}.toml").is_file():
            say(f"{name}: no description file, left out")
            continue
        robot = _load(name)
        f = robot.dynamics.functions
        names = ["rne", "rne_lagrange", "accel", "accel_lagrange"]
        say(f"{name}: building the variant library ...")
        t0 = time.perf_counter()
        lib, info = build_library(f"{name}-variants", f"{robot.description.digest()}|reflected|variants|{source_fingerprint()}",
                                  lambda f=f: [getattr(f, k) for k in names])
        say(f"{name}: {'cached' if info.cached else 'built'} in {time.perf_counter() - t0:.1f} s")
        rng = np.random.default_rng(7)
        Q, QD, QDD = (np.ascontiguousarray(a) for a in rng.uniform(-2, 2, (3, N, robot.n)))
        p = robot.parameters.vector
        ns = {k: time_best(lambda k=k: lib.evaluate(k, [Q, QD, QDD, p], N)) / N * 1e9 for k in names}
        ops = {k: getattr(f, k).n_instructions() for k in names}
        rows.append((name, n, ns, ops))
    say(f"{'robot':9s} {'n':>2s} | {'rne NE':>9s} {'rne Lag':>9s} | {'accel NE':>9s} {'accel Lag':>9s}   ns/state"
        f" | instructions NE/Lag (rne; accel)")
    for name, n, ns, ops in rows:
        say(f"{name:9s} {n:2d} | {ns['rne']:9.1f} {ns['rne_lagrange']:9.1f} | {ns['accel']:9.1f} {ns['accel_lagrange']:9.1f}"
            f"            | {ops['rne']}/{ops['rne_lagrange']}; {ops['accel']}/{ops['accel_lagrange']}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-N", type=int, default=100_000, help="states per batch (default 100000)")
    parser.add_argument("--rtb-states", type=int, default=20_000, help="states given to RTB's rne (default 20000)")
    parser.add_argument("--cold", action="store_true", help="first measure cold and cached builds in a fresh cache")
    parser.add_argument("--no-table", action="store_true", help="skip the cost-vs-joints table")
    args = parser.parse_args(argv)
    if args.cold:
        build_times(["scara", "puma560"])
    for name in ("scara", "puma560"):
        compare_peers(name, args.N, args.rtb_states)
        compare_inertia_gravload(name, args.N, min(args.rtb_states, 5_000))
    if not args.no_table:
        joints_table(args.N)


if __name__ == "__main__":
    main()
