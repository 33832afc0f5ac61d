"""Closed loops through FMUs: the plant FMU with the Python controller, with controller FMUs, and in libcosim.

Every run is the seed's SCARA pick-and-place (15 s, 1 kHz) compared with the pure
Python loop :func:`closed_loop.simulate_tracking` driving the same
controller, sample by sample.

Tolerances. Both loops hold the torque over the period and integrate the same
ODE with classical RK4 at the same sub-step (``internal_step = dt / substeps``,
one sub-step here); the compiled right-hand sides perform the same operations
(no FMA contraction: neither build targets it), and the controller FMUs run the
Python controller's own law Function (control_design.laws). The only
arithmetic that differs is the association of RK4's final weighted sum
(``k1 + 2 (k2 + k3) + k4`` in C, ``k1 + 2 k2 + 2 k3 + k4`` in Python): at most
about one ulp of the state per step. Summed coherently over N = 15 000 steps with
no help from the loop's damping, that is ``N ulp(3 m) = 15e3 x 4.4e-16 = 7e-12``
in q; :data:`TOL_Q` = 1e-10 leaves a factor 15 for transient amplification by the
closed loop. Velocity errors follow position errors through the loop
(``|d qd| <~ wn |d q|``, wn ~ 50 rad/s for both designs): :data:`TOL_QD` = 1e-8.
Torques: through the stiffest motor-side gains (``|Kp G| <= 1.1e4 N m/rad``,
``|Kd G| <= 3.1e2 N m s/rad``) those bounds give 4e-6 N m: :data:`TOL_TAU` = 1e-5.
Seen: 4e-16 (q), 2e-14 (qd), 3e-13 N m (tau_m). A one-period delay, a wrong sign,
gain or saturation changes q by 1e-6 to 1e-4, far above these.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from closed_loop import (OnePeriodDelay, closed_loop_through_fmu, controller_fmu_kind, controller_spec,
                         export_controller_fmu, run_closed_loop, run_libcosim_closed_loop, simulate_tracking,
                         validate_controller_fmu)
from control_design import NO_LIMIT, design_robot, plant_with_mismatch, reference_task
from control_design.computed_torque import ModelMismatch
from control_design.controllers import DecentralisedController
from control_design.errors import SimulationDivergedError
from fmu import export_fmu
from fmu.instance import FmuCallError
from fmu.opened import open_fmu
from model import InertiaConsistencyWarning, load_robot
from model.errors import InputError

from tests.support.fmu_support import heavy_scara_fmu, scara_fmu

TOL_Q = 1e-10    # rad or m
TOL_QD = 1e-8    # rad/s or m/s
TOL_TAU = 1e-5   # N m
RATE = 1000.0


@pytest.fixture(scope="module")
def robot():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot("scara")


@pytest.fixture(scope="module")
def task(robot):
    return reference_task(robot)


@pytest.fixture(scope="module")
def designs(robot):
    return {kind: design_robot(robot, kind, analyse=False) for kind in ("pd", "ct")}


@pytest.fixture(scope="module")
def plant_fmu():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return scara_fmu()


@pytest.fixture(scope="module")
def controller_fmus(designs, tmp_path_factory):
    folder = tmp_path_factory.mktemp("controller_fmus")
    return {kind: export_controller_fmu(d, folder / f"{kind}.fmu", rate_hz=RATE) for kind, d in designs.items()}


@pytest.fixture(scope="module")
def python_runs(robot, task, designs):
    """The reference loops: pure Python, and the same with a one-period delay (libcosim's Jacobi coupling)."""
    runs = {}
    for kind, d in designs.items():
        runs[kind] = simulate_tracking(robot, d.controller(RATE), task)
        runs[kind + "+delay"] = simulate_tracking(robot, OnePeriodDelay(d.controller(RATE)), task)
    return runs


def assert_same_run(a, b, *, n_samples=None):
    """Sample-by-sample agreement within the tolerances of the module docstring."""
    k = a.t.size if n_samples is None else n_samples
    assert a.t.size == k and np.array_equal(a.t, b.t[:k])
    assert np.max(np.abs(a.q - b.q[:k])) <= TOL_Q
    assert np.max(np.abs(a.qd - b.qd[:k])) <= TOL_QD
    assert np.max(np.abs(a.tau_m - b.tau_m[:k])) <= TOL_TAU
    assert np.array_equal(a.q_ref, b.q_ref[:k]) and np.array_equal(a.qdd_ref, b.qdd_ref[:k])


# ------------------------------------------------------------ controller FMUs

@pytest.mark.parametrize("kind", ["pd", "ct"])
def test_controller_fmu_validates_with_zero_problems(kind, designs, controller_fmus):
    report = validate_controller_fmu(controller_fmus[kind], designs[kind].controller(RATE), samples=300, seed=3)
    assert report.problems() == []
    assert report.description_problems == () and report.binary_problems == ()
    assert report.max_rel_diff <= 1e-12                               # the same operations in the same order
    assert 0.1 < report.saturated_fraction < 0.9                      # both branches of the clipping exercised
    assert controller_fmu_kind(controller_fmus[kind]) == ("scara", kind)


@pytest.mark.parametrize("kind", ["pd-ff", "pd-g"])
def test_other_decentralised_kinds_export_and_validate(kind, robot, tmp_path):
    design = design_robot(robot, kind, analyse=False)
    path = export_controller_fmu(design, tmp_path / f"{kind}.fmu", rate_hz=RATE)
    report = validate_controller_fmu(path, design.controller(RATE), samples=100, seed=5)
    assert report.problems() == []


def test_controller_fmu_variables(robot, designs):
    pd = controller_spec(designs["pd"].controller(RATE), robot)
    assert len(pd.states) == 0 and pd.step == pytest.approx(1e-3)
    assert [q.name for q in pd.inputs][:: 4] == ["q_ref[1]", "qd_ref[1]", "q[1]", "qd[1]"]
    assert [q.name for q in pd.outputs] == [f"tau_m[{i}]" for i in range(1, 5)]
    names = [q.name for q in pd.params]
    assert names[:4] == ["Kp[1]", "Kp[2]", "Kp[3]", "Kp[4]"] and "gear_ratio[3]" in names and all(pd.p_tunable)
    ct = controller_spec(designs["ct"].controller(RATE), robot)
    assert "qdd_ref[4]" in [q.name for q in ct.inputs]
    assert {"model.payload_mass", "model.gravity[3]", "tau_m_max[1]"} <= {q.name for q in ct.params}
    unsaturated = controller_spec(designs["pd"].controller(RATE, saturate=False), robot)
    assert np.all(unsaturated.p_start[12:16] == NO_LIMIT)


@pytest.fixture(scope="module")
def pid_fmu(robot, tmp_path_factory):
    design = design_robot(robot, "pid", analyse=False)
    return design, export_controller_fmu(design, tmp_path_factory.mktemp("pid") / "pid.fmu", rate_hz=RATE)


def test_pid_controller_fmu_integrator_is_a_sampled_state(robot, pid_fmu):
    """The PID's integrator z[i] is a discrete state ticked once per period: the torques equal the Python
    controller's over 300 random samples (the integrator carried from sample to sample) to 1e-12."""
    design, path = pid_fmu
    spec = controller_spec(design.controller(RATE), robot)
    assert [q.name for q in spec.discrete.states] == [f"z[{i}]" for i in range(1, 5)]
    assert spec.discrete.period == pytest.approx(1e-3) and "Ki[1]" in [q.name for q in spec.params]
    report = validate_controller_fmu(path, design.controller(RATE), samples=300, seed=3)
    assert report.problems(tol=1e-12) == [] and report.max_rel_diff <= 1e-12
    assert 0.05 < report.saturated_fraction < 0.95                   # the anti-wind-up branch is exercised
    assert controller_fmu_kind(path) == ("scara", "pid")


def test_pid_controller_fmu_steps_ticks_and_state(pid_fmu):
    """A step of two periods is two ticks with the inputs held; a step that is no whole number of periods,
    Model Exchange, and a serialised state of the wrong size are refused; the FMU state carries z."""
    _, path = pid_fmu
    inputs = [f"{g}[{i}]" for g in ("q_ref", "qd_ref", "q", "qd") for i in range(1, 5)]
    q_ref = np.array([0.1, 0.2, 0.05, 0.3])
    u = np.concatenate([q_ref, np.zeros(4), q_ref - 1e-6 * np.arange(1, 5), np.zeros(4)])  # unsaturated
    z = [f"z[{i}]" for i in range(1, 5)]
    with open_fmu(path) as fmu:
        assert "me" not in fmu.interfaces and "cs" in fmu.interfaces
        with fmu.instance("cs", "a") as a, fmu.instance("cs", "b") as b:
            for s in (a, b):
                s.start(0.0)
                s.set(inputs, u)
            a.do_step(0.0, 2e-3)
            b.do_step(0.0, 1e-3)
            b.do_step(1e-3, 1e-3)
            za = a.get(z)
            assert np.array_equal(za, b.get(z)) and np.all(za != 0)
            state = a.get_state()
            blob = a.serialize(state)
            a.do_step(2e-3, 1e-3)
            assert not np.array_equal(a.get(z), za)
            a.set_state(a.deserialize(blob))
            assert np.array_equal(a.get(z), za)                          # z is in the (serialised) FMU state
            with pytest.raises(FmuCallError):
                a.deserialize(blob[:-8])
            with pytest.raises(FmuCallError):
                b.do_step(2e-3, 1.5e-3)                                  # not a whole number of periods
        with pytest.raises(InputError, match="has no Model Exchange interface"):
            fmu.instance("me", "me")
        fmu.interfaces["me"] = fmu.interfaces["cs"]  # ask the binary itself: fmi2Instantiate(fmi2ModelExchange)
        with pytest.raises(FmuCallError, match="instantiating 'me' failed"), fmu.instance("me", "me") as me:
            me.instantiate()


def test_plant_fmu_with_pid_controller_fmu_matches_python_loop(robot, task, plant_fmu, pid_fmu):
    """3 s of the pick-and-place: the plant FMU with the PID FMU against the Python loop with the PID."""
    design, path = pid_fmu
    ref = simulate_tracking(robot, design.controller(RATE), task, t_final=3.0)
    res = run_closed_loop(plant_fmu, path, task, plant=robot, t_final=3.0)
    assert res.controller == "pid"
    assert_same_run(res, ref)
    pd = simulate_tracking(robot, design_robot(robot, "pd", analyse=False).controller(RATE), task, t_final=3.0)
    assert np.max(np.abs(pd.q - res.q)) > 1e3 * TOL_Q               # the integrator did act


# ------------------------------------------------- (a) plant FMU + Python controller

@pytest.mark.parametrize("kind", ["pd", "ct"])
def test_plant_fmu_with_python_controller_matches_python_loop(kind, robot, task, designs, plant_fmu, python_runs):
    seen = []
    res = run_closed_loop(plant_fmu, designs[kind].controller(RATE), task, plant=robot,
                          progress=lambda f, t, tf: seen.append((f, t, tf)))
    ref = python_runs[kind]
    assert res.t[-1] == pytest.approx(15.0) and res.t.size == 15001
    assert_same_run(res, ref)
    assert (res.controller, res.robot, res.substeps, res.rate_hz) == (kind, "scara", ref.substeps, RATE)
    assert np.array_equal(res.tau_m_max, ref.tau_m_max)
    m, mr = res.metrics(), ref.metrics()
    assert np.allclose(m.max_error, mr.max_error, rtol=1e-6, atol=1e-12)
    assert len(seen) == 15000 and seen[-1] == (1.0, pytest.approx(15.0), pytest.approx(15.0))


def test_an_fmi3_plant_fmu_runs_the_same_loops_bit_for_bit(robot, designs, task, plant_fmu, controller_fmus,
                                                         tmp_path):
    """The master drives an FMI 3.0 plant FMU through the same adapter: 1 s with the Python controller and with
    the controller FMU equals the FMI 2.0 plant's runs bit for bit (the same C, the same calls)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        fmi3 = export_fmu(robot, tmp_path / "scara3.fmu", step=1.0 / RATE, fmi_version=3)
    with open_fmu(fmi3) as fmu:
        assert fmu.fmi_version == 3
    for controller in (designs["pd"].controller(RATE), controller_fmus["pd"]):
        a = run_closed_loop(fmi3, controller, task, plant=robot, t_final=1.0)
        b = run_closed_loop(plant_fmu, controller, task, plant=robot, t_final=1.0)
        assert a.t.size == 1001
        for field in ("q", "qd", "tau_m", "tau_m_max"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


# ------------------------------------------------- (b) plant FMU + controller FMU

@pytest.mark.parametrize("kind", ["pd", "ct"])
def test_plant_fmu_with_controller_fmu_matches_python_loop(kind, robot, task, plant_fmu, controller_fmus,
                                                           python_runs):
    res = run_closed_loop(plant_fmu, controller_fmus[kind], task, plant=robot)
    assert res.controller == kind and res.rate_hz == RATE
    assert_same_run(res, python_runs[kind])
    assert np.array_equal(res.tau_m_max, python_runs[kind].tau_m_max)


def test_controller_fmu_parameters_are_live(robot, task, designs, plant_fmu, controller_fmus):
    """A gain changed in the FMU acts like the same gain changed in the Python controller."""
    base = designs["pd"].controller(RATE)
    Kp = base.Kp.copy()
    Kp[1] *= 0.5
    changed = DecentralisedController("pd", Kp, base.Kd, base.Ki, base.G, RATE, base.tau_m_max)
    ref = simulate_tracking(robot, changed, task, t_final=2.0)
    res = run_closed_loop(plant_fmu, controller_fmus["pd"], task, plant=robot, t_final=2.0,
                          controller_parameters={"Kp[2]": float(Kp[1])})
    assert_same_run(res, ref)
    nominal = simulate_tracking(robot, base, task, t_final=2.0)
    assert np.max(np.abs(nominal.q - res.q)) > 1e3 * TOL_Q       # the change did matter


def test_plant_parameters_follow_the_plant_robot(robot, task, designs, plant_fmu, controller_fmus):
    """A payload unknown to the computed-torque controller: set in the plant FMU from the plant Robot."""
    plant = plant_with_mismatch(robot, ModelMismatch(payload_mass=5.0))
    ref = simulate_tracking(plant, designs["ct"].controller(RATE), task, t_final=3.0)
    res = run_closed_loop(plant_fmu, controller_fmus["ct"], task, plant=plant, t_final=3.0)
    assert_same_run(res, ref)
    exact = run_closed_loop(plant_fmu, controller_fmus["ct"], task, plant=robot, t_final=3.0)
    assert np.max(np.abs(exact.q - res.q)) > 1e3 * TOL_Q


# ------------------------------------------------- (c) libcosim, two FMUs connected

@pytest.mark.parametrize("kind", ["pd", "ct"])
def test_libcosim_loop_is_the_python_loop_with_one_period_delay(kind, robot, task, plant_fmu, controller_fmus,
                                                                python_runs):
    res = run_libcosim_closed_loop(plant_fmu, controller_fmus[kind], task, plant=robot)
    assert res.t.size == 15001 and res.controller == kind
    assert_same_run(res, python_runs[kind + "+delay"])
    # libcosim's Jacobi coupling is a real one-period delay, visible against the undelayed loop, and small
    gap = np.max(np.abs(res.q - python_runs[kind].q))
    assert 1e3 * TOL_Q < gap < 1e-3


def test_libcosim_agrees_with_the_fmpy_master_running_the_delayed_loop(robot, task, designs, plant_fmu,
                                                                       controller_fmus):
    via_fmpy = run_closed_loop(plant_fmu, OnePeriodDelay(designs["pd"].controller(RATE)), task, plant=robot,
                               t_final=2.0)
    via_libcosim = run_libcosim_closed_loop(plant_fmu, controller_fmus["pd"], task, plant=robot, t_final=2.0)
    assert np.max(np.abs(via_fmpy.q - via_libcosim.q)) <= 1e-13      # same binaries, same arithmetic
    assert np.max(np.abs(via_fmpy.tau_m - via_libcosim.tau_m)) <= 1e-10


def test_the_plant_fmu_takes_the_python_loops_substeps(robot, task, designs, plant_fmu):
    """RK4 with 1 and 3 sub-steps differ by only ~1e-14 here, so the check is relative to that difference."""
    ct = designs["ct"].controller(RATE)
    one = simulate_tracking(robot, ct, task, t_final=2.0, substeps=1)
    three = simulate_tracking(robot, ct, task, t_final=2.0, substeps=3)
    res = run_closed_loop(plant_fmu, ct, task, plant=robot, t_final=2.0, substeps=3)
    assert res.substeps == 3
    assert np.max(np.abs(res.q - three.q)) < 1e-2 * np.max(np.abs(one.q - three.q))


def test_an_initial_state_off_the_reference_reaches_both_masters(robot, task, designs, plant_fmu, controller_fmus):
    q0, qd0 = np.array([0.02, -0.03, 1.05, 0.1]), np.array([0.1, 0.0, -0.05, 0.0])
    pd = designs["pd"].controller(RATE)
    ref = simulate_tracking(robot, pd, task, t_final=0.5, q0=q0, qd0=qd0)
    assert_same_run(run_closed_loop(plant_fmu, pd, task, plant=robot, t_final=0.5, q0=q0, qd0=qd0), ref)
    delayed = simulate_tracking(robot, OnePeriodDelay(pd), task, t_final=0.5, q0=q0, qd0=qd0)
    cosim = run_libcosim_closed_loop(plant_fmu, controller_fmus["pd"], task, plant=robot, t_final=0.5, q0=q0, qd0=qd0)
    assert_same_run(cosim, delayed)
    assert np.max(np.abs(cosim.q[1] - q0)) > 1e-5                   # it moved from q0, not from the reference


# ------------------------------------------------- the demo's entry point, errors

def test_closed_loop_through_fmu_exports_once_and_runs(robot, task, designs, tmp_path, python_runs):
    said = []
    a = closed_loop_through_fmu(robot, designs["pd"], task, tmp_path, controller_fmu=True, t_final=1.0,
                                say=said.append)
    built = {p.name: p.stat().st_mtime for p in tmp_path.glob("*.fmu")}
    assert set(built) == {"scara.fmu", "scara_pd_controller.fmu"}
    b = closed_loop_through_fmu(robot, designs["pd"], task, tmp_path, controller_fmu=False, t_final=1.0)
    assert {p.name: p.stat().st_mtime for p in tmp_path.glob("*.fmu")} == built   # reused, not rebuilt
    assert_same_run(a, python_runs["pd"], n_samples=1001)
    assert_same_run(b, python_runs["pd"], n_samples=1001)
    assert any("controller FMU" in line for line in said)


def test_an_unstable_loop_is_reported(robot, task, designs, plant_fmu):
    base = designs["pd"].controller(RATE, saturate=False)
    wild = DecentralisedController("pd", base.Kp * 1e4, base.Kd * 1e4, base.Ki, base.G, RATE)
    with pytest.raises(SimulationDivergedError, match="the plant FMU rejected the step at t = "):
        run_closed_loop(plant_fmu, wild, task, plant=robot, t_final=1.0)


def test_bad_inputs_are_named(robot, task, designs, plant_fmu, tmp_path):
    controller = designs["pd"].controller(RATE)
    with pytest.raises(ValueError, match="plant_fmu: expected an FMU file, got '.*missing.fmu'"):
        run_closed_loop(tmp_path / "missing.fmu", controller, task, plant=robot)
    with pytest.raises(ValueError, match="is not a controller FMU"):
        run_closed_loop(plant_fmu, plant_fmu, task, plant=robot)
    with pytest.raises(ValueError, match="t_final: expected at least one control period"):
        run_closed_loop(plant_fmu, controller, task, plant=robot, t_final=0.0)
    with pytest.raises(ValueError, match="rate_hz: the Python controller runs at 1000 Hz"):
        run_closed_loop(plant_fmu, controller, task, plant=robot, rate_hz=500.0)


def test_a_plant_fmu_of_a_modified_robot_carries_its_own_description(robot, task, designs, plant_fmu):
    """The mass-scaled SCARA FMU keeps the name scara but embeds its description (resources/robot.json):
    the master simulates the heavy arm it holds, not the built-in SCARA, with or without ``plant=``."""
    controller = designs["pd"].controller(RATE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        heavy = heavy_scara_fmu()
        plant = plant_with_mismatch(robot, ModelMismatch(link_mass_scale=1.5))
    alone = run_closed_loop(heavy, controller, task, t_final=0.01)
    given = run_closed_loop(heavy, controller, task, plant=plant, t_final=0.01)
    nominal = run_closed_loop(plant_fmu, controller, task, t_final=0.01)
    assert alone.t.size == 11
    np.testing.assert_array_equal(alone.q, given.q)
    # negative control: the 1.5x heavier arm really is what ran (it lags the nominal SCARA's FMU)
    assert np.abs(alone.q - nominal.q).max() > 1e-9
