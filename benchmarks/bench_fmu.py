"""Cost of one Co-Simulation step of the SCARA FMU, natively and through FMPy, against a trivial FMU.

Run as ``python -m benchmarks.bench_fmu`` (``--native-steps`` and ``--fmpy-steps``
set the loop lengths). Both FMUs are built in the same run with the same
wrapper: the SCARA (4 joints, RK4 with one sub-step at a 1 ms communication
step) and a one-state lag ``xdot = rate (u_1 + ... + u_4 - x)`` with as many
inputs as the SCARA, whose cost through FMPy is FMPy's own overhead (setting
four inputs included). Peers, all at h = 1 ms:

* native: ``fmu/c/fmu_driver.c`` dlopens the binary and loops ``fmi2DoStep``
  (alone, and after ``fmi2SetReal`` of the inputs);
* FMPy: ``FMU2Slave.setReal`` of the inputs and ``FMU2Slave.doStep`` in a Python loop.

Targets: under 2 us per native step; through FMPy at most 1.5 times the trivial FMU.
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

if TYPE_CHECKING:
    from fmu.opened import OpenedFmu

__all__ = ["main", "native_step_cost", "fmpy_step_cost"]

NATIVE_TARGET_US = 2.0
FMPY_RATIO_TARGET = 1.5
STEP = 1e-3


def say(text: str) -> None:
    print(text, flush=True)


def _input_vrs(fmu: "OpenedFmu") -> list[int]:
    """The value references of the inputs, in the model description's order."""
    return [int(v.valueReference) for v in fmu.md.modelVariables if v.causality == "input"]


def native_step_cost(driver: Path, fmu: "OpenedFmu", steps: int) -> dict[str, float]:
    """Microseconds per ``fmi2DoStep`` and per ``fmi2SetReal`` + ``fmi2DoStep`` in the C driver."""
    lib = Path(fmu.unzip_dir) / "binaries" / "linux64" / f"{fmu.interfaces['cs']}.so"
    inputs = [str(vr) for vr in _input_vrs(fmu)]
    out = subprocess.run([str(driver), "bench", str(lib), fmu.guid, str(fmu.n_states), str(steps), *inputs],
                         capture_output=True, text=True, check=True).stdout
    values = dict(line.split() for line in out.splitlines() if line.strip())
    return {key: float(value) for key, value in values.items()}


def fmpy_step_cost(fmu: "OpenedFmu", steps: int, repeat: int = 5) -> float:
    """Best microseconds per ``setReal`` + ``doStep`` of an FMPy ``FMU2Slave`` in a Python loop.

    FMPy's own class, not :class:`fmu.instance.Instance`: FMPy's Python loop is the peer being timed.
    """
    from fmpy.fmi2 import FMU2Slave

    vrs = _input_vrs(fmu)
    slave = FMU2Slave(guid=fmu.guid, unzipDirectory=fmu.unzip_dir, modelIdentifier=fmu.interfaces["cs"],
                      instanceName="bench")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    values = [0.0] * len(vrs)
    best = float("inf")
    k = 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(steps):
            values[0] = 1e-4 * (k & 7)
            slave.setReal(vrs, values)
            slave.doStep(currentCommunicationPoint=k * STEP, communicationStepSize=STEP)
            k += 1
        best = min(best, time.perf_counter() - t0)
    slave.terminate()
    slave.freeInstance()
    return 1e6 * best / steps


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_fmu", description=__doc__.split("\n")[0])
    parser.add_argument("--native-steps", type=int, default=200_000, help="steps per native loop")
    parser.add_argument("--fmpy-steps", type=int, default=20_000, help="steps per FMPy loop")
    args = parser.parse_args(argv)

    from fmu.build import build_driver, export_fmu, export_trivial_fmu
    from fmu.opened import open_fmu
    from model import InertiaConsistencyWarning

    with tempfile.TemporaryDirectory(prefix="bench_fmu_") as tmp:
        root = Path(tmp)
        say("building scara.fmu, trivial.fmu and the C driver ...")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InertiaConsistencyWarning)
            fmus = {"scara": export_fmu("scara", root / "scara.fmu", step=STEP),
                    "trivial": export_trivial_fmu(root / "trivial.fmu", step=STEP, n_inputs=4)}
        driver = build_driver(root / "fmu_driver")
        rows = {}
        for name, path in fmus.items():
            say(f"timing {name}: native ({args.native_steps} steps), FMPy ({args.fmpy_steps} steps, best of 5)")
            with open_fmu(path) as fmu:  # extracted once, removed on close
                native = native_step_cost(driver, fmu, args.native_steps)
                rows[name] = (native["doStep_us"], native["setReal_doStep_us"], fmpy_step_cost(fmu, args.fmpy_steps))

    trivial = rows["trivial"]
    say("")
    say(f"cost per Co-Simulation step at h = {STEP * 1e3:g} ms (us); ratios against the trivial one-state FMU")
    say(f"{'FMU':<9} {'native doStep':>14} {'native set+step':>16} {'FMPy set+step':>14} "
        f"{'native ratio':>13} {'FMPy ratio':>11}")
    for name, (step_us, set_step_us, fmpy_us) in rows.items():
        say(f"{name:<9} {step_us:>14.3f} {set_step_us:>16.3f} {fmpy_us:>14.3f} "
            f"{set_step_us / trivial[1]:>13.2f} {fmpy_us / trivial[2]:>11.2f}")
    scara = rows["scara"]
    native_ok = scara[1] < NATIVE_TARGET_US
    ratio_ok = scara[2] / trivial[2] <= FMPY_RATIO_TARGET
    say("")
    say(f"target native < {NATIVE_TARGET_US:g} us per step (setReal + doStep): {scara[1]:.3f} us, "
        f"{'met' if native_ok else 'MISSED'}")
    say(f"target FMPy <= {FMPY_RATIO_TARGET:g} x trivial: {scara[2] / trivial[2]:.2f} x "
        f"(FMPy's own overhead {trivial[2]:.2f} us per step), {'met' if ratio_ok else 'MISSED'}")
    return 0 if native_ok and ratio_ok else 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
