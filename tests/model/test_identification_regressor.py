"""The joint-torque regressor against the model's Newton-Euler and against Pinocchio's regressor.

* ``Y(q, qd, qdd) pi == rne(q, qd, qdd)`` at random states for random physical parameters on every built-in,
  the modified-DH Panda, a robot on a tilted base with a tool, and a flipped joint. Tolerance 1e-12 relative
  to the largest torque: two evaluations of the same rigid-body sums in a different order (observed ~4e-16).
* Pinocchio's ``computeJointTorqueRegressor`` (written by others) mapped through the stated link-frame
  transform, ``Y_pin[:, 10 i:10 i + 10] @ frame_transform(C_i)``: to 1e-12 of the largest entry. A negative
  control shows that for standard DH the transform is needed (the columns differ by O(1) without it).
* The compiled batch against CasADi's own evaluation of the same Functions (1e-12), and the compiled
  reverse-mode derivative against central finite differences of the compiled regressor.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from model.chain import build_chain
from model.identification.parameters import (INERTIAL_FIELDS, PER_JOINT, frame_transform, inertial_block,
                                             inertial_from_pseudo, parameter_names, pseudo_inertia,
                                             standard_parameters)
from model.identification.regressor import Regressor
from model.loading import load_description
from model.robot import Robot
from tests.support.identification import randomised, with_poses
from tests.support.references import available_robots, pinocchio_model

CASES = [*available_robots(), "tests/data/panda_mdh.toml", "posed-puma560", "flipped-scara"]


def _description(case: str):
    if case == "posed-puma560":
        return with_poses(load_description("puma560"))
    if case == "flipped-scara":
        d = load_description("scara")
        return dataclasses.replace(d, links=(d.links[0], dataclasses.replace(d.links[1], flip=True), *d.links[2:]))
    return load_description(case)


def _states(desc, N: int, seed: int):
    rng = np.random.default_rng(seed)
    return tuple(rng.uniform(-2.0, 2.0, (N, desc.n)) for _ in range(3))


@pytest.mark.parametrize("case", CASES)
def test_regressor_times_random_parameters_is_the_inverse_dynamics(case):
    base_desc = _description(case)
    reg = Regressor(base_desc)
    Q, QD, QDD = _states(base_desc, 40, seed=1)
    Y = reg.batch(Q, QD, QDD)
    assert Y.shape == (40, base_desc.n, PER_JOINT * base_desc.n)
    for seed in (0, 1):
        desc = randomised(base_desc, seed)
        tau = Robot(desc).rne_batch(Q, QD, QDD)
        np.testing.assert_allclose(Y @ standard_parameters(desc), tau, rtol=0, atol=1e-12 * np.abs(tau).max())
    # and the file's own values (the Puma's inconsistent published inertias included)
    tau = Robot(base_desc).rne_batch(Q, QD, QDD)
    np.testing.assert_allclose(Y @ standard_parameters(base_desc), tau, rtol=0, atol=1e-12 * np.abs(tau).max())


def test_the_regressor_depends_on_the_geometry_only():
    """A robot with other masses and motors has the same regressor (one compiled library serves both)."""
    d = load_description("ur5")
    Q, QD, QDD = _states(d, 5, seed=2)
    np.testing.assert_array_equal(Regressor(d).batch(Q, QD, QDD), Regressor(randomised(d, 3)).batch(Q, QD, QDD))


@pytest.mark.parametrize("case", CASES)
def test_inertial_columns_are_pinocchios_regressor_in_the_link_frame(case):
    pin = pytest.importorskip("pinocchio")
    desc = _description(case)
    model = pinocchio_model(desc, armature=False)
    data = model.createData()
    chain = build_chain(desc)
    reg = Regressor(desc)
    Q, QD, QDD = _states(desc, 5, seed=3)
    for q, qd, qdd in zip(Q, QD, QDD):
        Y_pin = pin.computeJointTorqueRegressor(model, data, q, qd, qdd)
        Y = reg.Y(q, qd, qdd)
        scale = np.abs(Y_pin).max()
        for i in range(desc.n):
            ours = Y[:, PER_JOINT * i:PER_JOINT * i + len(INERTIAL_FIELDS)]
            mapped = Y_pin[:, 10 * i:10 * i + 10] @ frame_transform(chain.reported[i])
            np.testing.assert_allclose(ours, mapped, rtol=0, atol=1e-12 * scale)
            # the joint columns: Ia multiplies qdd_i, fv qd_i, fc sign(qd_i), off 1, on joint i only
            e = np.zeros(desc.n)
            e[i] = 1.0
            joint_cols = Y[:, PER_JOINT * i + 10:PER_JOINT * (i + 1)]
            np.testing.assert_array_equal(joint_cols, np.column_stack([e * qdd[i], e * qd[i], e * np.sign(qd[i]), e]))


def test_without_the_link_frame_transform_standard_dh_columns_differ():
    """Negative control: for standard DH, Pinocchio's joint-frame columns are not ours as they stand."""
    pin = pytest.importorskip("pinocchio")
    desc = load_description("puma560")
    model = pinocchio_model(desc, armature=False)
    q, qd, qdd = (v[0] for v in _states(desc, 1, seed=4))
    Y_pin = pin.computeJointTorqueRegressor(model, model.createData(), q, qd, qdd)
    Y = Regressor(desc).Y(q, qd, qdd)
    i = 1  # link 2: its DH frame sits a = 0.4318 m down the link from joint 2
    gap = np.abs(Y[:, PER_JOINT * i:PER_JOINT * i + 10] - Y_pin[:, 10 * i:10 * i + 10]).max()
    assert gap > 0.1 * np.abs(Y_pin).max()


