"""The r3's plant FMU (drive trains) exported with the default step, its FMI-LS-REF experiment and validate-fmu.

* Export: the default internal step of a drive-train robot is 1 ms / ``drive_substeps`` (1/30 ms for the r3); at 1 ms
  RK4 on the r3's gear springs (about 7.5e3 rad/s) is unstable and the export's reference run diverges.
* FMI-LS-REF: the stimuli are the FMU's own inputs (its ``causality="input"`` variables), the run starts where the
  FMU starts (its continuous states after initialisation, the static equilibrium), the reference is the links' q and
  qd. Besides the replay against the workbench's rule (the same C, so to 1e-9), the experiment is replayed by FMPy's
  Model Exchange with CVode (an integrator nobody here wrote, rtol 1e-10): it must agree to 1e-5 of each column's
  scale (the margin of validate-fmu's own ME bound, 1e-4, over its 1.8 s horizon; measured ~1e-7 there).
* Negative controls: a payload of 1 g, and the reference started from the rigid arm's start state (drive trains
  unloaded) instead of the equilibrium, both fail the comparison.
* The start state is an equilibrium (a physical invariant): with the gravity torques / G held, nothing moves.
"""

from __future__ import annotations

import numpy as np
import pytest

from model.plant import build_plant
from model.robot import load_robot

fmpy = pytest.importorskip("fmpy")


@pytest.fixture(scope="module")
def r3_default(tmp_path_factory):
    import fmu

    robot = load_robot("manutec_r3")
    path = fmu.export_fmu(robot, tmp_path_factory.mktemp("r3d") / "r3.fmu", platforms="linux64")
    from fmu.opened import open_fmu

    return robot, path, open_fmu(path).md


def test_default_step_of_a_drive_train_robot(r3_default):
    from fmu.build import DEFAULT_STEP, default_step
    from model.drive_train import drive_substeps

    robot, _, md = r3_default
    step = float(next(v.start for v in md.modelVariables if v.name == "internal_step"))
    assert drive_substeps(robot.description, DEFAULT_STEP) == 30
    assert step == DEFAULT_STEP / 30
    assert default_step(load_robot("puma560")) == DEFAULT_STEP  # a rigid arm keeps 1 ms


def test_experiment_uses_the_fmus_inputs_start_and_link_states(r3_default):
    from fmu.ls_ref import read_experiment

    robot, path, md = r3_default
    exp = read_experiment(path)
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    assert list(exp.inputs.dtype.names[1:]) == inputs
    n = robot.n
    assert list(exp.reference.dtype.names[1:]) == [f"q[{i}]" for i in range(1, n + 1)] + \
        [f"qd[{i}]" for i in range(1, n + 1)]
    x0 = build_plant(robot).x0
    assert x0.size == 30
    row0 = np.array([exp.reference[c][0] for c in exp.reference.dtype.names[1:]])
    np.testing.assert_array_equal(row0, x0[:2 * n])
    # the stimulus: the task's feed-forward (motor side, N m), first hold = the computed torque at 5 ms
    from fmu.validate import feedforward_profile

    u0 = np.array([exp.inputs[c][0] for c in inputs])
    np.testing.assert_array_equal(u0, feedforward_profile(robot, t_end=0.5).tau_m[0])
    assert "static equilibrium" in open_text(path, "extra/org.fmi-standard.fmi-ls-ref/tracking.exp")


def open_text(path, member: str) -> str:
    import zipfile

    with zipfile.ZipFile(path) as zf:
        return zf.read(member).decode()


