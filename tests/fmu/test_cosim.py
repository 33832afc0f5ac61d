"""libcosim (Open Simulation Platform), the second importer: loads the FMU, runs two instances, agrees with FMPy."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from fmu.cosim import CosimError, run_libcosim
from fmu.simulate import simulate_cs, step_input
from fmu.validate import feedforward_profile
from model import InertiaConsistencyWarning, load_robot

from tests.support.fmu_support import build_root, scara_fmu, trivial_fmu

TAU = [f"tau_m[{i}]" for i in range(1, 5)]
OUTPUTS = ["q[1]", "q[2]", "q[3]", "q[4]", "qd[1]", "qd[2]", "tool_position[1]", "tool_rpy[3]"]


@pytest.fixture(scope="module")
def profile():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot("scara")
    return feedforward_profile(robot, t_end=1.0, hold=0.01)


def test_two_instances_side_by_side_agree_with_fmpy(profile):
    res = run_libcosim(scara_fmu(), stop_time=1.0, step=1e-3, inputs=profile.at, input_names=TAU,
                       output_names=OUTPUTS)
    a, b = res.values["robot_a"], res.values["robot_b"]
    assert a.shape == (1000, len(OUTPUTS)) and np.allclose(res.t[[0, -1]], [1e-3, 1.0])
    assert a.tobytes() == b.tobytes()                                   # no shared state between instances
    cs = simulate_cs(scara_fmu(), 1.0, 1e-3, inputs=step_input(TAU, profile.t_switch, profile.tau_m),
                     outputs=OUTPUTS)
    fmpy_values = cs.stack(OUTPUTS)[1:]                                 # FMPy also records t = 0
    assert np.max(np.abs(a - fmpy_values)) < 1e-12
    assert np.max(np.abs(a[:, 1])) > 0.01                               # joint 2 did move


def test_instances_with_different_names_and_a_second_fmu():
    res = run_libcosim(trivial_fmu(), stop_time=0.5, step=1e-2, inputs=lambda t: [1.0], input_names=["u"],
                       output_names=["x"], instances=("lag_1", "lag_2", "lag_3"))
    for name in ("lag_1", "lag_2", "lag_3"):
        x = res.values[name][:, 0]
        assert x[-1] == pytest.approx(1.0 - np.exp(-0.5), abs=1e-9)      # RK4 at 10 ms on a unit lag


def test_a_missing_fmu_is_an_error_not_a_crash():
    with pytest.raises(CosimError, match="fmu_path: expected an FMU file, got '.*missing.fmu'"):
        run_libcosim(build_root() / "missing.fmu", stop_time=0.1, step=1e-3)


def test_a_corrupt_fmu_is_an_error_not_a_crash():
    """run_libcosim refuses it in the archive check, before libcosim sees it (a behaviour change of the
    hostile-input work: it was libcosim's refusal); libcosim's own refusal is still an error, not a crash."""
    from libcosimpy.CosimExecution import CosimExecution

    from fmu.archive import FmuArchiveError
    from fmu.cosim import add_slave

    bad = build_root() / "corrupt.fmu"
    bad.write_bytes(b"this is not a zip file")
    with pytest.raises(FmuArchiveError, match="not an FMU: .*corrupt.fmu is not a zip archive"):
        run_libcosim(bad, stop_time=0.1, step=1e-3)
    execution = CosimExecution.from_step_size(1_000_000)
    with pytest.raises(CosimError, match="libcosim could not load corrupt.fmu as instance 'robot_a'"):
        add_slave(execution, bad, "robot_a")


def test_unknown_variable_names_are_reported():
    with pytest.raises(CosimError, match=r"instance 'robot_a': no variables \['tau'\] in scara.fmu"):
        run_libcosim(scara_fmu(), stop_time=0.1, step=1e-3, input_names=["tau"])
