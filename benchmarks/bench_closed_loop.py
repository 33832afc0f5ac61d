"""Wall time of the seed's pick-and-place closed loop (15 s of motion, 1 kHz) through the plant FMU.

Run as ``python -m benchmarks.bench_closed_loop`` (``--kinds pd ct``, ``--repeat N``,
``--libcosim``). The SCARA plant FMU and one controller FMU per kind are built in
the same run; each loop is timed end to end (instantiation included, exports
not) and the best of ``--repeat`` runs is kept. Peer: the pure Python loop
:func:`closed_loop.simulate_tracking` with the same controller
(compiled dynamics, RK4 in numpy), timed the same way. Rows:

* ``python``: ``simulate_tracking`` (the peer);
* ``fmu+py``: plant FMU through FMPy's ``FMU2Slave``, the Python controller;
* ``fmu+fmu``: plant FMU and controller FMU, the torques passed in C buffers;
* ``libcosim`` (with ``--libcosim``): both FMUs connected in libcosim (one-period delay).

Target: the FMU loops under 1 s for the 15 s task.
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path
from typing import Sequence

from benchmarks._timing import best_time

__all__ = ["TARGET_S", "main", "best_time"]

TARGET_S = 1.0
RATE_HZ = 1000.0


def say(text: str) -> None:
    print(text, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_closed_loop",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--kinds", nargs="+", default=["pd"], choices=["pd", "pd-ff", "pd-g", "ct"],
                        help="controller kinds (default: pd)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per loop, the best is kept (default 3)")
    parser.add_argument("--libcosim", action="store_true", help="also time the libcosim loop")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat: expected at least 1, got {args.repeat}")

    from closed_loop import export_controller_fmu, run_closed_loop, run_libcosim_closed_loop, simulate_tracking
    from control_design import design_robot, reference_task
    from fmu import export_fmu
    from model import InertiaConsistencyWarning, load_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot("scara")
    task = reference_task(robot)
    duration = task.path.t_end - task.path.t_start
    rows: list[tuple[str, str, float]] = []
    with tempfile.TemporaryDirectory(prefix="bench_closed_loop_") as tmp:
        root = Path(tmp)
        say(f"building scara.fmu and the controller FMUs ({', '.join(args.kinds)}) ...")
        plant_fmu = export_fmu(robot, root / "scara.fmu", step=1.0 / RATE_HZ)
        robot.dynamics.compile()
        for kind in args.kinds:
            design = design_robot(robot, kind, analyse=False)
            ctrl_fmu = export_controller_fmu(design, root / f"{kind}.fmu", rate_hz=RATE_HZ)
            controller = design.controller(RATE_HZ)
            say(f"timing {kind}: {duration:g} s of motion at {RATE_HZ:g} Hz, best of {args.repeat}")
            rows.append((kind, "python", best_time(lambda: simulate_tracking(robot, controller, task), args.repeat)))
            rows.append((kind, "fmu+py", best_time(lambda: run_closed_loop(plant_fmu, controller, task, plant=robot),
                                                   args.repeat)))
            rows.append((kind, "fmu+fmu", best_time(lambda: run_closed_loop(plant_fmu, ctrl_fmu, task, plant=robot),
                                                    args.repeat)))
            if args.libcosim:
                rows.append((kind, "libcosim", best_time(
                    lambda: run_libcosim_closed_loop(plant_fmu, ctrl_fmu, task, plant=robot), args.repeat)))

    say("")
    say(f"closed-loop pick-and-place of scara, {duration:g} s at {RATE_HZ:g} Hz ({int(round(duration * RATE_HZ))} "
        f"periods); wall time end to end (s), ratio = python / loop (> 1: faster than the peer)")
    say(f"{'kind':<6} {'loop':<9} {'wall [s]':>9} {'us/period':>10} {'vs python':>10}")
    met = True
    for kind, loop, wall in rows:
        peer = next(w for k, lp, w in rows if k == kind and lp == "python")
        say(f"{kind:<6} {loop:<9} {wall:>9.3f} {1e6 * wall / (duration * RATE_HZ):>10.1f} {peer / wall:>9.2f}x")
        if loop in ("fmu+py", "fmu+fmu") and wall >= TARGET_S:
            met = False
    say("")
    say(f"target: FMU loops (fmu+py, fmu+fmu) under {TARGET_S:g} s for the {duration:g} s task: "
        f"{'met' if met else 'MISSED'}")
    return 0 if met else 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