def test_ls_ref_replay_passes_and_agrees_with_cvode(r3_default):
    from fmu.ls_ref import compare_with_reference, read_experiment, replay_problems

    _, path, _ = r3_default
    exp = read_experiment(path)
    worst, problems = replay_problems(path, exp)
    assert problems == [] and worst <= 1.0, problems
    names = list(exp.reference.dtype.names[1:])
    me = fmpy.simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=exp.stop_time, output_interval=1e-3,
                           relative_tolerance=1e-10, input=exp.inputs, output=names)
    sub = exp.reference[::30]  # the reference rows at CVode's output points (every 1 ms = 30 steps)
    tm = np.asarray(me["time"])
    idx = [tm.size - 1 - int(np.argmin(np.abs(tm[::-1] - tr))) for tr in sub["time"]]  # last sample at an event
    assert np.max(np.abs(tm[idx] - sub["time"])) < 1e-12
    for c in names:
        scale = max(1.0, float(np.max(np.abs(sub[c]))))
        assert np.max(np.abs(np.asarray(me[c])[idx] - sub[c])) < 1e-5 * scale, c
    # negative control: 1 g of payload, replayed through the same comparison, fails it
    res = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=exp.stop_time, output_interval=exp.step_size,
                            input=exp.inputs, output=names, start_values={"payload_mass": 1e-3})
    worst_bad, problems_bad = compare_with_reference(res, exp)
    assert problems_bad and worst_bad > 1.0


def test_reference_from_the_wrong_start_fails(r3_default):
    """Negative control of the start state: the rule from [q_rest, 0, ..., 0] (rotors not wound up against gravity,
    current loops off) leaves the FMU's replay by far more than the tolerance."""
    from fmu.ls_ref import compare_with_reference, read_experiment
    from fmu.validate import feedforward_profile, plant_states, start_state

    robot, path, md = r3_default
    exp = read_experiment(path)
    n = robot.n
    x_wrong = np.zeros(30)
    x_wrong[:n] = robot.q_rest
    assert not np.array_equal(x_wrong, start_state(robot))
    t = exp.reference["time"]
    step = float(next(v.start for v in md.modelVariables if v.name == "internal_step"))
    profile = feedforward_profile(robot, t_end=0.5)
    U = np.array([profile.at(float(tk)) for tk in t[:-1]])
    X = plant_states(robot, t, U, step, x0=x_wrong)
    res = np.zeros(t.size, dtype=exp.reference.dtype)
    res["time"] = t
    for j, c in enumerate(exp.reference.dtype.names[1:]):
        res[c] = X[:, j]
    worst, problems = compare_with_reference(res, exp)
    assert problems and worst > 1e3
    # and from start_state the same rule is the reference (the FMU's export computed it so)
    X_ok = plant_states(robot, t, U, step)
    for j, c in enumerate(exp.reference.dtype.names[1:]):
        res[c] = X_ok[:, j]
    assert compare_with_reference(res, exp) == (0.0, [])


def test_start_state_is_at_rest_under_gravity_torques(r3_default):
    """The equilibrium (physical invariant): held at g(q_rest) / G, the FMU stays put (speeds below 1e-9 rad/s)."""
    robot, path, _ = r3_default
    u = robot.gravload(robot.q_rest) / robot.gear_ratio
    signal = np.zeros(2, dtype=[("time", float)] + [(f"tau_m[{i}]", float) for i in range(1, 7)])
    signal["time"] = [0.0, 0.1]
    for i in range(6):
        signal[f"tau_m[{i + 1}]"] = u[i]
    res = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=0.1, output_interval=1e-3, input=signal,
                            output=[f"qd[{i}]" for i in range(1, 7)])
    assert max(float(np.max(np.abs(res[f"qd[{i}]"]))) for i in range(1, 7)) < 1e-9


def test_validate_fmu_passes_on_the_drive_train_fmu(r3_default):
    from fmu.validate import validate_fmu

    _, path, _ = r3_default
    report = validate_fmu(path, t_end=1.0, with_cosim=False)
    assert report.ok, report.format()
    names = [c.name for c in report.checks]
    for expected in ("FMI-LS-REF replay", "Co-Simulation q", "Co-Simulation = plant q", "Model Exchange qd",
                     "FMU state round trips", "directional derivatives"):
        assert expected in names


def test_a_step_too_long_for_the_drive_trains_is_a_step_error(tmp_path):
    """1 ms: RK4 on the r3's gear springs (h w ~ 7.5) diverges; the export refuses it naming the step, before
    compiling anything."""
    import fmu
    from model.errors import InputError

    with pytest.raises(InputError, match="drive trains need a shorter internal step") as info:
        fmu.export_fmu(load_robot("manutec_r3"), tmp_path / "r3.fmu", step=1e-3, platforms="linux64")
    assert info.value.parameter == "step"
    assert not (tmp_path / "r3.fmu").exists()
