"""export_fmu(robot) exports the robot the user holds, and reading the FMU back gives the same robot.

* Its parameters (payload, friction, gravity) are the FMU parameters' start values, and the FMU's
  Co-Simulation from those start values equals the plant of that robot advanced by its
  fixed-step rule (fmu.validate.plant_states) to rounding: 1e-12 rad (the same C rule on the same
  generated expressions; seen 0 to 2e-16), while the robot without them misses by > 1e-6.
* Its motor model is the FMU's ("full" against "reflected" on the planar 2R, whose full model
  has a different B(q): the FMU follows the full plant to rounding and misses the reflected one).
* A ``motor_model`` keyword that differs from the Robot's is an InputError, not an override.
* Reading back (fmu.robot_resource.reload_fmu_robot, from resources/robot.json) gives a Robot equal to
  the exported one: description, motor model and parameters.
* ``platforms`` takes the names the CLI's --platforms takes.
* The tool outputs are in the world frame W, as ``fkine``: with a base pose they differ from the
  pose in the robot's frame 0, and their descriptions say so.
"""

from __future__ import annotations

import warnings
import zipfile

import numpy as np
import pytest

from fmu import export_fmu
from fmu.simulate import simulate_cs, step_input
from fmu.robot_resource import reload_fmu_robot
from fmu.validate import plant_states
from model import InertiaConsistencyWarning, InputError, Robot, load_robot
from model.description import BUILTIN_DIR
from model.loading import load_description

TOL = 1e-12  # rad, rad/s: see the module docstring


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return fn(*args, **kw)


def _start_values(path):
    from fmu.opened import open_fmu

    return {v.name: float(v.start) for v in open_fmu(path).md.modelVariables
            if v.causality == "parameter" and v.start is not None}


def _cs_against_plant(path, robot, tau, t_end=0.3, step=1e-3):
    """FMPy Co-Simulation from the FMU's own start values against the robot's plant rule, max |dx|."""
    n = robot.n
    names = [f"q[{i}]" for i in range(1, n + 1)] + [f"qd[{i}]" for i in range(1, n + 1)]
    table = step_input([f"tau_m[{i}]" for i in range(1, n + 1)], np.array([0.0]), np.array([tau]))
    res = simulate_cs(path, t_end, step, inputs=table, outputs=names)
    X = plant_states(robot, res.t, np.tile(tau, (res.t.size - 1, 1)), step)
    return float(np.max(np.abs(res.stack(names) - X)))


@pytest.fixture(scope="module")
def scara():
    return _quiet(load_robot, "scara")


def test_payload_friction_and_gravity_are_the_start_values_and_come_back(scara, tmp_path):
    p = scara.parameters
    robot = scara.with_parameters(p.with_payload(2.0, [0.01, 0.0, 0.05], [0.01, 0.02, 0.03, 0.0, 0.0, 0.0])
                                  .with_friction(viscous=1.5 * p.viscous_friction,
                                                 coulomb_pos=[0.1, 0.05, 0.2, 0.01],
                                                 coulomb_neg=[-0.1, -0.06, -0.2, -0.02])
                                  .with_gravity([0.0, 0.5, -9.7]))
    path = _quiet(export_fmu, robot, tmp_path / "loaded.fmu")
    start = _start_values(path)
    for name, value in robot.parameters.as_dict().items():
        assert start[name] == value, name
    assert start["payload_mass"] == 2.0
    back = reload_fmu_robot(path)
    assert back == robot and back.parameters == robot.parameters and back.motor_model == "reflected"
    assert back != scara                                       # negative control: equality sees the parameters
    tau = np.array([0.05, -0.02, 0.1, 0.001])
    assert _cs_against_plant(path, robot, tau) <= TOL
    assert _cs_against_plant(path, scara, tau) > 1e-6          # the FMU is not the robot without them


