"""The composite-rigid-body inertia (model/dynamics/crba.py), the recursive Coriolis matrix
(model/dynamics/coriolis_recursive.py) and their choice in the compiled set.

References: Pinocchio's ``crba`` (written independently; tolerance 1e-10 relative to max(1, |B|):
both sides are exact algorithms in double precision, measured to agree to ~1e-15), the Newton-Euler
columns B was formed from before (``_inertia_columns_ne``, 1e-12 relative: the issue's bound for
"numbers unchanged"; the same for C against ``1/2 (Bdot + J - J^T)`` and Pinocchio's
``computeCoriolisMatrix``), and physical invariants (symmetry, exactly; positive definiteness).
"""

from __future__ import annotations

import warnings

import casadi as ca
import numpy as np
import pinocchio as pin  # a mandatory reference: a missing Pinocchio fails, never skips
import pytest

from model import InertiaConsistencyWarning, load_description, load_robot
from model.dynamics.coriolis_recursive import coriolis_recursive_sx, coriolis_world_sx
from model.dynamics.crba import crba_sx, crba_world_sx
from model.dynamics.symbolic import _inertia_columns_ne, _Symbols, coriolis_ne_sx
from tests.support.chains import random_chain
from tests.support.references import friction_reference, pinocchio_model, random_payload_parameters, symmetric_from_upper

CASES = ["puma560", "ur5", "panda", "scara", "chain9"]


def _desc(name):
    if name.startswith("chain"):
        return random_chain(int(name[5:]), seed=4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_description(name)


def _close(actual, expected, rtol):
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * max(1.0, float(np.abs(expected).max())))


@pytest.fixture(scope="module", params=CASES)
def functions(request):
    desc = _desc(request.param)
    s = _Symbols(desc)
    crba = ca.Function("crba", [s.q, s.p], [crba_sx(desc, s.q, s.params)])
    cols = _inertia_columns_ne(desc, "reflected", s.q, s.params)
    B_ne = ca.tril(cols) + ca.tril(cols, False).T
    ne = ca.Function("ne", [s.q, s.p], [B_ne])
    return desc, crba, ne, s, B_ne


def test_crba_equals_pinocchio_and_the_newton_euler_columns(functions):
    desc, crba, ne, s, _ = functions
    world = ca.Function("world", [s.q, s.p], [crba_world_sx(desc, s.q, s.params)])
    model = pinocchio_model(desc)
    data = model.createData()
    rng = np.random.default_rng(41)
    for _ in range(10):  # with a random payload: symmetric, positive definite, the NE columns' B
        q = rng.uniform(-3.0, 3.0, desc.n)
        p = random_payload_parameters(desc, rng)
        B = np.array(crba(q, p))
        np.testing.assert_array_equal(B, B.T)
        assert np.linalg.eigvalsh(B).min() > 0
        _close(B, np.array(ne(q, p)), 1e-12)
        Bw = np.array(world(q, p))
        np.testing.assert_array_equal(Bw, Bw.T)
        _close(Bw, np.array(ne(q, p)), 1e-12)
    for _ in range(5):  # Pinocchio without payload (the model it is given has none)
        q = rng.uniform(-3.0, 3.0, desc.n)
        B = np.array(crba(q, _default_p(desc)))
        _close(B, symmetric_from_upper(pin.crba(model, data, q)), 1e-10)


def test_recursive_coriolis_equals_the_christoffel_formula_and_pinocchio(functions):
    desc, _, _, s, B_ne = functions
    body = ca.Function("body", [s.q, s.qd, s.p], [coriolis_recursive_sx(desc, s.q, s.qd, s.params)])
    world = ca.Function("world", [s.q, s.qd, s.p], [coriolis_world_sx(desc, s.q, s.qd, s.params)])
    christoffel = ca.Function("c", [s.q, s.qd, s.p], [coriolis_ne_sx(desc, "reflected", s.q, s.qd, s.params, B_ne)])
    model = pinocchio_model(desc)
    data = model.createData()
    rng = np.random.default_rng(43)
    for _ in range(8):
        q, qd = rng.uniform(-3.0, 3.0, (2, desc.n))
        p = random_payload_parameters(desc, rng)
        expected = np.array(christoffel(q, qd, p))
        _close(np.array(body(q, qd, p)), expected, 1e-12)
        _close(np.array(world(q, qd, p)), expected, 1e-12)
        p0 = _default_p(desc)
        _close(np.array(world(q, qd, p0)), pin.computeCoriolisMatrix(model, data, q, qd), 1e-10)
    # negative control: C^T in place of C (equal only where C is symmetric) is caught
    assert np.abs(np.array(world(q, qd, p)).T - expected).max() > 1e-6


