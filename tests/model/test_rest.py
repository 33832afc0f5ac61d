"""The rest configuration: one property of the description, inside the joint box, read by everything.

A robot file without ``rest`` rests at the point of its joint box (``qlim``) nearest to zero: 0 where a
joint's range holds it, else its nearer limit (kinova's joints 2, 3 and 5 exclude 0, as the kinova-like
URDF below). The closed form is independent of the code: per joint ``min(max(0, lo), hi)``.
``manip info``, the FMU's start values (the plant's ``x0``), ``validate-fmu`` (``robot.q_rest``), the
workspace figure, the generic tour (``track``'s start) and ``teach`` all read
:attr:`~model.description.RobotDescription.q_rest`; one end-to-end check exports the FMU and reads
its start values back from ``modelDescription.xml``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from model.description import RobotDescriptionError
from model.loading import load_description
from model.robot import Robot

#: (lower, upper) per joint of the kinova-like arm: joints 2, 3 and 5 exclude 0 (one above, two below).
LIMITS = [(-3.0, 3.0), (0.8, 5.4), (-5.6, -0.6), (-2.5, 2.5), (-4.0, -1.1), (-2.0, 2.0)]
EXPECTED_REST = [0.0, 0.8, -0.6, 0.0, -1.1, 0.0]


def kinova_like_urdf(tmp_path) -> str:
    parts = ['<link name="base"/>']
    for i, (lo, hi) in enumerate(LIMITS):
        parts.append(f'<link name="l{i + 1}"><inertial><origin xyz="0 0.02 0.1"/><mass value="{1.5 - 0.2 * i}"/>'
                     '<inertia ixx="0.01" iyy="0.01" izz="0.005" ixy="0" ixz="0" iyz="0"/></inertial></link>')
        axis = "0 0 1" if i % 2 == 0 else "0 1 0"
        parts.append(f'<joint name="j{i + 1}" type="revolute"><parent link="{"base" if i == 0 else f"l{i}"}"/>'
                     f'<child link="l{i + 1}"/><origin xyz="0 0 0.2"/><axis xyz="{axis}"/>'
                     f'<limit lower="{lo}" upper="{hi}" effort="10" velocity="1"/></joint>')
    path = tmp_path / "kinova_like.urdf"
    path.write_text('<robot name="kinova_like">' + "".join(parts) + "</robot>")
    return str(path)


def test_a_robot_without_rest_rests_at_the_point_of_its_joint_box_nearest_to_zero(tmp_path):
    desc = load_description(kinova_like_urdf(tmp_path))
    closed_form = [min(max(0.0, lo), hi) for lo, hi in LIMITS]
    assert desc.q_rest.tolist() == closed_form == EXPECTED_REST
    lo, hi = desc.qlim
    assert np.all((lo <= desc.q_rest) & (desc.q_rest <= hi))
    assert not np.all((lo <= 0) & (0 <= hi))  # negative control: zeros are outside the box here
    # an unlimited joint rests at 0; a stated rest is kept
    assert load_description("scara").q_rest.tolist() == [0.0, 0.0, 1.0, 0.0]  # the file's rest
    assert np.all(load_description("puma560").q_rest == np.clip(0.0, *load_description("puma560").qlim))


def test_a_rest_outside_the_limits_is_refused_naming_the_joint(tmp_path):
    path = kinova_like_urdf(tmp_path)
    toml = tmp_path / "arm.toml"
    toml.write_text(f'name = "arm"\nurdf = "{path}"\nrest = [0.0, 0.0, -1.0, 0.0, -2.0, 0.0]\n')
    with pytest.raises(RobotDescriptionError, match=r"link 2: field 'rest' = 0.0: expected a rest position within qlim "
                                                    r"\[0.8, 5.4\]"):
        load_description(toml)


def test_every_consumer_starts_at_the_one_rest(tmp_path):
    from model.plant import build_plant
    from model.tasks import tour
    from workbench.formatting import format_info

    desc = load_description(kinova_like_urdf(tmp_path))
    robot = Robot(desc)
    rest = desc.q_rest
    assert robot.q_rest.tolist() == rest.tolist()
    assert np.asarray(build_plant(robot).x0).tolist() == rest.tolist() + [0.0] * desc.n  # the FMU's start values
    assert tour(desc).waypoints[0].tolist() == rest.tolist() == tour(desc).waypoints[-1].tolist()  # track's start
    assert "rest q [rad or m]: [0.0, 0.8, -0.6, 0.0, -1.1, 0.0]" in format_info(desc)  # manip info


def test_the_teach_page_starts_at_rest(tmp_path):
    """The teach page's sliders start at q_rest (it used to clip zeros into the limits on its own)."""
    pytest.importorskip("viser")
    from workbench.teach import start_teach

    page = start_teach(Robot(load_description(kinova_like_urdf(tmp_path))))
    try:
        assert page.q.tolist() == EXPECTED_REST
    finally:
        page.stop()


def test_the_exported_fmu_starts_at_rest(tmp_path):
    """End to end: the FMU's q start values in modelDescription.xml are the rest, not zeros."""
    from fmu.build import export_fmu
    from fmu.opened import open_fmu

    desc = load_description(kinova_like_urdf(tmp_path))
    path = export_fmu(Robot(desc), tmp_path / "kinova_like.fmu", platforms=None, progress=lambda _m: None)
    with open_fmu(path) as fmu:
        root = ET.fromstring(fmu.model_description_xml())
    starts = {v.get("name"): float(v[0].get("start")) for v in root.iter("ScalarVariable")
              if v.get("name", "").startswith("q[") and v[0].get("start") is not None}
    assert [starts[f"q[{i + 1}]"] for i in range(desc.n)] == EXPECTED_REST
