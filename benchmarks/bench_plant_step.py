"""The cost of the stick-slip plant in the compiled closed loop, against the sign(qd) kernel it replaced.

Run as ``python -m benchmarks.bench_plant_step`` (``--peer-rev REV``, ``--kind ct``, ``--repeat R``,
``--rounds K``). One compiled closed-loop run of the seed's pick-and-place (SCARA, 15 s of motion at
1 kHz), best of ``--repeat``, for two plants:

* ``no Coulomb``: the SCARA as its file states it (viscous friction only): the plant's rule finds no
  mode that can change (``active`` = 0) and skips the event indicators; a sweep of a robot without
  Coulomb friction must not get slower;
* ``Coulomb``: the same with Coulomb friction on every joint (motor side +-0.02, 0.02, 0.05, 0.002 N m,
  set as parameters): the rule evaluates the indicators every sub-step and locates the stick events.

The peer is the compiled closed loop of ``--peer-rev`` (default ``ff5a934``, the revision before the
one plant: RK4 on ``accel_scaled``, Coulomb friction by ``sign(qd)``, no events), exported with
``git archive`` into a temporary folder and timed in a subprocess on the same plants, rounds
alternating with this tree's (``--rounds``) so both see the same machine load. Ratios are this
tree's time over the peer's. Both trees build their kernels into the disk cache on the first round.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Sequence

__all__ = ["main", "time_kernels"]

ROOT = Path(__file__).resolve().parents[1]
#: Motor-side Coulomb friction of the ``Coulomb`` plant, N m (SCARA joints 1-4).
COULOMB = (0.02, 0.02, 0.05, 0.002)


def time_kernels(kind: str, repeat: int) -> dict[str, float]:
    """Best wall time (s) of one compiled run of the SCARA pick-and-place for each plant; importable by a peer tree
    (it uses only what both trees have: ``closed_loop.kernel``, ``Schedule``, ``design_robot``)."""
    import time
    import warnings

    import numpy as np

    from closed_loop.kernel import closed_loop_kernel
    from closed_loop.schedule import Schedule
    from control_design import design_robot, reference_task
    from model import load_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot("scara")
    task = reference_task(robot)
    controller = design_robot(robot, kind, analyse=False).controller(1000.0)
    sched = Schedule.build(robot, task, controller.dt, rate_hz=1000.0)
    kernel = closed_loop_kernel(robot, kind)
    c = np.array(COULOMB)
    plants = {"no Coulomb": robot.parameters,
              "Coulomb": robot.parameters.with_friction(coulomb_pos=c, coulomb_neg=-c)}
    out = {}
    for name, p in plants.items():
        kernel.run(controller, sched, p)  # warm
        best = float("inf")
        for _ in range(repeat):
            start = time.perf_counter()
            run = kernel.run(controller, sched, p)
            best = min(best, time.perf_counter() - start)
        out[name] = best
        out[name + " max_error"] = float(np.max(run.max_error))
    return out


def _load() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:  # pragma: no cover - not Linux
        return "?"


def _peer(tree: Path, kind: str, repeat: int) -> dict[str, float]:
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); sys.path.insert(1, sys.argv[2]); "
            "from bench_plant_step_peer import time_kernels; print(json.dumps(time_kernels(sys.argv[3], "
            "int(sys.argv[4]))))")
    shim = tree / "bench_plant_step_peer.py"
    shim.write_text(Path(__file__).read_text())
    proc = subprocess.run([sys.executable, "-c", code, str(tree), str(tree), kind, str(repeat)], cwd=tree,
                          capture_output=True, text=True, check=False,
                          env={**os.environ, "PYTHONPATH": str(tree)})
    if proc.returncode != 0:
        raise RuntimeError(f"peer run failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_plant_step", description=__doc__.split("\n")[0])
    parser.add_argument("--peer-rev", default="ff5a934", help="git revision of the sign(qd) kernel (default ff5a934)")
    parser.add_argument("--kind", default="ct", choices=["pd", "pd-g", "pd-ff", "pid", "ct"])
    parser.add_argument("--repeat", type=int, default=7, help="runs per plant, the best is kept (default 7)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds of both trees (default 3)")
    args = parser.parse_args(argv)
    if args.repeat < 1 or args.rounds < 1:
        parser.error("--repeat and --rounds: expected at least 1")

    with tempfile.TemporaryDirectory(prefix="bench_plant_step_peer_") as tmp:
        tree = Path(tmp)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.peer_rev], capture_output=True, check=False)
        if archive.returncode != 0:
            parser.error(f"--peer-rev: git archive {args.peer_rev} failed: {archive.stderr.decode().strip()}")
        subprocess.run(["tar", "-x", "-C", str(tree)], input=archive.stdout, check=True)
        ours: dict[str, float] = {}
        theirs: dict[str, float] = {}
        for r in range(args.rounds):
            print(f"round {r + 1}/{args.rounds}: this tree, then {args.peer_rev} (load {_load()})", flush=True)
            for best, got in ((ours, time_kernels(args.kind, args.repeat)),
                              (theirs, _peer(tree, args.kind, args.repeat))):
                for key, value in got.items():
                    best[key] = min(best.get(key, float("inf")), value) if "max_error" not in key else value
    print()
    print(f"compiled closed loop, scara {args.kind}, pick-and-place 15 s at 1 kHz, best of {args.repeat} x "
          f"{args.rounds} rounds (load {_load()})")
    print(f"{'plant':<12} {'this tree ms':>13} {args.peer_rev + ' ms':>13} {'ratio':>7}   max_error (this, peer)")
    for name in ("no Coulomb", "Coulomb"):
        a, b = ours[name], theirs[name]
        print(f"{name:<12} {1e3 * a:>13.2f} {1e3 * b:>13.2f} {a / b:>6.2f}x   "
              f"{ours[name + ' max_error']:.6e}, {theirs[name + ' max_error']:.6e}")
    print(f"the stick-slip plant against this tree's own plant without Coulomb friction: "
          f"{ours['Coulomb'] / ours['no Coulomb']:.2f}x")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
