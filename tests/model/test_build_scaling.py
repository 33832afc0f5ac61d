"""Builds that scale: Coriolis from Newton-Euler, progress, --force, the shared ABI header, a 12-joint chain.

References: the symbolic Lagrange model (Christoffel symbols of the expanded
B(q), written independently of Newton-Euler), Pinocchio, and physical
invariants. Tolerances are stated where used.
"""

from __future__ import annotations

import re
import subprocess
import warnings

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

from tests.support.chains import random_chain
from model import InertiaConsistencyWarning, load_description
from model.codegen import ABI_HEADER, CASADI_INT, CASADI_REAL, BuildEvent, build_library, find_compiler, generate_c
from model.dynamics import MOTOR_MODELS, Dynamics, build_functions, parameter_layout
from tests.support.references import (available_robots, friction_reference, pinocchio_model, random_payload_parameters,
                        symmetric_from_upper)
from workbench.cli import main

# Newton-Euler and Lagrange C are two exact formulas evaluated in double precision through
# O(10^2-10^4) operations: they agree to ~1e-15 relative (measured <= 2.3e-15 on the built-ins).
# 1e-12 leaves room for cancellation and catches any wrong term (>= 1e-3 relative).
RTOL = 1e-12


def _desc(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_description(name)


def _close(actual, expected, rtol=RTOL):
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * scale)


CASES = [(r, m) for r in available_robots() for m in MOTOR_MODELS] + [("chain5", "reflected"), ("chain5", "full")]


@pytest.fixture(scope="module", params=CASES, ids=lambda rm: f"{rm[0]}-{rm[1]}")
def functions(request):
    name, motor_model = request.param
    desc = random_chain(5, seed=3) if name == "chain5" else _desc(name)
    return desc, build_functions(desc, motor_model)


def test_newton_euler_inertia_coriolis_gravload_equal_lagrange(functions):
    desc, f = functions
    lag = f.lagrange
    rng = np.random.default_rng(51)
    for _ in range(5):
        q, qd = rng.uniform(-2, 2, (2, desc.n))
        p = random_payload_parameters(desc, rng)  # it enters B, so it must enter C
        _close(np.array(f.coriolis(q, qd, p)), np.array(lag.coriolis_lagrange(q, qd, p)))
        _close(np.array(f.inertia(q, p)), np.array(lag.inertia_lagrange(q, p)))
        _close(np.array(f.gravload(q, p)), np.array(lag.gravload_lagrange(q, p)))


def test_coriolis_times_qd_is_the_velocity_part_of_newton_euler(functions):
    """C qd = rne(q, qd, 0) - g - F: the Coriolis vector of the recursion, which no derivative enters."""
    desc, f = functions
    rng = np.random.default_rng(52)
    for _ in range(5):
        q, qd = rng.uniform(-2, 2, (2, desc.n))
        p = random_payload_parameters(desc, rng)
        bias = np.array(f.rne(q, qd, np.zeros(desc.n), p)).ravel() - np.array(f.gravload(q, p)).ravel()
        bias -= np.array(f.friction(qd, p)).ravel()
        _close(np.array(f.coriolis(q, qd, p)) @ qd, bias)


def test_lagrange_bdot_minus_2c_newton_euler_is_skew_symmetric(functions):
    """Bdot from the Lagrange B (independent of the NE passes); tolerance: rounding, 1e-12 of |N|."""
    desc, f = functions
    q, qd = ca.SX.sym("q", desc.n), ca.SX.sym("qd", desc.n)
    rng = np.random.default_rng(53)
    p = random_payload_parameters(desc, rng)
    Bdot = ca.Function("Bdot", [q, qd], [ca.jtimes(f.lagrange.inertia_lagrange(q, p), q, qd)])
    for _ in range(5):
        qv, qdv = rng.uniform(-2, 2, (2, desc.n))
        N = np.array(Bdot(qv, qdv)) - 2 * np.array(f.coriolis(qv, qdv, p))
        assert np.abs(N).max() > 1e-6  # not vacuous
        np.testing.assert_allclose(N + N.T, 0.0, atol=1e-12 * max(1.0, np.abs(N).max()))


