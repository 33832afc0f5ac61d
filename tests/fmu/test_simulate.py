"""The SCARA FMU simulated by FMPy (Co-Simulation and Model Exchange) against the Python plant.

Input: the computed-torque feed-forward of the seed's pick-and-place, first
segment (rest to A, 3 s), held for 10 ms at a time. Open loop, so the horizon
stays short; the reference is the one plant (model/plant.py) advanced by its
fixed-step rule at an eighth of the FMU's internal step, one hold interval at a
time (fmu.validate.reference_response). Model Exchange (CVode) is the
independent integrator of the comparison.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from fmu.simulate import simulate_cs, simulate_me, step_input, variable_names
from fmu.validate import (ME_RTOL, TOLERANCES, directional_derivative_error, feedforward_profile,
                          reference_response, state_roundtrip, tracking_error, validate_fmu)
from model import InertiaConsistencyWarning, load_robot
from model.plant import build_plant

from tests.support.fmu_support import Harness, heavy_scara_fmu, scara_fmu

N = 4
TAU = [f"tau_m[{i}]" for i in range(1, N + 1)]
STATES = [f"q[{i}]" for i in range(1, N + 1)] + [f"qd[{i}]" for i in range(1, N + 1)]
TOOL = ["tool_position[1]", "tool_position[2]", "tool_position[3]"]


@pytest.fixture(scope="module")
def scenario():
    """Robot, plant, torque profile and the Python reference, computed once."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot("scara")
    plant = build_plant(robot)
    profile = feedforward_profile(robot, t_end=3.0, hold=0.01)
    t_ref, X_ref = reference_response(robot, profile)
    u_last = np.vstack([profile.tau_m, profile.tau_m[-1]])
    P_ref = np.array([np.asarray(plant.out(x, u, plant.param_defaults)).reshape(-1)[3 * N:3 * N + 3]
                      for x, u in zip(X_ref, u_last)])
    return robot, plant, profile, t_ref, X_ref, P_ref


def test_profile_is_the_pick_and_place_feedforward(scenario):
    robot, plant, profile, t_ref, X_ref, _ = scenario
    assert profile.tau_m.shape == (300, N)
    assert np.max(np.abs(profile.tau_m[:, :2])) > 1e-3          # joints 1 and 2 move ...
    assert np.allclose(profile.q_plan[-1], [np.pi / 2, np.pi / 2, 1.0, 0.0])
    # ... and open loop the plant stays near the plan over this horizon (the comparison is meaningful)
    assert np.max(np.abs(X_ref[:, :N] - profile.q_plan)) < 1e-3


def test_co_simulation_matches_python_model(scenario):
    _, _, profile, t_ref, X_ref, P_ref = scenario
    table = step_input(TAU, profile.t_switch, profile.tau_m)
    cs = simulate_cs(scara_fmu(), 3.0, 1e-3, inputs=table, outputs=STATES + TOOL)
    err = tracking_error("Co-Simulation", cs.t, cs.stack(STATES), cs.stack(TOOL), t_ref, X_ref, P_ref)
    print(err.line())
    # RK4 at 1 ms on the SCARA's slow feed-forward: its own error is ~1e-13 (seen 3e-13 against the reference)
    assert err.q.max() < 1e-9 and err.qd.max() < 1e-9
    assert err.tool_position < 1e-9


def test_model_exchange_cvode_matches_python_model(scenario):
    _, _, profile, t_ref, X_ref, P_ref = scenario
    table = step_input(TAU, profile.t_switch, profile.tau_m)
    me = simulate_me(scara_fmu(), 3.0, 1e-3, inputs=table, outputs=STATES + TOOL, relative_tolerance=ME_RTOL)
    err = tracking_error("Model Exchange", me.t, me.stack(STATES), me.stack(TOOL), t_ref, X_ref, P_ref)
    print(err.line())
    assert max(err.relative.values()) < TOLERANCES["me"]


