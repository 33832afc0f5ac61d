"""Cold build time, library size and evaluation speed against the number of joints, with Pinocchio in the same run.

Run as ``python -m benchmarks.bench_build`` (``--joints 2 7 12`` to choose the
sizes, ``-N`` the states per batch). For each n, a seeded random standard-DH
revolute chain (:func:`tests.support.chains.random_chain`: alternating parallel and
perpendicular axes, random masses, inertias and geared motors) is built in a
fresh cache folder, then loaded again from the cache, then evaluated:

* cold build: wall time, CPU time of the compilers, peak memory of the
  largest child process (a compiler, or this process as it was when it
  forked) and of this process, size of the generated C and of the library;
* warm load: a new ``Dynamics`` of the same robot loading the cached library;
* rne and accel on N random states (``rne_batch``, ``accel_batch``), ns per state;
* Pinocchio on the same states: ``rnea`` and ``aba`` called in a Python loop,
  and its batched ``rneaInParallel`` / ``abaInParallel`` on one thread, ns
  per state, with the largest relative difference from ours (friction,
  which Pinocchio does not model, is added outside).

The table goes to stdout and to ``benchmarks/results/build.md``.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks._timing import best_time
from model.codegen import build_jobs, find_compiler
from model.dynamics import Dynamics

__all__ = ["main", "measure"]

RESULTS = Path(__file__).resolve().parent / "results" / "build.md"
DEFAULT_JOINTS = (2, 3, 4, 6, 7, 8, 12, 16, 20, 25)


def say(text: str) -> None:
    print(text, flush=True)


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _cpu_self() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def measure(n: int, N: int, seed: int = 1) -> dict:
    """Build, load and time the n-joint random chain; one row of the table as a dict."""
    import pinocchio as pin

    from tests.support.chains import random_chain
    from tests.support.references import friction_reference, pinocchio_model

    desc = random_chain(n, seed)
    row: dict = {"n": n}
    with tempfile.TemporaryDirectory(prefix="mw-bench-build-") as tmp:
        old = os.environ.get("MANIP_CACHE_DIR")
        os.environ["MANIP_CACHE_DIR"] = tmp
        try:
            cpu_c, cpu_s, t0 = _cpu_children(), _cpu_self(), time.perf_counter()
            dyn = Dynamics(desc)
            info = dyn.compile(progress=lambda event: say(f"  [{time.perf_counter() - t0:6.1f} s] {event}"))
            row["cold_s"] = time.perf_counter() - t0
            row["cpu_cc_s"] = _cpu_children() - cpu_c
            row["cpu_py_s"] = _cpu_self() - cpu_s
            row["rss_cc_mb"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
            row["rss_py_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            row["symbolic_s"] = info.seconds_symbolic
            row["c_mb"] = info.c_bytes / 1e6
            row["so_mb"] = info.library.stat().st_size / 1e6
            row["ops"] = sum(u.instructions for u in info.units)
            row["coriolis_ops"] = next(u.instructions for u in info.units if u.name == "coriolis")
            t0 = time.perf_counter()
            warm = Dynamics(desc)
            warm_info = warm.compile()
            row["warm_ms"] = (time.perf_counter() - t0) * 1e3
            if not warm_info.cached:  # a model source was edited between the two builds
                say("  the second build missed the cache: its time is not a warm load")
                row["warm_ms"] = float("nan")
        finally:
            if old is None:
                os.environ.pop("MANIP_CACHE_DIR", None)
            else:
                os.environ["MANIP_CACHE_DIR"] = old

        rng = np.random.default_rng(2024)
        Q, QD, QDD = (np.ascontiguousarray(a) for a in rng.uniform(-2.0, 2.0, (3, N, n)))
        row["rne_ns"] = best_time(lambda: warm.rne_batch(Q, QD, QDD)) / N * 1e9
        TAU = warm.rne_batch(Q, QD, QDD)
        row["accel_ns"] = best_time(lambda: warm.accel_batch(Q, QD, TAU)) / N * 1e9

        model = pinocchio_model(desc)
        data = model.createData()
        F = np.array([friction_reference(desc, v) for v in QD])
        M = min(N, 5000)

        def pin_rnea() -> np.ndarray:
            return np.array([pin.rnea(model, data, Q[k], QD[k], QDD[k]) for k in range(M)])

        def pin_aba() -> np.ndarray:
            rhs = TAU[:M] - F[:M]
            return np.array([pin.aba(model, data, Q[k], QD[k], rhs[k]) for k in range(M)])

        row["pin_rnea_ns"] = best_time(pin_rnea) / M * 1e9
        row["pin_aba_ns"] = best_time(pin_aba) / M * 1e9
        tau_scale = max(1.0, np.abs(TAU[:M]).max())
        row["err_rne"] = np.abs(pin_rnea() + F[:M] - TAU[:M]).max() / tau_scale
        row["err_accel"] = np.abs(pin_aba() - QDD[:M]).max() / max(1.0, np.abs(QDD[:M]).max())
        if hasattr(pin, "rneaInParallel"):
            pool = pin.ModelPool(model, 1)
            qT, vT, aT = (np.asfortranarray(a.T) for a in (Q, QD, QDD))
            rhsT = np.asfortranarray((TAU - F).T)
            row["pin_rnea_batch_ns"] = best_time(lambda: pin.rneaInParallel(1, pool, qT, vT, aT)) / N * 1e9
            row["pin_aba_batch_ns"] = best_time(lambda: pin.abaInParallel(1, pool, qT, vT, rhsT)) / N * 1e9
    return row


HEADER = ("| n | cold build s | compiler CPU s | symbolic s | peak child MB | peak python MB | operations (coriolis) "
          "| C MB | .so MB | warm load ms | rne ns | accel ns | pin rnea loop ns | pin aba loop ns "
          "| pin rnea batch ns | pin aba batch ns | max rel. diff rne / accel |")


def format_row(r: dict) -> str:
    def opt(key: str) -> str:
        return f"{r[key]:.0f}" if key in r else "-"

    return (f"| {r['n']} | {r['cold_s']:.1f} | {r['cpu_cc_s']:.1f} | {r['symbolic_s']:.1f} | {r['rss_cc_mb']:.0f} "
            f"| {r['rss_py_mb']:.0f} | {r['ops']:,} ({r['coriolis_ops']:,}) | {r['c_mb']:.2f} | {r['so_mb']:.2f} "
            f"| {r['warm_ms']:.1f} | {r['rne_ns']:.0f} | {r['accel_ns']:.0f} | {r['pin_rnea_ns']:.0f} "
            f"| {r['pin_aba_ns']:.0f} | {opt('pin_rnea_batch_ns')} | {opt('pin_aba_batch_ns')} "
            f"| {r['err_rne']:.1e} / {r['err_accel']:.1e} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--joints", type=int, nargs="+", default=list(DEFAULT_JOINTS), metavar="N",
                        help=f"chain lengths (default {' '.join(map(str, DEFAULT_JOINTS))})")
    parser.add_argument("-N", type=int, default=20_000, help="states per batch (default 20000)")
    parser.add_argument("--no-write", action="store_true", help=f"do not write {RESULTS.name}")
    args = parser.parse_args(argv)
    compiler = find_compiler()
    version = subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    load = os.getloadavg()[0]
    say(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, {build_jobs()} compiler processes, {version}, "
        f"load average {load:.1f} at start")
    rows = []
    for n in args.joints:
        say(f"\n== {n}-joint random chain ==")
        rows.append(measure(n, args.N))
        say(format_row(rows[-1]))
    lines = [
        "# Cold build and evaluation against the number of joints",
        "",
        f"`python -m benchmarks.bench_build` on {platform.machine()}, {os.cpu_count()} CPUs, "
        f"{build_jobs()} parallel compiler processes, {version}; load average {load:.1f} at the start "
        f"(other work on the machine stretches wall times: compare the compiler CPU column). Random "
        f"standard-DH revolute chains (`tests/support/chains.py`, seed 1), N = {args.N} states; Pinocchio loops on "
        f"{min(args.N, 5000)} states, its batched calls on one thread.",
        "",
        HEADER,
        "|" + "---|" * (HEADER.count("|") - 1),
        *[format_row(r) for r in rows],
        "",
    ]
    say("\n" + "\n".join(lines))
    if not args.no_write:
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        RESULTS.write_text("\n".join(lines))
        say(f"written {RESULTS}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