def test_a_slightly_wrong_coriolis_fails_the_skew_check():
    """Negative control: C scaled by 1.001 breaks the skew check by ~1e-3, far above its 1e-12 tolerance."""
    desc = _desc("puma560")
    f = build_functions(desc)
    q, qd = ca.SX.sym("q", desc.n), ca.SX.sym("qd", desc.n)
    p = parameter_layout(desc).defaults
    Bdot = ca.Function("Bdot", [q, qd], [ca.jtimes(f.lagrange.inertia_lagrange(q, p), q, qd)])
    qv, qdv = np.random.default_rng(54).uniform(-2, 2, (2, desc.n))
    N = np.array(Bdot(qv, qdv)) - 2 * 1.001 * np.array(f.coriolis(qv, qdv, p))
    assert np.abs(N + N.T).max() > 1e-5 * np.abs(N).max()


def test_the_compiled_set_is_built_without_the_lagrange_model():
    f = build_functions(random_chain(4, seed=2))
    assert "lagrange" not in f.__dict__  # the cached_property has not run
    assert {"inertia", "coriolis", "gravload", "friction", "rne", "accel"} == set(f.as_dict(lagrange=False))


def test_progress_reports_every_stage_then_the_cache_hit(tmp_path, monkeypatch):
    monkeypatch.setenv("MANIP_CACHE_DIR", str(tmp_path))
    events: list[BuildEvent] = []
    info = Dynamics(_desc("planar2r")).compile(progress=events.append)
    stages = [e.stage for e in events]
    assert not info.cached
    for stage in ("symbolic", "generate", "compile", "link", "done"):
        assert stage in stages, stages
    assert stages.index("symbolic") < stages.index("generate") < stages.index("link") < stages.index("done")
    assert all(e.message.startswith("planar2r-reflected: ") for e in events)  # names the robot
    generated = next(e.message for e in events if e.stage == "generate")
    assert re.search(r"\d+ kB of C", generated)  # the size
    compiled = [e for e in events if e.stage == "compile" and e.done]
    assert [e.done for e in compiled] == list(range(1, compiled[0].total + 1))  # one event per unit
    events.clear()
    assert Dynamics(_desc("planar2r")).compile(progress=events.append).cached
    assert [e.stage for e in events] == ["cached"]


