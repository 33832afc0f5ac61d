"""Drive trains in the one plant (issue 23): elastic gears, friction peak, current loops, equilibrium, PTP.

References, none of them the workbench's code:

* the one-link flexible joint in closed form (derived in the test: the two-mass system's centre of inertia moves
  as ``u t^2 / (2 J)``, the gear's twist as ``u / (Jm w^2) (1 - cos w t)``, ``w^2 = c (1/Jm + G^2/Jl)``);
* the current loop's step response with the rotor at rest (the second-order law's textbook closed form);
* energy conservation of the r3's elastic arm without damping, friction and current loops;
* the stiff-gear limit: an elastic gear converges on the rigid plant as the stiffness grows;
* Dymola's initial state of RobotR3.fullRobot (the MSL regression result as the issue's README lists it, section 3.8);
* the KinematicPTP2 switching times of the MSL model (same README, section 3.2).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from control_design.cascade import cascade_from_robot
from control_design.reference import Reference
from model.compiled_plant import compiled_plant
from model.description import RobotDescriptionError, description_from_dict
from model.drive_train import drive_layout, equilibrium_state, rigid_arm_description
from model.plant import build_plant
from model.robot import Robot, load_robot
from model.tasks import robot_tasks


def _one_link(**motor) -> Robot:
    link = {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "mass": 1.0,
            "inertia": [1.0, 1.0, 2.0, 0.0, 0.0, 0.0], **motor}
    return Robot(description_from_dict({"name": "flex1", "gravity": [0.0, 0.0, 0.0], "links": [link]}))


def _advance(robot: Robot, x0, u, h: float, steps: int, substeps: int):
    run = compiled_plant(robot).run(robot.parameters.vector)
    run.start(np.asarray(x0, dtype=float))
    out = [run.x.copy()]
    for _ in range(steps):
        assert run.advance(np.atleast_1d(u), h, substeps)
        out.append(run.x.copy())
    run.close()
    return np.array(out)


def test_one_link_flexible_joint_closed_form():
    """Constant motor torque from rest, no friction, no damping: q and q_m against the closed form.

    RK4 at h w = 0.0087 (w = 86.6 rad/s, h = 0.1 ms): the global error is ~(h w)^4 ~ 6e-9 of the twist's
    amplitude; 1e-7 of the motion's scale leaves room and still fails for a 1 % error in any of J, c, G.
    """
    Jl, Jm, G, c, u = 2.0, 0.01, 10.0, 50.0, 0.3
    robot = _one_link(motor_inertia=Jm, gear_ratio=G, gear_stiffness=c)
    X = _advance(robot, [0.0, 0.0, 0.0, 0.0], u, 1e-3, 300, 10)
    t = np.arange(X.shape[0]) * 1e-3
    Jl_m = Jl / G**2  # the link's inertia seen from the motor side
    J = Jm + Jl_m
    w = math.sqrt(c * (1.0 / Jm + 1.0 / Jl_m))
    twist = u / (Jm * w * w) * (1.0 - np.cos(w * t))
    centre = u * t * t / (2.0 * J)
    q = (centre - Jm / J * twist) / G
    qm = centre + Jl_m / J * twist
    scale = np.abs(qm).max()
    assert np.abs(X[:, 0] - q).max() * G < 1e-7 * scale
    assert np.abs(X[:, 2] - qm).max() < 1e-7 * scale
    # negative control: the rigid answer (no twist) is off by the twist's amplitude, far beyond the tolerance
    assert np.abs(centre / G - X[:, 0]).max() * G > 1e-3 * scale


def test_current_loop_step_with_the_rotor_at_rest():
    """A stuck joint (its holding torque within a large Coulomb limit): tau_m follows u as w^2 / (s^2 + 2 D w s + w^2)."""
    w, D, u = 1000.0, 0.6, 1.5
    robot = _one_link(motor_inertia=1e-3, gear_ratio=5.0, coulomb_friction=100.0, current_bandwidth=w,
                      current_damping=D, torque_constant=0.5, armature_resistance=10.0)
    lay = drive_layout(robot.description)
    X = _advance(robot, np.zeros(lay.nx), u, 1e-4, 100, 10)
    t = np.arange(X.shape[0]) * 1e-4
    wd = w * math.sqrt(1 - D * D)
    step = u * (1 - np.exp(-D * w * t) * (np.cos(wd * t) + D / math.sqrt(1 - D * D) * np.sin(wd * t)))
    assert np.all(X[:, 1] == 0.0)  # the joint never moved: no back-EMF
    assert np.abs(X[:, lay.tau_slice.start] - step).max() < 1e-8 * u


def test_friction_peak_holds_until_the_breakaway_then_slides_on_coulomb():
    J, Tc, peak = 2.0, 1.0, 1.5
    robot = _one_link(coulomb_friction=Tc, friction_peak=peak)
    held = _advance(robot, [0.0, 0.0], 1.2, 1e-3, 100, 1)
    assert np.all(held[:, 1] == 0.0)  # 1.2 N m < 1.5 N m: stuck
    moved = _advance(robot, [0.0, 0.0], 1.6, 1e-3, 100, 1)
    assert moved[-1, 1] == pytest.approx((1.6 - Tc) / J * 0.1, rel=1e-9)  # slides against Tc, not the peak
    no_peak = _advance(_one_link(coulomb_friction=Tc), [0.0, 0.0], 1.2, 1e-3, 100, 1)
    assert no_peak[-1, 1] == pytest.approx((1.2 - Tc) / J * 0.1, rel=1e-9)  # negative control: 1.2 > Tc moves


def _conservative_r3() -> Robot:
    desc = load_robot("manutec_r3").description
    links = tuple(dataclasses.replace(lk, viscous_friction=0.0, coulomb_friction=(0.0, 0.0), friction_peak=1.0,
                                      gear_damping=0.0, current_bandwidth=None, armature_resistance=None)
                  for lk in desc.links)
    return Robot(dataclasses.replace(desc, links=links))


def test_energy_balance_of_the_elastic_r3_without_damping_and_friction():
    """0.3 s of free motion under gravity from a twisted start: arm + rotors + springs keep their energy.

    RK4 at h = 0.1 ms against the fastest rotor mode (211 rad/s, h w = 0.02): the drift measured is ~1e-10 of
    the energy scale; 1e-8 is the bound. Without the springs' energy the sum moves by ~1e-2 of it (the check
    can fail).
    """
    robot = _conservative_r3()
    desc = robot.description
    lay = drive_layout(desc)
    n = desc.n
    x0 = equilibrium_state(desc, desc.q_rest, robot.gravload(desc.q_rest))
    rng = np.random.default_rng(23)
    x0[n:2 * n] = rng.uniform(-0.5, 0.5, n)
    x0[lay.qm_slice] += rng.uniform(-0.05, 0.05, lay.ne)
    X = _advance(robot, x0, np.zeros(n), 1e-3, 300, 10)
    arm = Robot(rigid_arm_description(desc))
    energy = arm.dynamics.functions.energy
    p = arm.parameters.vector
    G = robot.gear_ratio
    idx = list(lay.elastic)
    Jm = np.array([desc.links[i].motor_inertia for i in idx])
    c = np.array([desc.links[i].gear_stiffness for i in idx])
    T, U, S = [], [], []
    for x in X:
        t_k, u_k = energy(x[:n], x[n:2 * n], p)
        twist = x[lay.qm_slice] - G[idx] * x[idx]
        T.append(float(t_k) + 0.5 * float(Jm @ x[lay.qdm_slice] ** 2))
        U.append(float(u_k))
        S.append(0.5 * float(c @ twist**2))
    T, U, S = map(np.array, (T, U, S))
    scale = T.max() + (U.max() - U.min())
    assert np.abs(T + U + S - (T + U + S)[0]).max() < 1e-8 * scale
    assert np.abs(T + U - (T + U)[0]).max() > 1e-4 * scale  # negative control: the springs do hold energy


def test_stiff_gear_converges_on_the_rigid_plant():
    """planar2r with elastic gears (well damped) falling under gravity: q approaches the rigid plant's as c grows,
    the gap shrinking about as 1/c (the static twist tau / c)."""
    base = load_robot("planar2r").description
    rigid_links = tuple(dataclasses.replace(lk, motor_inertia=1e-3, gear_ratio=50.0) for lk in base.links)
    rigid = Robot(dataclasses.replace(base, links=rigid_links))
    q0 = np.array([0.3, -0.4])
    ref = _advance(rigid, np.concatenate([q0, [0.0, 0.0]]), np.zeros(2), 1e-3, 200, 20)

    def gap(c: float) -> float:
        links = tuple(dataclasses.replace(lk, gear_stiffness=c, gear_damping=2 * math.sqrt(c * 1e-3))
                      for lk in rigid_links)
        robot = Robot(dataclasses.replace(base, links=links))
        x0 = np.concatenate([q0, [0.0, 0.0], 50.0 * q0, [0.0, 0.0]])
        X = _advance(robot, x0, np.zeros(2), 1e-3, 200, 20)
        return float(np.abs(X[:, :2] - ref[:, :2]).max())

    g1, g2 = gap(1e3), gap(1e4)
    assert g2 < 2e-3
    assert 5.0 < g1 / g2 < 20.0


def test_rigid_default_keys_leave_the_plant_as_it_was():
    """Drive-train keys at their defaults: the same digest (so the same compiled code) and the rigid plant."""
    desc = load_robot("puma560").description
    stated = dataclasses.replace(desc, links=tuple(dataclasses.replace(lk, friction_peak=1.0, friction_side="motor",
                                                                       gear_damping=0.0) for lk in desc.links))
    assert stated.digest() == desc.digest()
    assert build_plant(Robot(stated)).nx == 2 * desc.n


def test_the_r3_starts_in_dymolas_equilibrium():
    """Dymola's initial states of fullRobot (i_a, v_C, spring phi_rel, PI state), to their 7 printed digits."""
    robot = load_robot("manutec_r3")
    desc = robot.description
    lay = drive_layout(desc)
    x = equilibrium_state(desc, desc.q_rest, robot.gravload(desc.q_rest))
    tau = x[lay.tau_slice]
    xi = x[lay.xi_slice]
    k = np.array([lk.torque_constant for lk in desc.links])
    D = np.array([lk.current_damping for lk in desc.links])
    w = np.array([lk.current_bandwidth for lk in desc.links])
    Ra = np.array([lk.armature_resistance for lk in desc.links])
    i_a = tau / k
    v_c = xi * Ra * w / (10.0 * D * k)  # xi = 5 k v_C / (L_a w^2), L_a = Ra / (2 D w)
    G = robot.gear_ratio
    phi_rel = G[:3] * x[:3] - x[lay.qm_slice]
    qm, qdm = lay.motor_state(x, G)
    ctrl = cascade_from_robot(robot)
    ctrl.hold_from(qm, qdm, Reference(desc.q_rest, np.zeros(6), np.zeros(6)), tau)
    dymola_i = [0.0, -1.888091, -3.678835, -0.6004244, -0.7242793, 0.0]
    dymola_v = [0.0, 94.40457, 183.94174, 30.02122, 36.21397, 0.0]
    dymola_phi = [0.0, 0.2741509, 0.07367818]
    dymola_x = [0.0, -5.14694, -7.72606, -1.200849, -1.448559, 0.0]
    np.testing.assert_allclose(i_a, dymola_i, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(v_c, dymola_v, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(phi_rel, dymola_phi, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(ctrl.x, dymola_x, rtol=1e-5, atol=1e-9)


def test_ptp_switching_times_are_the_msl_models():
    traj = robot_tasks("manutec_r3")["ptp"].trajectory(0.001)
    breaks = traj.path.breaks
    np.testing.assert_allclose(breaks[1:4], [0.117424242, 1.238620759, 1.356045002], rtol=0, atol=1e-9)
    q, qd, qdd = traj.sample(0.5)
    np.testing.assert_allclose(qd, [1.690909, -1.268182, -1.761364, 0.634091, 3.1, 0.634091], atol=1e-6)
    _, _, qdd = traj.sample(0.05)
    np.testing.assert_allclose(qdd, [14.4, -10.8, -15.0, 5.4, 26.4, 5.4], atol=1e-9)
    assert traj.sample(breaks[-1])[0] == pytest.approx(traj.q_via[1], abs=0)


@pytest.mark.parametrize("key, value, message", [
    ("gear_damping", 0.1, "to be stated with 'gear_stiffness'"),
    ("friction_peak", 0.5, "a break-away factor >= 1"),
    ("friction_side", "rotor", "'motor' or 'link'"),
    ("gear_stiffness", -1.0, "a gear stiffness > 0"),
    ("current_bandwidth", 0.0, "a current-loop bandwidth > 0"),
])
def test_bad_drive_train_keys_are_one_line_each(key, value, message):
    link = {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "motor_inertia": 1e-3, key: value}
    if key == "friction_side":
        link["gear_stiffness"] = 10.0
    with pytest.raises(RobotDescriptionError) as info:
        description_from_dict({"name": "bad", "links": [link]}, "bad.toml")
    text = str(info.value)
    assert f"bad.toml, link 1: field '{key}' = {value!r}" in text and message in text
    assert len(text.splitlines()) == 1


def test_an_elastic_gear_needs_a_rotor():
    link = {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "gear_stiffness": 10.0}
    with pytest.raises(RobotDescriptionError, match="motor_inertia.*rotor inertia > 0"):
        description_from_dict({"name": "bad", "links": [link]}, "bad.toml")