def test_variable_communication_step_takes_equal_substeps(scenario):
    """h = 2.5 ms takes ceil(2.5) = 3 RK4 sub-steps; uneven steps land on the same solution."""
    _, plant, profile, t_ref, X_ref, _ = scenario
    u = profile.tau_m[0]
    h = Harness("cs").start()
    try:
        h.fmu.setReal(h.vr(*TAU), list(u))
        times = [0.0, 2.5e-3, 3.0e-3, 10.0e-3]             # steps 2.5 ms, 0.5 ms, 7 ms
        for t0, t1 in zip(times[:-1], times[1:]):
            h.fmu.doStep(currentCommunicationPoint=t0, communicationStepSize=t1 - t0)
        x = h.states()
    finally:
        h.close()
    # the first hold interval (10 ms) of the reference has this very input
    assert np.max(np.abs(x - X_ref[1])) < 1e-12


def test_outputs_at_start_are_the_rest_configuration():
    h = Harness("cs").start()
    try:
        names = variable_names(scara_fmu(), "output")
        values = dict(zip(names, h.fmu.getReal(h.vr(*names))))
    finally:
        h.close()
    assert [values[f"q[{i}]"] for i in range(1, 5)] == [0.0, 0.0, 1.0, 0.0]
    assert values["tool_position[1]"] == pytest.approx(4.0)     # a1 + a2, arm stretched along x
    assert values["qm[3]"] == pytest.approx(-53.7063)           # G q for the quill at 1 m


def test_state_round_trips_reproduce_the_run_bit_for_bit(scenario):
    _, _, profile, *_ = scenario
    rt = state_roundtrip(scara_fmu(), profile.at, TAU, STATES + TOOL, steps_before=300, steps_after=300)
    assert rt.get_set_identical and rt.deserialized_identical and rt.me_identical
    assert rt.serialized_size == 136 + 8 * (8 + 4 + 25 + 4)     # header, x, u, p, friction modes


def test_directional_derivatives_match_finite_differences():
    worst, count, adjoint = directional_derivative_error(scara_fmu())
    assert count == (8 + 4 + 22) * (8 + 10)     # knowns: x, u, 22 tunable p; unknowns: xdot and 10 outputs
    assert worst < TOLERANCES["directional"] and adjoint is None     # FMI 2.0: no reverse mode


def test_instances_share_no_state():
    """Two instances stepped alternately with different inputs equal each one run alone, bit for bit."""
    def run(instances, inputs, steps=100):
        for k in range(steps):
            for h, u in zip(instances, inputs):
                h.fmu.setReal(h.vr(*TAU), u)
                h.fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
        return [h.states() for h in instances]

    u_a, u_b = [0.02, -0.01, 0.0, 0.001], [-0.03, 0.02, 0.0, -0.002]
    pair = [Harness("cs", "a").start(), Harness("cs", "b").start()]
    alone_a, alone_b = Harness("cs", "a_alone").start(), Harness("cs", "b_alone").start()
    try:
        together = run(pair, [u_a, u_b])
        ref_a, = run([alone_a], [u_a])
        ref_b, = run([alone_b], [u_b])
    finally:
        for h in pair + [alone_a, alone_b]:
            h.close()
    assert together[0].tobytes() == ref_a.tobytes() and together[1].tobytes() == ref_b.tobytes()
    assert not np.array_equal(ref_a, ref_b)


def test_validate_fmu_command_reports_every_check(capsys):
    from workbench.cli import main

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        status = main(["validate-fmu", str(scara_fmu())])
    out = capsys.readouterr().out
    print(out)
    assert status == 0
    for expected in ("(FMPy validation): 0 problems", "Co-Simulation (RK4, h=0.001) max|q - q_ref|",
                     "Model Exchange (CVode 1e-10) max|q - q_ref|", "get/set identical",
                     "directional derivatives vs central differences", "libcosim, two instances",
                     "result: OK"):
        assert expected in out


