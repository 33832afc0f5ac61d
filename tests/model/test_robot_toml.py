"""Descriptions written as robot TOML read back as the same robot (model.robot_toml).

Every DH built-in and the modified-DH Panda: the same digest (the physical content, bit for bit), the same
joint limits, ratings, names, rest and tasks. Base and tool poses go through roll-pitch-yaw, so they read back
to rounding (1e-15). A URDF description is refused in one line (it has no DH table).
"""

from __future__ import annotations

import numpy as np
import pytest

from model.description import description_from_dict, pose_matrix
from model.errors import InputError
from model.limits import tomllib
from model.loading import load_description
from model.robot_toml import robot_toml_text, write_robot_toml
from tests.support.identification import with_poses

DH_ROBOTS = ("scara", "planar2r", "planar3r", "arm4", "spherical", "puma560", "tests/data/panda_mdh.toml")


@pytest.mark.parametrize("name", DH_ROBOTS)
def test_round_trip_is_exact(name):
    desc = load_description(name)
    back = description_from_dict(tomllib.loads(robot_toml_text(desc, header="a header\nof two lines")), "x.toml")
    assert back.digest() == desc.digest()
    assert back.qlim.tolist() == desc.qlim.tolist()
    assert [lk.torque_limit for lk in back.links] == [lk.torque_limit for lk in desc.links]
    assert back.joint_names == desc.joint_names and back.rest == desc.rest and back.name == desc.name
    assert [dict(t) for t in back.tasks] == [dict(t) for t in desc.tasks]


def test_base_and_tool_read_back_to_rounding(tmp_path, recwarn):
    desc = with_poses(load_description("puma560"))
    path = write_robot_toml(desc, tmp_path / "posed.toml")
    back = load_description(path)
    for key in ("base", "tool"):
        np.testing.assert_allclose(pose_matrix(getattr(back, key)), pose_matrix(getattr(desc, key)), atol=1e-15)
    assert back.links == desc.links
    assert not recwarn.list  # the Puma's published link 3 keeps its note: no triangle-inequality warning


def test_a_urdf_robot_is_refused():
    with pytest.raises(InputError, match="standard or modified DH links only"):
        robot_toml_text(load_description("ur5"))
