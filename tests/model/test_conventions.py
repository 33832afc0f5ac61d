"""Modified DH, base, tool, flip and the "urdf" chain form against the Robotics Toolbox and Pinocchio.

References:

* the Robotics Toolbox (``RevoluteMDH``/``PrismaticMDH``, ``flip``, ``DHRobot(base=, tool=)``,
  ``rne_python`` and its ``inertia``/``coriolis``/``gravload``, built on rne);
* Pinocchio built from the same data (``tests/support/references.py``) or, for the "urdf" form,
  built by hand with ``addJoint``/``appendBodyToJoint`` from the origins and axes;
* the standard-DH original of a robot rewritten in the "urdf" form.

Tolerances: kinematics 1e-12 absolute (m, rad; O(10) products of unit-size
rotations, round-off ~1e-15); dynamics 1e-10 relative to the largest reference
value (at least 1), as in tests/model/test_dynamics_pinocchio.py: both sides do
O(100) double operations; any wrong term (a missing rotor, a com in the wrong
frame, gravity not rotated) is >= 1e-3 relative on these states.

The dynamics are evaluated from the symbolic CasADi expressions (``rne_sx``,
``lagrange_model``) with the description's default parameters: no C compiler needed.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import pinocchio as pin
import roboticstoolbox as rtb
import pytest

from model import InertiaConsistencyWarning, Robot
from model.chain import dh_standard
from model.description import description_from_dict, rpy_matrix
from model.loading import load_description
from model.dynamics.lagrange import lagrange_model
from model.dynamics.newton_euler import rne_sx
from model.dynamics.parameters import parameter_layout, split_parameters
from tests.support.references import pinocchio_model, rtb_robot, symmetric_from_upper

TOL_KIN = 1e-12
RTOL_DYN = 1e-10
DATA = Path(__file__).resolve().parents[1] / "data"


def close(actual, expected, rtol=RTOL_DYN):
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * scale)


class SymbolicDynamics:
    """rne (Newton-Euler), inertia/coriolis/gravload (Lagrange) of a description, default parameters."""

    def __init__(self, desc, motor_model="reflected"):
        n = desc.n
        layout = parameter_layout(desc)
        q, qd, qdd, p = (ca.SX.sym(s, k) for s, k in (("q", n), ("qd", n), ("qdd", n), ("p", layout.size)))
        params = split_parameters(layout, p)
        lag = lagrange_model(desc, motor_model, q, qd, params)
        self._p = layout.defaults
        self._rne = ca.Function("rne", [q, qd, qdd, p], [rne_sx(desc, motor_model, q, qd, qdd, params)])
        self._B = ca.Function("B", [q, p], [lag.B])
        self._C = ca.Function("C", [q, qd, p], [lag.C])
        self._g = ca.Function("g", [q, p], [lag.g])

    def rne(self, q, qd, qdd):
        return np.array(self._rne(q, qd, qdd, self._p)).ravel()

    def inertia(self, q):
        return np.array(self._B(q, self._p))

    def coriolis(self, q, qd):
        return np.array(self._C(q, qd, self._p))

    def gravload(self, q):
        return np.array(self._g(q, self._p)).ravel()


def states(n, seed, count=4, span=2.0):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-span, span, (3, n)) for _ in range(count)]


def check_kinematics_against_rtb(robot, ref, qs):
    for q in qs:
        assert np.abs(robot.fkine(q) - ref.fkine(q).A).max() <= TOL_KIN
        assert np.abs(robot.jacob0(q) - ref.jacob0(q)).max() <= TOL_KIN
        assert np.abs(robot.jacobe(q) - ref.jacobe(q)).max() <= TOL_KIN


def check_dynamics_against_rtb(dyn, ref, n, seed):
    """rne against RTB's rne_python; B, C qd and g against RTB's own and against rne_python passes
    (B e_j = rne(q, 0, e_j) without gravity, C qd = rne(q, qd, 0) without gravity, g = rne(q, 0, 0))."""
    zero, no_g = np.zeros(n), np.zeros(3)
    for q, qd, qdd in states(n, seed):
        close(dyn.rne(q, qd, qdd), ref.rne_python(q, qd, qdd))
        B_python = np.column_stack([ref.rne_python(q, zero, e, gravity=no_g) for e in np.eye(n)])
        for B in (ref.inertia(q), B_python):
            close(dyn.inertia(q), B)
        for Cqd in (ref.coriolis(q, qd) @ qd, ref.rne_python(q, qd, zero, gravity=no_g)):
            close(dyn.coriolis(q, qd) @ qd, Cqd)
        for g in (ref.gravload(q), ref.rne_python(q, zero, zero)):
            close(dyn.gravload(q), g)


def check_against_pinocchio(robot, dyn, model, seed):
    data = model.createData()
    tool = model.getFrameId("tool")
    for q, qd, qdd in states(robot.n, seed):
        pin.framesForwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        assert np.abs(robot.fkine(q) - data.oMf[tool].homogeneous).max() <= TOL_KIN
        assert np.abs(robot.jacob0(q) - pin.getFrameJacobian(model, data, tool, pin.LOCAL_WORLD_ALIGNED)).max() <= TOL_KIN
        assert np.abs(robot.jacobe(q) - pin.getFrameJacobian(model, data, tool, pin.LOCAL)).max() <= TOL_KIN
        close(dyn.rne(q, qd, qdd), pin.rnea(model, data, q, qd, qdd))
        close(dyn.inertia(q), symmetric_from_upper(pin.crba(model, data, q)))
        close(dyn.coriolis(q, qd), pin.computeCoriolisMatrix(model, data, q, qd))
        close(dyn.gravload(q), pin.computeGeneralizedGravity(model, data, q))


# ------------------------------------------------------------------ robots of the tests

def _link(joint, a, alpha, d, theta, mass, com, inertia, **extra):
    return {"joint": joint, "a": a, "alpha": alpha, "d": d, "theta": theta, "mass": mass, "com": com,
            "inertia": inertia, "motor_inertia": 2e-4, "gear_ratio": 50.0, **extra}


def two_link_mdh(prismatic=False, **top):
    """A two-link modified-DH arm with masses, inertias and motors (joint 2 optionally prismatic)."""
    links = [
        _link("revolute", 0.0, 0.0, 0.3, 0.2, 4.0, [0.05, 0.02, -0.1], [0.06, 0.05, 0.02, 0.004, -0.003, 0.002]),
        _link("prismatic" if prismatic else "revolute", 0.4, -1.1, 0.1, 0.5, 2.5,
              [0.2, -0.03, 0.04], [0.02, 0.03, 0.025, -0.002, 0.001, 0.003], gear_ratio=-30.0),
    ]
    return description_from_dict({"name": "two-link MDH", "convention": "modified", "links": links, **top}, "two.toml")


def three_link(convention, **top):
    """Revolute, prismatic, revolute with a flipped joint, off-axis coms and products of inertia."""
    links = [
        _link("revolute", 0.1, 0.7, 0.25, 0.3, 3.0, [0.02, -0.04, 0.1], [0.05, 0.04, 0.03, 0.003, 0.002, -0.001], flip=True),
        _link("prismatic", 0.3, -0.5, 0.2, 0.4, 2.0, [0.1, 0.02, -0.05], [0.02, 0.025, 0.015, 0.001, -0.002, 0.001]),
        _link("revolute", 0.2, 1.2, 0.05, -0.6, 1.5, [0.05, 0.03, 0.02], [0.01, 0.012, 0.008, -0.001, 0.0005, 0.0007],
              flip=True, gear_ratio=-40.0),
    ]
    return description_from_dict({"name": "three", "convention": convention, "links": links, **top}, "three.toml")


BASE = {"xyz": [0.3, -0.2, 0.5], "rpy": [0.4, -0.7, 1.1]}
TOOL = {"xyz": [0.05, 0.02, 0.12], "rpy": [-0.3, 0.2, 0.9]}


# ------------------------------------------------------------------ modified DH

@pytest.fixture(scope="module")
def panda():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return Robot(load_description(DATA / "panda_mdh.toml"))


def _panda_qs(robot, count=10):
    rng = np.random.default_rng(7)
    lo, hi = robot.qlim
    return [rng.uniform(lo, hi) for _ in range(count)]


def test_panda_mdh_kinematics_match_rtb_panda(panda):
    ref = rtb.models.DH.Panda()
    check_kinematics_against_rtb(panda, ref, _panda_qs(panda))


def test_panda_mdh_rne_matches_rtb_panda(panda):
    ref = rtb.models.DH.Panda()
    ref.gravity = np.array([0.0, 0.0, -9.81])
    dyn = SymbolicDynamics(panda.description)
    for q, (_, qd, qdd) in zip(_panda_qs(panda, 4), states(panda.n, 8)):
        close(dyn.rne(q, qd, qdd), ref.rne_python(q, qd, qdd))


def test_panda_mdh_fkine_all_reports_the_mdh_frames(panda):
    ref = rtb.models.DH.Panda()
    for q in _panda_qs(panda, 3):
        frames = np.array([X.A for X in ref.fkine_all(q)])  # base, then frames 1..n (no tool)
        assert np.abs(panda.fkine_all(q) - frames).max() <= TOL_KIN


@pytest.mark.parametrize("prismatic", [False, True], ids=["RR", "RP"])
def test_two_link_mdh_dynamics_match_rtb_and_pinocchio(prismatic):
    desc = two_link_mdh(prismatic)
    robot = Robot(desc)
    dyn = SymbolicDynamics(desc)
    ref = rtb_robot(desc)
    check_kinematics_against_rtb(robot, ref, [s[0] for s in states(2, 11)])
    check_dynamics_against_rtb(dyn, ref, 2, 12)
    check_against_pinocchio(robot, dyn, pinocchio_model(desc), 13)


def test_mdh_is_not_read_as_standard():
    """Negative control: the same table read as standard DH moves the tool by decimetres."""
    mdh = Robot(two_link_mdh())
    std = Robot(dataclasses.replace(mdh.description, convention="standard"))
    q = np.array([0.3, -0.4])
    assert np.abs(mdh.fkine(q) - std.fkine(q)).max() > 0.05


# ------------------------------------------------------------------ base, tool, flip

def _unflipped(desc):
    return dataclasses.replace(desc, links=tuple(dataclasses.replace(lk, flip=False) for lk in desc.links))


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_base_tool_flip_match_rtb_and_pinocchio(convention):
    """Kinematics with flip, base and tool against RTB and Pinocchio; dynamics against Pinocchio.

    RTB's dynamics ignore ``flip`` (its C ``rne`` returns the unflipped torques, ``rne_python``
    a third answer), so the RTB dynamics check runs on the same arm without flip; the flipped
    torques are checked against Pinocchio and the invariant of test_flip_negates_the_joint_coordinate.
    """
    desc = three_link(convention, base=BASE, tool=TOOL, gravity=[0.5, -1.0, -9.7])
    robot = Robot(desc)
    ref = rtb_robot(desc)
    assert [lk.isflip for lk in ref.links] == [True, False, True]
    check_kinematics_against_rtb(robot, ref, [s[0] for s in states(3, 21)])
    check_dynamics_against_rtb(SymbolicDynamics(_unflipped(desc)), rtb_robot(_unflipped(desc)), 3, 22)
    check_against_pinocchio(robot, SymbolicDynamics(desc), pinocchio_model(desc), 23)


def test_gravity_is_in_the_world_frame():
    """A base turned upside down: the gravity torque is that of the upright arm under reversed gravity."""
    up = three_link("standard")
    down = three_link("standard", base={"rpy": [np.pi, 0.0, 0.0]})
    reversed_g = three_link("standard", gravity=[0.0, 0.0, 9.81])
    g_down, g_rev = SymbolicDynamics(down), SymbolicDynamics(reversed_g)
    for q, _, _ in states(3, 31):
        close(g_down.gravload(q), g_rev.gravload(q))
        assert np.abs(g_down.gravload(q) - SymbolicDynamics(up).gravload(q)).max() > 1.0


def test_flip_negates_the_joint_coordinate():
    """flip = joint coordinate -q: with S = diag(+-1), fkine(q) = fkine_plain(S q), J = J_plain S, tau = S tau_plain(S q, S qd, S qdd)."""
    flipped = three_link("standard", base=BASE)
    plain = _unflipped(flipped)
    r_flip, r_plain = Robot(flipped), Robot(plain)
    d_flip, d_plain = SymbolicDynamics(flipped), SymbolicDynamics(plain)
    S = np.array([-1.0, 1.0, -1.0])
    for q, qd, qdd in states(3, 32):
        assert np.abs(r_flip.fkine(q) - r_plain.fkine(S * q)).max() <= TOL_KIN
        assert np.abs(r_flip.jacob0(q) - r_plain.jacob0(S * q) * S).max() <= TOL_KIN
        close(d_flip.rne(q, qd, qdd), S * d_plain.rne(S * q, S * qd, S * qdd))
        close(d_flip.inertia(q), S[:, None] * d_plain.inertia(S * q) * S)


# ------------------------------------------------------------------ the "urdf" form

def _rotation(rng):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    angle = rng.uniform(-np.pi, np.pi)
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def as_urdf(desc, seed=5):
    """Rewrite a standard-DH description as origin/axis links with arbitrary joint frames.

    Joint frame i is DH frame i-1 times ``Q_i`` (a random rotation and a shift along z_{i-1},
    so the frame stays on the joint axis); the axis is then ``Q_i^T z``. Body i is the moved
    joint frame: it equals the DH body (frame i-1 turned by q) times Q_i, so
    ``origin_i = Q_{i-1}^-1 A_{i-1} Q_i`` with the constant DH transforms A, com ``Q_i^-1 A_i c``,
    inertia ``R^T I R`` with ``R = R(Q_i^-1 A_i)``, and ``tip = Q_n^-1 A_n``.
    """
    rng = np.random.default_rng(seed)
    Q = [np.eye(4)]
    for _ in desc.links:
        T = np.eye(4)
        T[:3, :3] = _rotation(rng)
        T[2, 3] = rng.uniform(-0.3, 0.3)
        Q.append(T)
    A = [dh_standard(lk.a, lk.alpha, lk.d, lk.theta) for lk in desc.links]
    links = []
    for i, lk in enumerate(desc.links, start=1):
        origin = np.linalg.inv(Q[i - 1]) @ (A[i - 2] if i > 1 else np.eye(4)) @ Q[i]
        axis = Q[i][:3, :3].T @ np.array([0.0, 0.0, -1.0 if lk.flip else 1.0])
        M = np.linalg.inv(Q[i]) @ A[i - 1]  # DH frame i in the body frame
        com = M[:3, :3] @ np.array(lk.com) + M[:3, 3]
        I = M[:3, :3] @ lk.inertia_matrix @ M[:3, :3].T
        links.append(dataclasses.replace(
            lk, a=0.0, alpha=0.0, d=0.0, theta=0.0, flip=False, origin=tuple(origin.ravel()), axis=tuple(axis),
            com=tuple(com), inertia=(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2]),
        ))
    tip = np.linalg.inv(Q[-1]) @ A[-1]
    return dataclasses.replace(desc, convention="urdf", links=tuple(links), tip=tuple(tip.ravel()))


def pinocchio_by_hand(desc):
    """Pinocchio from the "urdf" links: joint i at ``origin_i`` about ``axis_i``, body data as given."""
    model = pin.Model()
    model.gravity = pin.Motion(np.array(desc.gravity), np.zeros(3))
    parent = 0
    for i, lk in enumerate(desc.links):
        placement = pin.SE3(np.array(lk.origin).reshape(4, 4))
        if i == 0:
            placement = pin.SE3(desc.T_base) * placement
        axis = np.array(lk.axis)
        joint = pin.JointModelRevoluteUnaligned(axis) if lk.is_revolute else pin.JointModelPrismaticUnaligned(axis)
        parent = model.addJoint(parent, joint, placement, f"j{i + 1}")
        model.appendBodyToJoint(parent, pin.Inertia(lk.mass, np.array(lk.com), lk.inertia_matrix), pin.SE3.Identity())
    tool = pin.SE3(np.array(desc.tip).reshape(4, 4)) * pin.SE3(desc.T_tool)
    model.addFrame(pin.Frame("tool", parent, tool, pin.FrameType.OP_FRAME))
    model.armature = np.array([lk.gear_ratio ** 2 * lk.motor_inertia for lk in desc.links])
    return model


@pytest.mark.parametrize("name", ["puma560", "three"])
def test_urdf_form_equals_its_dh_original(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        dh = load_description(name) if name != "three" else three_link("standard", base=BASE, tool=TOOL)
    urdf = as_urdf(dh)
    assert any(abs(lk.axis[2]) < 0.9 for lk in urdf.links), "the rewrite must use axes other than z"
    r_dh, r_urdf = Robot(dh), Robot(urdf)
    for model in ("reflected", "full"):
        d_dh, d_urdf = SymbolicDynamics(dh, model), SymbolicDynamics(urdf, model)
        for q, qd, qdd in states(dh.n, 41):
            if model == "reflected":
                assert np.abs(r_urdf.fkine(q) - r_dh.fkine(q)).max() <= TOL_KIN
                assert np.abs(r_urdf.jacob0(q) - r_dh.jacob0(q)).max() <= TOL_KIN
                assert np.abs(r_urdf.jacobe(q) - r_dh.jacobe(q)).max() <= TOL_KIN
            close(d_urdf.rne(q, qd, qdd), d_dh.rne(q, qd, qdd))
            close(d_urdf.inertia(q), d_dh.inertia(q))
            close(d_urdf.gravload(q), d_dh.gravload(q))


def test_urdf_form_matches_pinocchio_built_by_hand():
    urdf = as_urdf(three_link("standard", base=BASE, tool=TOOL, gravity=[0.3, 0.2, -9.8]), seed=9)
    robot = Robot(urdf)
    check_against_pinocchio(robot, SymbolicDynamics(urdf), pinocchio_by_hand(urdf), 51)


def test_full_motor_model_newton_euler_equals_lagrange_in_every_convention():
    """Rotors as bodies (mass and spin inertia) on an MDH arm and a "urdf" arm: rne = B qdd + C qd + g."""
    rotor = {"rotor_mass": 0.7}
    mdh = two_link_mdh()
    mdh = dataclasses.replace(mdh, links=tuple(dataclasses.replace(lk, **rotor) for lk in mdh.links))
    urdf = as_urdf(dataclasses.replace(three_link("standard", base=BASE), links=tuple(
        dataclasses.replace(lk, **rotor) for lk in three_link("standard").links)))
    for desc in (mdh, urdf):
        dyn = SymbolicDynamics(desc, "full")
        for q, qd, qdd in states(desc.n, 61):
            lagrange = dyn.inertia(q) @ qdd + dyn.coriolis(q, qd) @ qd + dyn.gravload(q)
            close(dyn.rne(q, qd, qdd), lagrange)


def test_bad_urdf_axis_is_refused():
    urdf = as_urdf(three_link("standard"))
    bad = dataclasses.replace(urdf, links=(dataclasses.replace(urdf.links[0], axis=(0.0, 0.0, 2.0)), *urdf.links[1:]))
    with pytest.raises(ValueError, match=r"three.toml, link 1: field 'axis' = \(0.0, 0.0, 2.0\): expected a unit vector"):
        Robot(bad).fkine(np.zeros(3))


def test_rpy_is_urdf_order():
    """rpy = [r, p, y] is Rz(y) Ry(p) Rx(r), as URDF and spatialmath's rpy2r(order='zyx')."""
    from spatialmath.base import rpy2r

    rpy = [0.3, -0.8, 2.0]
    assert np.abs(rpy_matrix(rpy) - rpy2r(rpy, order="zyx")).max() <= 1e-15


def test_compiled_dynamics_of_a_free_text_name_use_its_identifier():
    """A robot named with spaces and brackets compiles under its identifier and gives the symbolic torques."""
    desc = dataclasses.replace(two_link_mdh(base=BASE, tool=TOOL), name="Two-link (MDH) arm #2")
    robot = Robot(desc)
    info = robot.dynamics.compile()
    assert Path(info.library).name.startswith("Two_link_MDH_arm_2-reflected"), info.library
    dyn = SymbolicDynamics(desc)
    for q, qd, qdd in states(2, 71):
        close(robot.rne(q, qd, qdd), dyn.rne(q, qd, qdd))
        close(robot.inertia(q), dyn.inertia(q))