def test_validate_flags_a_wrong_model(scenario, monkeypatch):
    """Validation is not a rubber stamp: against a reference with other friction it reports the errors."""
    import importlib

    v = importlib.import_module("fmu.validate")   # the submodule (the package's `validate` is the function)

    _, plant, *_ = scenario
    original = v.reference_response

    def wrong(robot, profile, p=None, **kw):
        p = np.array(robot.parameters.vector, dtype=float)
        p[list(robot.parameters.layout.names).index("viscous_friction[1]")] *= 2.0
        return original(robot, profile, p=p, **kw)

    monkeypatch.setattr(v, "reference_response", wrong)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        report = validate_fmu(scara_fmu(), with_cosim=False)
    assert not report.ok
    failed = {c.name for c in report.checks if not c.passed}
    assert {"Co-Simulation q", "Model Exchange q"} <= failed
    text = report.format()
    # every failed check is named on the console with its figure and its bound
    assert "FAIL Co-Simulation q: max|q - q_ref| / " in text and "> bound " in text


def test_validate_a_robot_from_a_file_with_coulomb_friction(tmp_path):
    """A TOML robot with Coulomb friction, validated from the FMU alone against the stick-slip reference."""
    from fmu import export_fmu
    from fmu.robot_resource import fmu_robot
    from model.description import BUILTIN_DIR

    text = (BUILTIN_DIR / "planar2r.toml").read_text().replace('name = "planar2r"', 'name = "planar2r_coulomb"')
    text = text.replace("viscous_friction = 0.01\n", "viscous_friction = 0.01\ncoulomb_friction = [0.05, -0.04]\n")
    toml = tmp_path / "planar2r_coulomb.toml"
    toml.write_text(text)
    path = export_fmu(str(toml), tmp_path / "planar2r_coulomb.fmu")
    assert fmu_robot(path) == ("planar2r_coulomb", "reflected")
    toml.unlink()                                       # validation needs nothing but the FMU
    report = validate_fmu(path, t_end=1.0)
    print(report.format())
    assert report.ok, report.problems()
    assert any("Coulomb friction with stick-slip" in note for note in report.notes)
    assert "quintic from rest" in report.profile


def test_validate_without_libcosimpy_skips_the_libcosim_check(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "libcosimpy", None)   # `import libcosimpy` now raises ImportError
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        report = validate_fmu(scara_fmu(), t_end=0.5, with_cosim=True)
    text = report.format()
    assert report.ok, report.problems()
    assert report.cosim_between_instances is None and report.cosim_skipped
    assert "libcosim: skipped (libcosimpy is not importable" in text and "result: OK" in text


def test_validate_fmu_command_names_a_file_that_is_not_an_fmu(tmp_path, capsys):
    import zipfile

    from workbench.cli import main

    text = tmp_path / "bad.fmu"
    text.write_text("not a zip")
    assert main(["validate-fmu", str(text)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"not an FMU: {text} is not a zip archive" in err
    empty = tmp_path / "empty.fmu"
    with zipfile.ZipFile(empty, "w") as zf:
        zf.writestr("readme.txt", "no model description")
    assert main(["validate-fmu", str(empty)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"not an FMU: {empty} has no modelDescription.xml" in err


def test_validate_compares_a_modified_robot_with_its_own_description():
    """An FMU of a mass-scaled SCARA keeps the name scara; its embedded description, not the built-in SCARA,
    is the reference (the built-in one would miss by the 1.5x masses)."""
    from fmu.robot_resource import reload_fmu_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = reload_fmu_robot(heavy_scara_fmu())
        scara = load_robot("scara")
        assert robot.name == "scara" and robot.description.digest() != scara.description.digest()
        assert robot.description.links[1].mass == pytest.approx(1.5 * scara.description.links[1].mass)
        report = validate_fmu(heavy_scara_fmu(), t_end=1.0, with_cosim=False)
    print(report.format())
    assert report.ok, report.problems()
    assert report.errors and report.roundtrip is not None