def test_the_full_motor_model_is_the_fmus_and_comes_back(tmp_path):
    robot = _quiet(Robot, _quiet(load_description, "planar2r"), motor_model="full")
    path = _quiet(export_fmu, robot, tmp_path / "planar2r_full.fmu")
    from fmu.robot_resource import fmu_robot

    assert fmu_robot(path) == ("planar2r", "full")
    back = reload_fmu_robot(path)
    assert back == robot and back.motor_model == "full"
    reflected = Robot(robot.description)
    assert not np.allclose(robot.inertia([0.3, 0.4]), reflected.inertia([0.3, 0.4]), rtol=1e-6)
    tau = np.array([0.02, -0.01])
    assert _cs_against_plant(path, robot, tau) <= TOL
    assert _cs_against_plant(path, reflected, tau) > 1e-6


def test_a_motor_model_keyword_that_differs_from_the_robots_is_refused(tmp_path):
    robot = _quiet(Robot, _quiet(load_description, "planar2r"), motor_model="full")
    with pytest.raises(InputError, match=r"motor_model: 'reflected' differs from the robot's own 'full'"):
        export_fmu(robot, tmp_path / "x.fmu", motor_model="reflected")
    assert not (tmp_path / "x.fmu").exists()
    # a name or path still takes the keyword
    assert reload_fmu_robot(_quiet(export_fmu, "planar2r", tmp_path / "y.fmu", motor_model="full")).motor_model == "full"


def test_platforms_take_the_names_of_the_cli(tmp_path):
    from fmu.binaries import carried_platforms

    path = _quiet(export_fmu, "planar2r", tmp_path / "named.fmu", platforms=["host", "win64"])
    assert set(carried_platforms(path)) == {"x86_64-linux", "x86_64-windows"}
    path = _quiet(export_fmu, "planar2r", tmp_path / "host.fmu", platforms="linux64")
    assert set(carried_platforms(path)) == {"x86_64-linux"}
    with pytest.raises(InputError, match=r"platforms: unknown platform 'win32'; known: host, linux64"):
        export_fmu("planar2r", tmp_path / "bad.fmu", platforms=["host", "win32"])


def test_the_tool_outputs_are_in_the_world_frame_and_say_so(tmp_path):
    text = (BUILTIN_DIR / "planar2r.toml").read_text().replace('name = "planar2r"', 'name = "planar2r_based"')
    text = text.replace("[[links]]", 'base = { xyz = [0.5, -0.2, 1.0], rpy = [0.0, 0.0, 1.0] }\n\n[[links]]', 1)
    toml = tmp_path / "based.toml"
    toml.write_text(text)
    robot = _quiet(Robot, _quiet(load_description, toml))
    assert robot.description.base is not None
    path = _quiet(export_fmu, robot, tmp_path / "based.fmu")
    from fmu.opened import open_fmu

    described = {v.name: v.description for v in open_fmu(path).md.modelVariables}
    assert "in the world frame W" in described["tool_position[1]"] and "not frame 0" in described["tool_position[1]"]
    assert "in the world frame W" in described["tool_rpy[3]"] and "R_WE" in described["tool_rpy[3]"]
    res = simulate_cs(path, 0.05, 1e-3, outputs=["q[1]", "q[2]", "tool_position[1]", "tool_position[2]",
                                                 "tool_position[3]"])
    q = np.array([res["q[1]"][-1], res["q[2]"][-1]])
    p_fmu = np.array([res[f"tool_position[{k}]"][-1] for k in (1, 2, 3)])
    T_WE = robot.fkine(q)
    np.testing.assert_allclose(p_fmu, T_WE[:3, 3], rtol=0, atol=1e-14)
    T_0E = np.linalg.inv(robot.description.T_base) @ T_WE
    assert np.linalg.norm(p_fmu - T_0E[:3, 3]) > 0.1           # not the pose in frame 0
    with zipfile.ZipFile(path) as zf:
        assert "world frame" in zf.read("modelDescription.xml").decode()
