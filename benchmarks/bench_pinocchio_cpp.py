"""Our generated C against Pinocchio's C++ algorithms, both called from C++ in one process and one run.

Run as ``python -m benchmarks.bench_pinocchio_cpp`` (``-N`` states, ``--robots`` to choose). For each
robot the URDF (``model.urdf_export``; for ``chainN`` a seeded random n-joint chain of
:func:`tests.support.chains.random_chain`) is read by ``pinocchio::urdf::buildModel`` with armature
``G^2 Jm`` and the robot's gravity, and our compiled dynamics library (the one ``manip build`` makes) is
opened with ``dlopen``. The harness ``benchmarks/pinocchio_cpp/harness.cpp`` is compiled here with
``g++ -O3`` against Pinocchio's headers and libraries from the pip ``pin`` wheel
(``site-packages/cmeel.prefix``), Debian's Eigen (``/usr/include/eigen3``) and the urdfdom headers of the
``cmeel-urdfdom-headers`` wheel, header-only (no precompiled template instances), and cached by its hash.

Both sides run on the same N random states (q, qd, qdd uniform in [-2, 2], seed 2027): ``rne`` vs
``rnea``, ``accel`` vs ``aba`` (on our rne's torques), ``inertia`` vs ``crba`` (its upper triangle),
``gravload`` vs ``computeGeneralizedGravity`` and ``coriolis`` vs ``computeCoriolisMatrix``; friction
is set to 0 in our parameter vector (Pinocchio has none). Reported: ns per state (best of the repeats),
the ratio Pinocchio / ours and the largest difference relative to max(1, |ours|). The table goes to
stdout and ``benchmarks/results/pinocchio_cpp.md``.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from model import InertiaConsistencyWarning, Robot, load_description
from model.codegen import cache_dir
from model.urdf_export import urdf_text

__all__ = ["harness_binary", "main", "measure"]

HERE = Path(__file__).resolve().parent
HARNESS = HERE / "pinocchio_cpp" / "harness.cpp"
RESULTS = HERE / "results" / "pinocchio_cpp.md"
DEFAULT_ROBOTS = ("puma560", "ur5", "panda", "chain12", "chain25")
QUANTITIES = ("rne", "accel", "inertia", "gravload", "coriolis")
PEER = {"rne": "rnea", "accel": "aba", "inertia": "crba", "gravload": "computeGeneralizedGravity",
        "coriolis": "computeCoriolisMatrix"}
#: Preprocessor definitions Pinocchio's CMake config gives its users (lib/cmake/pinocchio), minus
#: PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION: the algorithms are compiled here, at -O3.
DEFINES = ("PINOCCHIO_WITH_URDFDOM", "BOOST_MPL_LIMIT_LIST_SIZE=30", "BOOST_MPL_LIMIT_VECTOR_SIZE=30",
           "BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "BOOST_FUSION_INVOKE_MAX_ARITY=12")


def say(text: str) -> None:
    print(text, flush=True)


def _prefix() -> Path:
    import pinocchio

    prefix = Path(pinocchio.__file__).resolve()  # .../site-packages/cmeel.prefix/lib/python3.X/site-packages/pinocchio
    while prefix.name != "cmeel.prefix":
        if prefix == prefix.parent:
            raise SystemExit(f"bench_pinocchio_cpp: Pinocchio at {pinocchio.__file__} is not the pip wheel (no cmeel.prefix)")
        prefix = prefix.parent
    return prefix


def harness_binary() -> Path:
    """The compiled harness (built on first use, cached under the source's and the compiler's hash)."""
    prefix = _prefix()
    eigen = Path("/usr/include/eigen3")
    urdf_headers = prefix / "include" / "urdfdom_headers"
    for need, hint in ((eigen, "apt-get install libeigen3-dev"), (urdf_headers, "pip install cmeel-urdfdom-headers")):
        if not need.is_dir():
            raise SystemExit(f"bench_pinocchio_cpp: {need} is missing ({hint})")
    cxx = os.environ.get("CXX", "g++")
    cmd = [cxx, "-std=c++17", "-O3", "-DNDEBUG", f"-I{eigen}", f"-I{prefix / 'include'}", f"-I{urdf_headers}",
           *[f"-D{d}" for d in DEFINES], str(HARNESS), f"-L{prefix / 'lib'}", f"-Wl,-rpath,{prefix / 'lib'}",
           "-lpinocchio_parsers", "-lpinocchio_default", "-lurdfdom_model", "-ldl"]
    key = hashlib.sha256((HARNESS.read_text() + " ".join(cmd)).encode()).hexdigest()[:16]
    binary = cache_dir() / f"pinocchio-cpp-harness-{key}"
    if not binary.is_file():
        say(f"compiling the harness ({cxx} -O3, about 1-3 minutes) ...")
        tmp = binary.with_suffix(".tmp")
        proc = subprocess.run([*cmd, "-o", str(tmp)], capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise SystemExit(f"bench_pinocchio_cpp: the harness does not compile:\n{proc.stderr[-3000:]}")
        os.replace(tmp, binary)
    return binary


def _description(name: str):
    if name.startswith("chain"):
        from tests.support.chains import random_chain

        return random_chain(int(name[5:]), seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_description(name)


def measure(name: str, N: int, repeat: int, binary: Path) -> dict[str, tuple[float, float, float]]:
    """``{quantity: (ours ns, Pinocchio ns, max rel. difference)}`` for robot ``name`` on N states."""
    import pinocchio as pin

    from tests.support.urdf_references import pin_q

    desc = _description(name)
    robot = Robot(desc)
    info = robot.dynamics.compile()
    n = desc.n
    zero = np.zeros(n)
    p = robot.parameters.with_friction(zero, zero, zero).vector
    rng = np.random.default_rng(2027)
    Q, QD, QDD = rng.uniform(-2.0, 2.0, (3, N, n))
    with tempfile.TemporaryDirectory(prefix="bench-pin-cpp-") as tmp:
        folder = Path(tmp)
        urdf = folder / f"{name}.urdf"
        urdf.write_text(urdf_text(desc))
        model = pin.buildModelFromUrdf(str(urdf))
        if model.nv != n:
            raise SystemExit(f"bench_pinocchio_cpp: {name}: Pinocchio reads {model.nv} joints, we have {n}")
        QP = np.array([pin_q(model, q) for q in Q])
        arrays = {"qpin": QP, "q": Q, "qd": QD, "qdd": QDD, "p": p, "gravity": np.asarray(desc.gravity, float),
                  "armature": np.array([lk.gear_ratio ** 2 * lk.motor_inertia for lk in desc.links])}
        for key, arr in arrays.items():
            np.ascontiguousarray(arr, dtype=np.float64).tofile(folder / key)
        proc = subprocess.run([str(binary), str(urdf), str(info.library), str(folder), str(N), str(repeat)],
                              capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"bench_pinocchio_cpp: the harness failed on {name}:\n{proc.stderr[-3000:]}")
    out = {}
    for line in proc.stdout.splitlines():
        quantity, ours, theirs, diff = line.split()
        out[quantity] = (float(ours), float(theirs), float(diff))
    return out


def _versions() -> str:
    import casadi
    import pinocchio

    gcc = subprocess.run([os.environ.get("CXX", "g++"), "--version"], capture_output=True, text=True).stdout.splitlines()
    return (f"{platform.machine()}, {os.cpu_count()} CPUs, {gcc[0] if gcc else 'g++'}, CasADi {casadi.__version__}, "
            f"Pinocchio {pinocchio.__version__}, Python {sys.version.split()[0]}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-N", type=int, default=10_000, help="states (default 10000)")
    parser.add_argument("--repeat", type=int, default=5, help="timed passes over the states, best kept (default 5)")
    parser.add_argument("--robots", nargs="+", default=list(DEFAULT_ROBOTS), help="robots (chainN: random N-joint chain)")
    parser.add_argument("--no-write", action="store_true", help=f"do not write {RESULTS.relative_to(HERE.parent)}")
    args = parser.parse_args(argv)
    if shutil.which(os.environ.get("CXX", "g++")) is None:
        say("bench_pinocchio_cpp: no C++ compiler (g++ or $CXX): skipped")
        return 0
    binary = harness_binary()
    load_before = os.getloadavg()
    rows = []
    for name in args.robots:
        say(f"{name}: measuring ({args.N} states, best of {args.repeat}), load {os.getloadavg()[0]:.2f} ...")
        result = measure(name, args.N, args.repeat, binary)
        n = _description(name).n
        for quantity in QUANTITIES:
            ours, theirs, diff = result[quantity]
            rows.append((name, n, quantity, ours, theirs, diff))
            say(f"  {quantity:9s} ours {ours:9.1f} ns   pinocchio {PEER[quantity]:26s} {theirs:9.1f} ns   "
                f"x{theirs / ours:5.2f}   max rel. diff {diff:.1e}")
    load_after = os.getloadavg()
    table = ["| robot | n | quantity | ours ns | Pinocchio C++ ns | Pinocchio / ours | max rel. diff |",
             "|---|---|---|---|---|---|---|"]
    table += [f"| {r} | {n} | {q} vs {PEER[q]} | {o:.1f} | {t:.1f} | x{t / o:.2f} | {d:.1e} |"
              for r, n, q, o, t, d in rows]
    text = "\n".join([
        "# Generated C against Pinocchio's C++, called from C++ in one run",
        "",
        f"`python -m benchmarks.bench_pinocchio_cpp -N {args.N} --repeat {args.repeat}` on {_versions()}. "
        "Harness `benchmarks/pinocchio_cpp/harness.cpp` compiled with g++ -O3 against the pip wheel's Pinocchio "
        "headers (template algorithms compiled here) and Debian's Eigen; our library as `manip build` makes it "
        "(its own -O1/-O2 policy, `-ffp-contract=off`). Same URDF (exported by `model.urdf_export`), same random "
        "states, friction 0 in our parameters; ns per state, best of the repeats, ours and Pinocchio's timed alternately. "
        f"Load average (1, 5, 15 min) before {tuple(round(x, 2) for x in load_before)}, after "
        f"{tuple(round(x, 2) for x in load_after)}: the machine was shared, so compare the ratios (same run, "
        "interleaved per quantity).",
        "",
        *table,
        "",
    ])
    say("\n" + text)
    if not args.no_write:
        RESULTS.write_text(text)
        say(f"written to {RESULTS}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
