"""Branch-free Coulomb friction (model/dynamics/motors.py:friction_sx): the same bits as the choice it replaces.

References: the choice ``Tc+ if qd > 0 else Tc- if qd < 0 else 0`` written here with CasADi's
``if_else`` (the formulation before), compared bit for bit (x * 1 = x, x * 0 = +-0, y + +-0 = y:
no rounding differs); and ``tests/support/references.py:friction_reference`` (NumPy, written
independently), to 1e-15 relative (one rounding of G^2 B qd may be ordered differently).
"""

from __future__ import annotations

import re
import warnings

import casadi as ca
import numpy as np
import pytest

from model import InertiaConsistencyWarning, load_robot
from model.codegen import generate_c
from model.dynamics.motors import friction_sx, viscous_friction_sx
from tests.support.references import friction_reference


@pytest.fixture(scope="module", params=["puma560", "scara", "panda"])
def robot(request):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot(request.param)
    n = robot.n
    rng = np.random.default_rng(31)  # every joint with viscous and unequal Coulomb friction
    return robot.with_parameters(robot.parameters.with_friction(rng.uniform(0.1, 2.0, n) * 1e-3,
                                                                rng.uniform(0.1, 1.0, n), -rng.uniform(0.1, 1.0, n)))


def _choice(robot):
    """The friction of the if_else formulation, as a CasADi Function of qd and the three coefficient vectors."""
    n = robot.n
    G = np.array([lk.gear_ratio for lk in robot.description.links])
    qd, visc, tcp, tcn = (ca.SX.sym(k, n) for k in ("qd", "visc", "tcp", "tcn"))
    terms = [v + abs(g) * ca.if_else(qd[i] > 0, tcp[i], ca.if_else(qd[i] < 0, tcn[i], 0))
             for i, (g, v) in enumerate(zip(G, viscous_friction_sx(G, qd, visc)))]
    branch_free = friction_sx(G, qd, visc, tcp, tcn)
    return ca.Function("choice", [qd, visc, tcp, tcn], [ca.vertcat(*terms)]), \
        ca.Function("branch_free", [qd, visc, tcp, tcn], [branch_free])


def _velocities(n):
    rng = np.random.default_rng(32)
    rows = [np.zeros(n), -np.zeros(n), np.full(n, 1e-300), np.full(n, -1e-300)]
    rows += list(rng.uniform(-3.0, 3.0, (20, n)))
    rows += [np.where(rng.random(n) < 0.5, 0.0, rng.uniform(-1, 1, n)) for _ in range(10)]  # some joints at rest
    return rows


def test_branch_free_friction_has_the_bits_of_the_choice(robot):
    choice, branch_free = _choice(robot)
    p = robot.parameters
    coeffs = [p.field(f) for f in ("viscous_friction", "coulomb_friction_pos", "coulomb_friction_neg")]
    for qd in _velocities(robot.n):
        expected = np.array(choice(qd, *coeffs)).ravel()
        np.testing.assert_array_equal(np.array(branch_free(qd, *coeffs)).ravel(), expected)
        compiled = robot.friction(qd)
        np.testing.assert_array_equal(compiled, expected)
        assert not np.signbit(compiled[qd == 0]).any()  # +0 at rest, as the choice gives
        reference = friction_reference(_desc_with(robot), qd)
        np.testing.assert_allclose(compiled, reference, rtol=1e-15, atol=1e-300)
    # negative control: a flipped Coulomb sign is caught by the same comparison
    flipped = np.array(choice(np.ones(robot.n), coeffs[0], coeffs[2], coeffs[1])).ravel()
    assert not np.array_equal(flipped, robot.friction(np.ones(robot.n)))


def _desc_with(robot):
    """The description carrying the robot's (randomised) friction, for friction_reference."""
    import dataclasses

    p = robot.parameters
    links = tuple(dataclasses.replace(lk, viscous_friction=float(v), coulomb_friction=(float(a), float(b)))
                  for lk, v, a, b in zip(robot.description.links, p.field("viscous_friction"),
                                         p.field("coulomb_friction_pos"), p.field("coulomb_friction_neg")))
    return dataclasses.replace(robot.description, links=links)


def _choices(code: str) -> list[str]:
    """Lines with a conditional besides CasADi's own argument checks (``arg[1]? arg[1][k] : 0``)."""
    body = code[code.index("casadi_f0("):]
    return [line for line in body.splitlines() if "?" in line and not re.search(r"arg\[\d+\]\?", line)]


def test_the_generated_friction_has_no_choice(robot, tmp_path):
    info = robot.dynamics.compile()
    src = info.library.with_name(info.library.stem + "-src") / "friction.c"
    assert not _choices(src.read_text())
    # negative control: the if_else formulation does generate conditionals
    choice, _ = _choice(robot)
    assert _choices(generate_c([choice], tmp_path / "choice.c").read_text())
