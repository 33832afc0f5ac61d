"""The elastic plant in the compiled closed loop and in sweeps: the Manutec r3 under its P-PI cascade (issue 23).

The kernel (:mod:`closed_loop.kernel`) runs the drive-train plant (state ``[q; qd; q_m; qd_m; tau_m; xi]``, one
friction mode per joint and per elastic rotor) with the same fixed-step rule on the same generated expressions as
the Python loop (:func:`closed_loop.simulate_tracking`), and the cascade as a generated law
(:func:`control_design.cascade.cascade_law`) whose operations are those of ``CascadeController.update_motor``.
The only difference is the kernel plant's link-mass scale (a multiplication by 1.0 in another expression
graph), so the runs agree to rounding.

Tolerances. The r3's ptp run to 1 s at 20 kHz is N = 20 000 periods of 2 RK4 sub-steps: an ulp of difference
per step, unhelped by the loop's damping, gives 4e4 x ulp(2 rad) = 2e-11 rad; TOL = 1e-9 rad (the bound of the
rigid kernel against the Python loop, ``test_one_plant.py``) leaves a factor 50 for the loop's transient
amplification (seen 7e-16 rad). Speeds, torques and rotor speeds: the same count relative to each signal's peak
(4e4 x 2.2e-16 = 9e-12) with a factor 100 left: REL = 1e-9 of the peak (seen 2e-14 of qd's peak). Negative
control: a plant whose Coulomb friction differs by 1e-4 (relative) misses the Python loop by more than 10 TOL
(seen 1.2e-7 rad).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from closed_loop.kernel import closed_loop_kernel
from closed_loop.schedule import Schedule
from closed_loop.simulate import simulate_tracking
from control_design.cascade import cascade_from_robot
from model.robot import load_robot
from model.tasks import robot_tasks

TOL = 1e-9  # rad: see the module docstring
REL = 1e-9  # of a signal's peak: see the module docstring


@pytest.fixture(scope="module")
def r3():
    return load_robot("manutec_r3")


@pytest.fixture(scope="module")
def setup(r3):
    controller = cascade_from_robot(r3)
    traj = robot_tasks(r3.description)["ptp"].trajectory(controller.dt)
    python = simulate_tracking(r3, controller, traj, t_final=1.0)
    sched = Schedule.build(r3, traj, controller.dt, rate_hz=controller.rate_hz, t_final=1.0, substeps=python.substeps)
    return controller, sched, python


@pytest.fixture(scope="module")
def kernel_run(r3, setup):
    controller, sched, _ = setup
    return closed_loop_kernel(r3, "cascade").run(controller, sched, r3.parameters, record=True)


def test_the_kernel_runs_the_r3_cascade_as_the_python_loop(kernel_run, setup):
    python = setup[2]
    got = kernel_run.result
    assert got is not None and not kernel_run.diverged and got.rotor_qd is not None
    assert np.max(np.abs(got.q - python.q)) <= TOL
    for name in ("qd", "tau_m", "rotor_qd"):
        a, b = getattr(got, name), getattr(python, name)
        assert np.max(np.abs(a - b)) <= REL * np.max(np.abs(b)), name
    # the stuck samples (qd == 0 exactly: the rule zeroes a stuck coordinate) are the same samples
    assert np.array_equal(got.qd == 0.0, python.qd == 0.0) and np.any(python.qd == 0.0)
    metrics = python.metrics()
    np.testing.assert_allclose(kernel_run.max_error, metrics.max_error, rtol=0, atol=TOL)
    np.testing.assert_allclose(kernel_run.rms_error, metrics.rms_error, rtol=0, atol=TOL)
    np.testing.assert_allclose(kernel_run.peak_motor_velocity, metrics.peak_motor_velocity,
                               rtol=REL)  # the rotor speeds behind the elastic gears, as the Python loop's


def test_the_kernels_r3_reproduces_dymola_by_the_issues_rules(kernel_run):
    """The kernel's run against Dymola's ``fullRobot`` (independent of this code): each axis within 1 % of its
    speed range outside +-2 ms of a friction event and the break-aways within 0.5 ms (the issue's rules)."""
    from tests.support import robotr3 as R3

    cmp = R3.compare(kernel_run.result.t, kernel_run.result.qd)
    assert np.all(cmp.worst < 0.01), cmp.worst
    assert np.all(np.abs(cmp.breakaway[3:]) < 5e-4), cmp.breakaway
    result = kernel_run.result
    for j in range(3):  # the rotors of the elastic axes, motor-side friction
        t_first = result.t[np.flatnonzero(result.rotor_qd[:, j] != 0.0)[0]]
        assert abs(t_first - R3.ROTOR_BREAKAWAY[j]) < 5e-4, (j + 1, t_first)


def test_negative_control_a_friction_difference_shows(r3, setup):
    controller, sched, python = setup
    p = r3.parameters
    p = p.with_friction(p.field("viscous_friction"), 1.0001 * p.field("coulomb_friction_pos"),
                        1.0001 * p.field("coulomb_friction_neg"))
    other = closed_loop_kernel(r3, "cascade").run(controller, sched, p, record=True).result
    assert np.max(np.abs(other.q - python.q)) > 10 * TOL


def test_plant_gravity_with_scaled_links_is_the_rebuilt_robots(r3):
    """The kernel's start (static equilibrium) under scaled link masses: ``g_payload + s g_links`` against the
    gravity of a robot rebuilt with its link masses and inertias scaled (``plant_with_mismatch``), to 1e-12 of
    its peak (a sum of a few dozen products rounds at ~1e-15 relative; seen 6e-16)."""
    from control_design.computed_torque import ModelMismatch, plant_with_mismatch

    kernel = closed_loop_kernel(r3, "cascade")
    q = np.array([0.3, -0.5, 1.0, 0.2, -0.4, 0.7])
    p = r3.parameters.with_payload(3.0, [0.01, 0.02, 0.1])
    twin = plant_with_mismatch(r3, ModelMismatch(link_mass_scale=1.25)).with_parameters(p).gravload(q)
    got = kernel.plant_gravity(q, p, 1.25)
    assert np.max(np.abs(got - twin)) <= 1e-12 * np.max(np.abs(twin))
    assert np.max(np.abs(r3.gravload(q, p) - twin)) > 1e-3 * np.max(np.abs(twin))  # the scale matters here
    np.testing.assert_array_equal(kernel.plant_gravity(q, p, 1.0), r3.gravload(q, p))


SPEC = """robot = "manutec_r3"
controller = "cascade"
task = "ptp"
samples = 3
seed = 3
[vary]
payload_mass = [0.0, 10.0]
friction_scale = [0.5, 2.0]
link_mass_scale = [0.9, 1.1]
"""


def test_manip_sweep_runs_the_r3_cascade_and_its_worst_case_reruns_in_the_python_loop(tmp_path):
    """``manip sweep`` of the r3's cascade (payload, friction and link masses varied): its worst case re-run in
    the Python loop on that case's plant gives the table's max_error to TOL (the kernel-vs-Python-loop bound; seen 0)."""
    import json

    import pandas as pd

    from closed_loop.sweep import _case_inputs, case_setup
    from closed_loop.sweep_spec import case_values, load_spec
    from control_design.computed_torque import ModelMismatch, plant_with_mismatch

    spec_file = tmp_path / "r3.toml"
    spec_file.write_text(SPEC)
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "workbench.cli", "sweep", str(spec_file), "--out", str(out),
                           "--workers", "1"], capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr
    table = pd.read_csv(out / "results.csv")
    summary = json.loads((out / "summary.json").read_text())
    assert len(table) == 3 and not table["diverged"].any()
    assert (out / "worst_case_tracking_error.png").stat().st_size > 0
    worst = summary["worst_case"]
    spec = load_spec(spec_file)
    setup = case_setup(spec)
    values = dict(zip(spec.quantities, case_values(spec, np.array([worst["case"]]))[0]))
    _, sched, p, mass_scale, _, _ = _case_inputs(spec, setup, values)
    plant = plant_with_mismatch(setup.robot, ModelMismatch(link_mass_scale=mass_scale)).with_parameters(p)
    python = simulate_tracking(plant, cascade_from_robot(setup.robot), setup.trajectory)
    assert python.substeps == sched.substeps
    assert abs(python.metrics().max_error.max() - worst["max_error"]) <= TOL
    others = np.sort(table["max_error"].to_numpy())
    assert others[-2] < worst["max_error"] - 1e3 * TOL  # the cases differ: the worst one is told apart