def test_force_rebuilds_and_the_cli_prints_the_stages(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MANIP_CACHE_DIR", str(tmp_path))
    assert main(["build", "planar2r"]) == 0
    first = capsys.readouterr()
    assert "cold build" in first.out and "manip build: planar2r-reflected: compiling" in first.err
    library = next(tmp_path.glob("planar2r-reflected-*.so"))
    mtime = library.stat().st_mtime_ns
    assert main(["build", "planar2r"]) == 0
    assert "loaded from the cache" in capsys.readouterr().out and library.stat().st_mtime_ns == mtime
    assert main(["build", "planar2r", "--force"]) == 0
    forced = capsys.readouterr()
    assert "cold build" in forced.out and "linking" in forced.err
    assert library.stat().st_mtime_ns > mtime


def test_the_cache_key_follows_the_model_sources(tmp_path, monkeypatch):
    monkeypatch.setenv("MANIP_CACHE_DIR", str(tmp_path))
    first = Dynamics(_desc("planar2r")).compile()
    monkeypatch.setattr("model.dynamics.core.source_fingerprint", lambda: "an edited model source")
    second = Dynamics(_desc("planar2r")).compile()
    assert not second.cached and second.key != first.key


def test_the_shared_abi_header_is_included_and_checked(tmp_path):
    header = ABI_HEADER.read_text()
    assert re.search(rf"#define casadi_int {CASADI_INT}\n", header)
    assert re.search(rf"#define casadi_real {CASADI_REAL}\n", header)
    assert "_Static_assert(sizeof(casadi_int) == 8" in header
    x = ca.SX.sym("x", 2)
    source = generate_c([ca.Function("twice", [x], [2 * x])], tmp_path / "twice.c")
    text = source.read_text()
    assert text.index('#include "casadi_abi.h"') < text.index("#define casadi_int")  # ours first
    assert (tmp_path / "casadi_abi.h").read_text() == header
    cc = find_compiler()
    ok = subprocess.run([cc, "-std=c99", "-Wall", "-Werror", "-c", str(source), "-o", str(tmp_path / "a.o")],
                        capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    # the assertion bites: the same file with a 4-byte casadi_int does not compile
    (tmp_path / "casadi_abi.h").write_text(header.replace(f"#define casadi_int {CASADI_INT}", "#define casadi_int int"))
    bad = subprocess.run([cc, "-std=c99", "-c", str(source), "-o", str(tmp_path / "b.o")], capture_output=True, text=True)
    assert bad.returncode != 0 and "casadi_int must be the 8-byte integer" in bad.stderr


def test_fmu_sources_carry_the_abi_header(tmp_path):
    from fmu.build import generate_sources
    from fmu.variables import trivial_spec

    _, _, c_files = generate_sources(trivial_spec(1e-3, 1), tmp_path)
    generated = next(name for name in c_files if name.endswith("_casadi.c"))
    assert '#include "casadi_abi.h"' in (tmp_path / generated).read_text()
    assert '#include "casadi_abi.h"' in (tmp_path / generated).with_suffix(".h").read_text()
    assert (tmp_path / "casadi_abi.h").read_text() == ABI_HEADER.read_text()


def test_every_function_gets_its_own_unit_with_a_size_chosen_optimisation(tmp_path):
    x = ca.SX.sym("x", 3)
    small = ca.Function("small", [x], [ca.sin(x)])
    big = ca.Function("big", [x], [ca.cse(sum((ca.sin(k * x) for k in range(1, 700)), ca.SX.zeros(3, 1)))])
    library, info = build_library("units", "units-test", lambda: [small, big], directory=tmp_path)
    levels = {u.name: u.optimisation for u in info.units}
    assert big.n_instructions() > 1500 > small.n_instructions()
    assert levels == {"small": "-O2", "big": "-O1"}
    _close(library.evaluate("big", [np.array([0.1, 0.2, 0.3])], 1)[0][0], np.array(big([0.1, 0.2, 0.3])).ravel(), 1e-14)


@pytest.mark.slow
def test_a_12_joint_chain_builds_and_matches_pinocchio():
    """Cold build of all six Functions of a 12-joint random chain; tolerance as tests/model/test_dynamics_pinocchio.py.

    1e-10 of the largest value: the same quantities through O(10^4) operations in double precision.
    """
    desc = random_chain(12, seed=1)
    dyn = Dynamics(desc)
    info = dyn.compile()
    assert {u.name for u in info.units} == {"inertia", "coriolis", "gravload", "friction", "rne", "accel"}
    model = pinocchio_model(desc)
    data = model.createData()
    rng = np.random.default_rng(55)
    Q, QD, QDD = rng.uniform(-2, 2, (3, 8, 12))
    F = np.array([friction_reference(desc, v) for v in QD])
    tau = dyn.rne_batch(Q, QD, QDD)
    ref_tau = np.array([pin.rnea(model, data, q, qd, qdd) for q, qd, qdd in zip(Q, QD, QDD)]) + F
    _close(tau, ref_tau, 1e-10)
    qdd = dyn.accel_batch(Q, QD, tau)
    _close(qdd, QDD, 1e-10)
    _close(qdd, np.array([pin.aba(model, data, q, qd, t) for q, qd, t in zip(Q, QD, tau - F)]), 1e-10)
    q, qd = Q[0], QD[0]
    _close(dyn.inertia(q), symmetric_from_upper(pin.crba(model, data, q)), 1e-10)
    _close(dyn.coriolis(q, qd), pin.computeCoriolisMatrix(model, data, q, qd), 1e-10)
    _close(dyn.gravload(q), pin.computeGeneralizedGravity(model, data, q), 1e-10)