def test_aba_equals_the_ldl_solve_and_pinocchio(functions):
    from model.dynamics.aba import aba_world_sx
    from model.dynamics.symbolic import _accel_sx

    desc, _, _, s, _ = functions
    aba = ca.Function("aba", [s.q, s.qd, s.tau, s.p], [aba_world_sx(desc, s.q, s.qd, s.tau - s.friction(s.qd), s.params)])
    ldl = ca.Function("ldl", [s.q, s.qd, s.tau, s.p], [_accel_sx(desc, "reflected", s)])
    model = pinocchio_model(desc)
    data = model.createData()
    rng = np.random.default_rng(45)
    for _ in range(8):
        q, qd, tau = rng.uniform(-2.0, 2.0, (3, desc.n))
        p = random_payload_parameters(desc, rng)
        _close(np.array(aba(q, qd, tau, p)).ravel(), np.array(ldl(q, qd, tau, p)).ravel(), 1e-12)
        p0 = _default_p(desc)
        F = friction_reference(desc, qd)
        _close(np.array(aba(q, qd, tau, p0)).ravel(), pin.aba(model, data, q, qd, tau - F), 1e-10)
    # negative control: the payload enters (left out, the accelerations differ well beyond the tolerance)
    assert np.abs(np.array(aba(q, qd, tau, p)) - np.array(aba(q, qd, tau, p0))).max() > 1e-6


def _default_p(desc):
    from model.dynamics import DynamicsParameters, parameter_layout

    return DynamicsParameters.defaults(parameter_layout(desc)).vector


def test_a_wrong_inertia_is_caught(functions):
    """Negative control: one body's inertia changed by 1 % moves B beyond the tolerance."""
    import dataclasses

    desc, crba, *_ = functions
    links = list(desc.links)
    links[-1] = dataclasses.replace(links[-1], mass=links[-1].mass * 1.01)
    other = dataclasses.replace(desc, links=tuple(links))
    s = _Symbols(other)
    wrong = ca.Function("w", [s.q, s.p], [crba_sx(other, s.q, s.params)])
    q = np.full(desc.n, 0.4)
    p = _default_p(desc)
    assert np.abs(np.array(wrong(q, p)) - np.array(crba(q, p))).max() > 1e-8


@pytest.mark.parametrize("name", ["puma560", "panda"])
def test_the_compiled_set_takes_the_smaller_formulation_and_says_so(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot(name)
        full = load_robot(name, motor_model="full")
    f = robot.dynamics.functions
    assert f.formulations.startswith("inertia: composite-rigid-body (")  # the fewest operations on these arms
    assert "coriolis: 1/2 (Bdot + J - J^T) (" in f.formulations
    said = full.dynamics.functions.formulations  # rotors as bodies: the Newton-Euler forms only
    assert said.startswith("inertia: Newton-Euler columns (") and "frame 0" not in said
    rng = np.random.default_rng(42)
    q, qd = rng.uniform(-2.0, 2.0, (2, robot.n))
    p = robot.parameters.vector
    lag = f.lagrange  # the independent Lagrange model: B and C (Christoffel), 1e-12
    _close(np.array(f.inertia(q, p)), np.array(lag.inertia_lagrange(q, p)), 1e-12)
    _close(np.array(f.coriolis(q, qd, p)), np.array(lag.coriolis_lagrange(q, qd, p)), 1e-12)


def test_a_long_chain_takes_the_frame_0_forms():
    from model.dynamics import build_functions

    desc = random_chain(16, seed=2)
    f = build_functions(desc)
    assert f.formulations.startswith("inertia: composite-rigid-body in frame 0 (")
    assert "coriolis: recursive in frame 0 (" in f.formulations
    model = pinocchio_model(desc)
    data = model.createData()
    rng = np.random.default_rng(44)
    q, qd = rng.uniform(-2.0, 2.0, (2, desc.n))
    p = _default_p(desc)
    _close(np.array(f.inertia(q, p)), symmetric_from_upper(pin.crba(model, data, q)), 1e-10)
    _close(np.array(f.coriolis(q, qd, p)), pin.computeCoriolisMatrix(model, data, q, qd), 1e-10)
    tau = rng.uniform(-2.0, 2.0, desc.n)
    F = friction_reference(desc, qd)
    _close(np.array(f.accel(q, qd, tau, p)).ravel(), pin.aba(model, data, q, qd, tau - F), 1e-10)


def test_manip_build_says_which_formulation(capsys, tmp_path, monkeypatch):
    from workbench.cli import main

    monkeypatch.setenv("MANIP_CACHE_DIR", str(tmp_path))
    assert main(["build", "planar2r"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("planar2r: inertia: ")]
    assert len(lines) == 1 and "; accel: " in lines[0] and "; coriolis: " in lines[0] and "operations" in lines[0]