def test_compiled_regressor_matches_casadi_evaluation():
    desc = load_description("panda")
    reg = Regressor(desc)
    Q, QD, QDD = _states(desc, 3, seed=5)
    f = reg.functions["regressor"]
    for q, qd, qdd, Y in zip(Q, QD, QDD, reg.batch(Q, QD, QDD)):
        np.testing.assert_allclose(Y, np.array(f(q, qd, qdd)), rtol=0, atol=1e-12 * np.abs(Y).max())


def test_reverse_mode_derivative_matches_finite_differences():
    desc = load_description("puma560")
    reg = Regressor(desc)
    Q, QD, QDD = _states(desc, 4, seed=6)
    QD = np.where(np.abs(QD) < 0.2, 0.5, QD)  # away from sign(qd)'s jump
    seed = np.random.default_rng(7).standard_normal((4, desc.n, reg.size))
    grads = reg.vjp_batch(Q, QD, QDD, seed)
    h = 1e-6
    for which, grad in enumerate(grads):
        fd = np.zeros_like(grad)
        for j in range(desc.n):
            plus, minus = [Q.copy(), QD.copy(), QDD.copy()], [Q.copy(), QD.copy(), QDD.copy()]
            plus[which][:, j] += h
            minus[which][:, j] -= h
            fd[:, j] = np.sum((reg.batch(*plus) - reg.batch(*minus)) * seed, axis=(1, 2)) / (2 * h)
        # central differences: error ~ h^2 |Y'''| ~ 1e-12, plus rounding 1e-16 |Y| / h ~ 1e-10
        np.testing.assert_allclose(grad, fd, rtol=0, atol=1e-7 * max(1.0, np.abs(fd).max()))


def test_frame_transform_composes_and_inverts():
    """``X(T_ab) X(T_bc) = X(T_ac)`` (moving a body's parameters through two frames is one move)."""
    from model.description import rpy_matrix

    rng = np.random.default_rng(8)

    def pose():
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = rpy_matrix(rng.uniform(-3, 3, 3)), rng.uniform(-1, 1, 3)
        return T

    T1, T2 = pose(), pose()
    np.testing.assert_allclose(frame_transform(T1) @ frame_transform(T2), frame_transform(T1 @ T2), atol=1e-13)
    np.testing.assert_allclose(frame_transform(np.linalg.inv(T1)) @ frame_transform(T1), np.eye(10), atol=1e-13)
    # a point mass at c in frame b: in frame a its parameters are those of a point mass at R c + p
    c = np.array([0.3, -0.2, 0.1])
    block = inertial_block(2.0, c, np.zeros((3, 3)))
    moved = inertial_block(2.0, T1[:3, :3] @ c + T1[:3, 3], np.zeros((3, 3)))
    np.testing.assert_allclose(frame_transform(T1) @ block, moved, atol=1e-13)


def test_pseudo_inertia_is_positive_exactly_for_rigid_bodies():
    """A box's pseudo-inertia is positive definite; the Puma's published link 3 (which breaks the triangle
    inequality) has a negative eigenvalue: the test the consistent fit relies on can fail."""
    box = inertial_block(3.0, [0.1, 0.0, -0.2], np.diag([0.02, 0.03, 0.04]))
    assert np.linalg.eigvalsh(pseudo_inertia(box)).min() > 0
    np.testing.assert_allclose(inertial_from_pseudo(pseudo_inertia(box)), box, atol=1e-15)
    puma = standard_parameters(load_description("puma560"))
    link3 = puma[2 * PER_JOINT:2 * PER_JOINT + 10]
    assert np.linalg.eigvalsh(pseudo_inertia(link3)).min() < -1e-3


def test_parameter_names_follow_the_stated_layout():
    names = parameter_names(2)
    assert names[:14] == ("m_1", "mc_x1", "mc_y1", "mc_z1", "I_xx1", "I_xy1", "I_yy1", "I_xz1", "I_yz1", "I_zz1",
                          "Ia_1", "fv_1", "fc_1", "off_1")
    assert names[14] == "m_2" and len(names) == 28


def test_coulomb_asymmetry_is_the_offset_while_moving():
    """``|G| Tc(sign qd) = fc sign(qd) + off`` with the stated fc and off, for both directions."""
    desc = load_description("puma560")
    pi = standard_parameters(desc)
    for i, lk in enumerate(desc.links):
        fc, off = pi[PER_JOINT * i + 12], pi[PER_JOINT * i + 13]
        G = abs(lk.gear_ratio)
        assert fc + off == pytest.approx(G * lk.coulomb_friction[0], rel=1e-14)
        assert -fc + off == pytest.approx(G * lk.coulomb_friction[1], rel=1e-14)
