"""``manip export-urdf``: any description written as URDF, read back by us and by Pinocchio.

Round trip (description -> URDF + companion TOML -> load): the same model to 1e-12
relative to max(1, |value|): the only change is the frames' rpy written as text with
17 significant digits and read back (~1e-16 each) and products of a few 4x4 matrices,
so 1e-12 leaves margin yet catches any wrong placement, axis, inertia or motor term.
Pinocchio reading the exported URDF: 1e-10, as in ``test_dynamics_pinocchio.py``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from model import BUILTIN_ROBOTS, InertiaConsistencyWarning, Robot
from model.loading import load_description
from model.urdf_export import export_urdf
from tests.support.references import friction_reference
from tests.support.urdf_references import pin_q
from workbench.cli import main


def close(actual, expected, rtol):
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * scale)


def states(n, seed, count=3):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-2.0, 2.0, (3, n)) for _ in range(count)]


VARIANT = '''name = "variant arm"
convention = "{convention}"
gravity = [0.5, -1.0, -9.7]
base = {{xyz = [0.1, -0.2, 0.3], rpy = [0.2, -0.1, 0.4]}}
tool = {{xyz = [0.0, 0.02, 0.11], rpy = [0.0, 0.3, -0.2]}}

[[links]]
joint = "revolute"
a = 0.1
alpha = 1.5707963267948966
d = 0.35
theta = 0.2
mass = 3.0
com = [0.01, -0.05, 0.02]
inertia = [0.05, 0.04, 0.03, 0.001, -0.002, 0.003]
motor_inertia = 2e-4
gear_ratio = 50.0
viscous_friction = 1e-3
coulomb_friction = [0.1, -0.12]
qlim = [-2.5, 2.5]

[[links]]
joint = "prismatic"
a = 0.3
alpha = -0.4
d = 0.1
theta = 0.5
mass = 1.5
com = [0.1, 0.0, -0.03]
inertia = [0.01, 0.02, 0.015, 0.0, 0.001, 0.0]
flip = true

[[links]]
joint = "revolute"
a = 0.25
alpha = 0.0
d = -0.05
theta = -0.3
mass = 0.8
com = [0.05, 0.01, 0.0]
inertia = [0.002, 0.003, 0.004, 0.0, 0.0, 0.0005]
flip = true
gear_ratio = -30.0
motor_inertia = 1e-4
'''


@pytest.fixture(scope="module", params=[*BUILTIN_ROBOTS, "variant-standard", "variant-modified"])
def exported(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        if request.param.startswith("variant-"):
            source = folder / "variant.toml"
            source.write_text(VARIANT.format(convention=request.param.split("-")[1]))
            desc = load_description(source)
        else:
            desc = load_description(request.param)
        urdf, toml = export_urdf(desc, folder / "arm.urdf", folder / "arm.toml")
        back = load_description(toml)
    return desc, back, urdf


def test_round_trip_is_the_same_model(exported):
    desc, back, _ = exported
    assert back.convention == "urdf" and back.n == desc.n and back.joint_types == desc.joint_types
    np.testing.assert_array_equal(back.qlim, desc.qlim)
    assert back.gravity == desc.gravity and back.rest == desc.rest
    for a, b in zip(desc.links, back.links):
        assert (a.motor_inertia, a.gear_ratio, a.viscous_friction, a.coulomb_friction, a.torque_limit) == \
            (b.motor_inertia, b.gear_ratio, b.viscous_friction, b.coulomb_friction, b.torque_limit)
    r0, r1 = Robot(desc), Robot(back)
    # dynamics through the CasADi Functions (no C compile of both models; compiled = symbolic is test_codegen's)
    d0, d1 = r0.dynamics, r1.dynamics
    p0, p1 = r0.parameters.vector, r1.parameters.vector
    np.testing.assert_array_equal(p1, p0)  # payload, friction, gravity
    for q, qd, qdd in states(desc.n, 7):
        close(r1.fkine(q), r0.fkine(q), 1e-12)
        close(r1.jacob0(q), r0.jacob0(q), 1e-12)
        close(np.array(d1.functions.rne(q, qd, qdd, p1)), np.array(d0.functions.rne(q, qd, qdd, p0)), 1e-12)
        close(np.array(d1.functions.inertia(q, p1)), np.array(d0.functions.inertia(q, p0)), 1e-12)


def test_pinocchio_reads_the_export_to_the_same_numbers(exported):
    desc, _, urdf = exported
    robot = Robot(desc)
    model = pin.buildModelFromUrdf(str(urdf))
    model.gravity = pin.Motion(np.array(desc.gravity), np.zeros(3))
    model.armature = np.array([lk.gear_ratio ** 2 * lk.motor_inertia for lk in desc.links])
    data = model.createData()
    fid = model.getFrameId("tool" if desc.tool is not None else "flange")
    for q, qd, qdd in states(desc.n, 8):
        qp = pin_q(model, q)
        pin.computeJointJacobians(model, data, qp)
        pin.updateFramePlacements(model, data)
        close(robot.fkine(q), data.oMf[fid].homogeneous, 1e-10)
        close(robot.jacob0(q), pin.getFrameJacobian(model, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED), 1e-10)
        close(robot.rne(q, qd, qdd), pin.rnea(model, data, qp, qd, qdd) + friction_reference(desc, qd), 1e-10)
        M = pin.crba(model, data, qp)
        close(robot.inertia(q), np.triu(M) + np.triu(M, 1).T, 1e-10)


def test_cli_writes_atomically_and_refuses_an_unwritable_folder(tmp_path, capsys):
    target = tmp_path / "arm.urdf"
    target.write_text("old content")
    assert main(["export-urdf", "planar2r", "-o", str(target)]) == 0
    assert target.read_text().startswith("<?xml") and "old content" not in target.read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.urdf"]  # no temporary file left behind
    assert f"wrote {target}" in capsys.readouterr().out
    assert load_description(target).n == 2
    # a missing folder is created, as for every output of the CLI; an unwritable one is refused before any work
    assert main(["export-urdf", "planar2r", "-o", str(tmp_path / "missing" / "arm.urdf")]) == 0
    assert load_description(tmp_path / "missing" / "arm.urdf").n == 2
    capsys.readouterr()
    assert main(["export-urdf", "planar2r", "-o", "/proc/manip-missing/arm.urdf"]) == 2
    assert capsys.readouterr().err.startswith("manip export-urdf: error: --output: cannot create the directory '/proc/manip-missing'")
