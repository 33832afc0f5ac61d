"""The r3's plant FMU (issue 23): its drive-train states in CS and ME, and the cascade's loop through it.

* Co-Simulation: the robot file's P-PI cascade (in Python, reading the FMU's outputs q, qd and its local states
  q_m, qd_m) closes the loop through the plant FMU at 20 kHz; the link-side speeds must reproduce Dymola's
  fullRobot result by the issue's rules (1 % of each axis's range outside +-2 ms of a friction event, break-aways
  within 0.5 ms, FMPy's validate_result). Measured: the same as the Python loop (worst 0.022 %, 0.03-0.04 ms).
* Model Exchange: at the start state (the static equilibrium) the FMU's derivatives are the plant's ``ode`` in its start
  modes, to the last bit (the same generated C, the same inputs), and it has one event indicator per friction mode (9).
"""

from __future__ import annotations

import numpy as np
import pytest

from control_design.cascade import cascade_from_robot
from control_design.reference import Reference
from model.plant import build_plant
from model.robot import load_robot
from model.tasks import robot_tasks
from tests.support import robotr3 as R3

fmpy = pytest.importorskip("fmpy")

from fmu.opened import open_fmu  # noqa: E402


def _names(base: str, joints) -> list[str]:
    return [f"{base}[{i}]" for i in joints]


@pytest.fixture(scope="module")
def r3_fmu(tmp_path_factory):
    import fmu

    robot = load_robot("manutec_r3")
    path = fmu.export_fmu(robot, tmp_path_factory.mktemp("r3") / "r3.fmu", step=2.5e-5, platforms="linux64")
    with open_fmu(path) as opened:
        yield robot, path, opened


def test_cascade_through_the_plant_fmu_reproduces_dymola(r3_fmu):
    robot, _, opened = r3_fmu
    s = opened.instance("cs", "r3").start(0.0)
    G = robot.gear_ratio
    vq, vqd = opened.select(_names("q", range(1, 7))), opened.select(_names("qd", range(1, 7)))
    vqm, vqdm = opened.select(_names("q_m", range(1, 4))), opened.select(_names("qd_m", range(1, 4)))
    vu = opened.select(_names("tau_m", range(1, 7)))

    def measure():
        q, qd = s.get(vq), s.get(vqd)
        qm, qdm = G * q, G * qd
        qm[:3], qdm[:3] = s.get(vqm), s.get(vqdm)
        return q, qd, qm, qdm

    controller = cascade_from_robot(robot)
    traj = robot_tasks(robot.description)["ptp"].trajectory(controller.dt)
    steps = int(round(1.0 / controller.dt))
    t = np.arange(steps + 1) * controller.dt
    QD = np.empty((steps + 1, 6))
    q, qd, qm, qdm = measure()
    controller.hold_from(qm, qdm, Reference(*traj.sample(0.0)), robot.gravload(q) / G)
    try:
        for k in range(steps + 1):
            q, qd, qm, qdm = measure()
            QD[k] = qd
            u = controller.update_motor(t[k], q, qd, qm, qdm, Reference(*traj.sample(t[k])))
            if k == steps:
                break
            s.set(vu, u)
            s.do_step(t[k], controller.dt)
    finally:
        s.close()
    cmp = R3.compare(t, QD)
    assert np.all(cmp.worst < 0.01), cmp.worst
    assert np.all(np.abs(cmp.breakaway[3:]) < 5e-4), cmp.breakaway
    from fmpy.cross_check import validate_result
    assert validate_result(R3.as_result(t, QD), R3.reference(), 0.0, 1.0) is None


def test_plant_fmu_and_cascade_fmu_reproduce_dymola(r3_fmu, tmp_path):
    """The same loop with the cascade as an FMU too (its PI integrators a sampled discrete state, starting from
    the equilibrium's values): two FMUs, FMPy's CS, the issue's three rules."""
    from closed_loop.cascade_fmu import export_cascade_fmu
    from fmpy.cross_check import validate_result

    robot, _, opened = r3_fmu
    G = robot.gear_ratio
    controller = cascade_from_robot(robot)
    traj = robot_tasks(robot.description)["ptp"].trajectory(controller.dt)
    x0 = build_plant(robot).x0
    qm0, qdm0 = G * x0[:6], np.zeros(6)
    qm0[:3] = x0[12:15]
    controller.hold_from(qm0, qdm0, Reference(*traj.sample(0.0)), robot.gravload(x0[:6]) / G)
    cpath = export_cascade_fmu(controller, robot, tmp_path / "cascade.fmu", platforms="linux64")
    cascade = open_fmu(cpath)
    plant = opened.instance("cs", "plant").start(0.0)
    ctrl = cascade.instance("cs", "cascade").start(0.0)
    vq, vqd = opened.select(_names("q", range(1, 7))), opened.select(_names("qd", range(1, 7)))
    vqm, vqdm = opened.select(_names("q_m", (1, 2, 3))), opened.select(_names("qd_m", (1, 2, 3)))
    c_in = cascade.select([f"{s}[{i}]" for s in ("q_ref", "qd_ref", "q_m", "qd_m") for i in range(1, 7)])
    c_out = cascade.select(_names("tau_m", range(1, 7)))
    p_in = opened.select(_names("tau_m", range(1, 7)))
    steps = int(round(1.0 / controller.dt))
    t = np.arange(steps + 1) * controller.dt
    QD = np.empty((steps + 1, 6))
    try:
        for k in range(steps + 1):
            q, qd = plant.get(vq), plant.get(vqd)
            QD[k] = qd
            if k == steps:
                break
            qm, qdm = G * q, G * qd
            qm[:3], qdm[:3] = plant.get(vqm), plant.get(vqdm)
            q_ref, qd_ref, _ = traj.sample(t[k])
            ctrl.set(c_in, [*q_ref, *qd_ref, *qm, *qdm])
            u = ctrl.get(c_out)
            ctrl.do_step(t[k], controller.dt)
            plant.set(p_in, u)
            plant.do_step(t[k], controller.dt)
    finally:
        for s in (plant, ctrl):
            s.close()
        cascade.close()
    cmp = R3.compare(t, QD)
    assert np.all(cmp.worst < 0.01), cmp.worst
    assert np.all(np.abs(cmp.breakaway[3:]) < 5e-4), cmp.breakaway
    assert validate_result(R3.as_result(t, QD), R3.reference(), 0.0, 1.0) is None


