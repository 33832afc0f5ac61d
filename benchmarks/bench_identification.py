"""Speed of the compiled identification regressor against Pinocchio's ``computeJointTorqueRegressor``, one run.

Run as ``python -m benchmarks.bench_identification`` (``-N`` sets the number of states). For each robot it
times, on the same N random states:

* ours: :meth:`model.identification.Regressor.batch`, one compiled C call for all N states, the full
  (n, 14 n) regressor (inertial, rotor, friction and offset columns);
* Pinocchio: ``pin.computeJointTorqueRegressor(model, data, q, v, a)`` in a Python loop (Pinocchio has no batch
  call), the (n, 10 n) inertial columns, with the model built from the same description by
  ``tests/support/references.py``;
* ours single-state: :meth:`Regressor.Y` called in the same kind of loop, for a like-for-like per-call cost.

It prints the agreement of the two (the inertial columns mapped to the link frames, as the tests check) and
the cost per state and the ratios.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from benchmarks._timing import best_time
from model import InertiaConsistencyWarning
from model.chain import build_chain
from model.identification import Regressor
from model.identification.parameters import PER_JOINT, frame_transform
from model.loading import load_description
from tests.support.references import pinocchio_model

__all__ = ["main"]

ROBOTS = ("puma560", "ur5", "panda")


def _agreement(desc, reg, pin, model, data, Q, QD, QDD) -> float:
    chain = build_chain(desc)
    worst = 0.0
    for q, qd, qdd in zip(Q[:10], QD[:10], QDD[:10]):
        Y_pin = pin.computeJointTorqueRegressor(model, data, q, qd, qdd)
        Y = reg.Y(q, qd, qdd)
        for i in range(desc.n):
            mapped = Y_pin[:, 10 * i:10 * i + 10] @ frame_transform(chain.reported[i])
            worst = max(worst, float(np.abs(Y[:, PER_JOINT * i:PER_JOINT * i + 10] - mapped).max()))
    return worst


def main(argv: list[str] | None = None) -> int:
    import pinocchio as pin

    parser = argparse.ArgumentParser(prog="bench_identification")
    parser.add_argument("-N", type=int, default=5000, help="random states per robot (default 5000)")
    args = parser.parse_args(argv)
    print(f"regressor Y(q, qd, qdd), {args.N} random states; best of 3 (ns per state)")
    print(f"{'robot':8s} {'n':>2s} {'ours batch':>11s} {'ours loop':>10s} {'pinocchio loop':>15s} "
          f"{'pin / batch':>12s} {'pin / loop':>11s} {'max diff':>9s}")
    for name in ROBOTS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InertiaConsistencyWarning)
            desc = load_description(name)
        reg = Regressor(desc)
        reg.compile()
        model = pinocchio_model(desc, armature=False)
        data = model.createData()
        rng = np.random.default_rng(0)
        Q, QD, QDD = (rng.uniform(-2, 2, (args.N, desc.n)) for _ in range(3))
        t_batch = best_time(lambda: reg.batch(Q, QD, QDD)) / args.N

        def ours_loop() -> None:
            for q, qd, qdd in zip(Q, QD, QDD):
                reg.Y(q, qd, qdd)

        def pin_loop() -> None:
            for q, qd, qdd in zip(Q, QD, QDD):
                pin.computeJointTorqueRegressor(model, data, q, qd, qdd)

        t_loop = best_time(ours_loop) / args.N
        t_pin = best_time(pin_loop) / args.N
        diff = _agreement(desc, reg, pin, model, data, Q, QD, QDD)
        print(f"{name:8s} {desc.n:2d} {t_batch * 1e9:11.0f} {t_loop * 1e9:10.0f} {t_pin * 1e9:15.0f} "
              f"{t_pin / t_batch:12.1f} {t_pin / t_loop:11.2f} {diff:9.1e}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