@pytest.mark.parametrize("extra, key", [('bandwidth = 50.0\n', "bandwidth"),
                                        ('[vary]\ndamping = [0.5, 0.9]\n', "vary.damping")])
def test_a_cascade_sweep_refuses_a_design_quantity(tmp_path, extra, key):
    from closed_loop.sweep_spec import SweepSpecError, load_spec

    text = 'robot = "manutec_r3"\ncontroller = "cascade"\nsamples = 2\n'
    text += extra if extra.startswith("[vary]") else extra + "[vary]\npayload_mass = [0.0, 1.0]\n"
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(SweepSpecError) as info:
        load_spec(path)
    msg = str(info.value)
    assert key in msg and "[cascade]" in msg and len(msg.splitlines()) == 1


def test_the_fmu_rerun_of_a_cascade_sweep_is_refused_in_one_line(tmp_path):
    """The FMU master (``run_closed_loop``) hands a controller q, qd and starts the plant at rest: a cascade case
    is refused by name rather than run wrong."""
    from closed_loop.sweep import rerun_case_through_fmu
    from closed_loop.sweep_spec import SweepSpecError, spec_from_dict

    spec = spec_from_dict({"robot": "manutec_r3", "controller": "cascade", "samples": 2,
                           "vary": {"payload_mass": [0.0, 1.0]}})
    with pytest.raises(SweepSpecError) as info:
        rerun_case_through_fmu(spec, 0, tmp_path)
    assert "controller: 'cascade'" in str(info.value) and len(str(info.value).splitlines()) == 1
    assert info.value.parameter == "controller"