def test_model_exchange_states_and_derivatives(r3_fmu):
    robot, _, opened = r3_fmu
    md = opened.md
    plant = build_plant(robot)
    assert md.numberOfEventIndicators == plant.nz == 9
    states = [d.variable.derivative.name for d in md.derivatives]
    assert states == [*(f"q[{i}]" for i in range(1, 7)), *(f"qd[{i}]" for i in range(1, 7)),
                      *(f"q_m[{i}]" for i in (1, 2, 3)), *(f"qd_m[{i}]" for i in (1, 2, 3)),
                      *(f"tau_motor[{i}]" for i in range(1, 7)), *(f"xi[{i}]" for i in range(1, 7))]
    with opened.instance("me", "r3me") as m:
        m.instantiate()
        m.call("setupExperiment", None, 0.0, None)    # no event iteration: the derivatives in the start modes
        m.call("enterInitializationMode")
        m.call("exitInitializationMode")
        m.enter_continuous_time_mode()
        assert opened.n_states == plant.nx
        x, dx = m.get_x(), m.get_dx()
    np.testing.assert_array_equal(x, plant.x0)
    # the law's start modes at rest: stuck where there is Coulomb friction (the rotors of axes 1-3, the joints 4-6),
    # sliding (+1) on the joints behind the elastic gears (their friction is on the rotor)
    modes = np.asarray(plant.start(plant.x0, np.zeros(6), plant.param_defaults, np.zeros(plant.nz))).ravel()
    assert modes.tolist() == [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    expected = np.asarray(plant.ode(plant.x0, np.zeros(6), plant.param_defaults, modes), dtype=float).ravel()
    np.testing.assert_array_equal(dx, expected)


def test_model_exchange_run_matches_the_fixed_step_rule(r3_fmu):
    """FMPy's CVode (rtol 1e-8) through the ME interface, torque steps that break every joint and rotor loose:
    the speeds agree with the plant's fixed-step rule (RK4, 25 us) to 2e-3 of each joint's peak speed (measured
    <= 3e-4: the break-away instants are located independently, by CVode's root finding and by bisection; a
    torque step that only just exceeds a break-away makes that instant, and so the gap, far more sensitive)."""
    from model.compiled_plant import compiled_plant

    robot, path, _ = r3_fmu
    plant = build_plant(robot)
    u = robot.gravload(robot.q_rest) / robot.gear_ratio + np.array([3.0, 2.0, 2.0, 1.0, 1.5, 0.6])
    T = 0.2
    run = compiled_plant(robot).run(robot.parameters.vector)
    run.start(plant.x0)
    X = [run.x.copy()]
    for _ in range(2000):
        assert run.advance(u, 1e-4, 4)
        X.append(run.x.copy())
    run.close()
    X = np.array(X)
    signal = np.zeros(2, dtype=[("time", float)] + [(f"tau_m[{i}]", float) for i in range(1, 7)])
    signal["time"] = [0.0, T]
    for i in range(6):
        signal[f"tau_m[{i + 1}]"] = u[i]
    res = fmpy.simulate_fmu(path, fmi_type="ModelExchange", stop_time=T, input=signal, output_interval=1e-3,
                            relative_tolerance=1e-8, output=[f"qd[{i}]" for i in range(1, 7)])
    t = np.arange(X.shape[0]) * 1e-4
    for i in range(6):
        ref = np.interp(res["time"], t, X[:, 6 + i])
        assert np.abs(ref).max() > 0.01  # every joint moved
        assert np.abs(res[f"qd[{i + 1}]"] - ref).max() < 2e-3 * np.abs(ref).max(), i + 1
