"""The joint-table CSV (model/joint_table.py): exact round trip, and every malformed file refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from model import load_robot
from model.joint_table import JointTableError, read_joint_table, write_joint_table

NAMES = ("shoulder", "elbow")


def _write(tmp_path, text: str):
    path = tmp_path / "data.csv"
    path.write_text(text)
    return path


def test_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(3)
    t = np.arange(50) * 1e-3
    groups = {"q": rng.normal(size=(50, 2)), "qd": rng.normal(size=(50, 2)) * 1e-17}
    path = write_joint_table(tmp_path / "traj.csv", t, groups, NAMES)
    table = read_joint_table(path, NAMES, ("q",), ("qd", "qdd"))
    assert list(table.groups) == ["q", "qd"] and "qdd" not in table
    np.testing.assert_array_equal(table.t, t)
    for g, values in groups.items():
        np.testing.assert_array_equal(table[g], values)  # repr round-trips every double bit for bit
    assert path.read_text().splitlines()[0] == "time,q_shoulder,q_elbow,qd_shoulder,qd_elbow"


def test_joint_names_come_from_the_description():
    assert load_robot("scara").description.joint_names == ("shoulder", "elbow", "quill", "wrist")
    names = load_robot("puma560").description.joint_names
    assert len(names) == 6 and len(set(names)) == 6


@pytest.mark.parametrize("text, message", [
    ("", "empty"),
    ("time;q_shoulder;q_elbow\n0;0;0\n1;0;0\n", "semicolons"),
    ("t,q_shoulder,q_elbow\n0,0,0\n1,0,0\n", "first column 't': expected 'time'"),
    ("time,q_shoulder,q_elbw\n0,0,0\n1,0,0\n", "unknown column 'q_elbw' (column 3)"),
    ("time,q_shoulder,q_elbow,q_elbow\n0,0,0,0\n1,0,0,0\n", "appears twice"),
    ("time,qd_shoulder,qd_elbow\n0,0,0\n1,0,0\n", "missing columns q_shoulder .. q_elbow"),
    ("time,q_shoulder,q_elbow,qd_shoulder\n0,0,0,0\n1,0,0,0\n", "missing column 'qd_elbow'"),
    ("time,q_elbow,q_shoulder\n0,0,0\n1,0,0\n", "columns out of order"),
    ("time,q_shoulder,q_elbow\n0,0,0\n", "1 data row(s)"),
    ("time,q_shoulder,q_elbow\n0,0,0\n1,0\n", "line 3: 2 values: expected 3"),
    ("time,q_shoulder,q_elbow\n0,0,0\n1,x,0\n", "line 3: column 'q_shoulder' = 'x': expected a number"),
    ("time,q_shoulder,q_elbow\n0,0,0\n1,nan,0\n", "expected a finite number"),
    ("time,q_shoulder,q_elbow\n0,0,0\n0,0,0\n", "line 3: time 0.0 after 0.0: expected strictly increasing"),
])
def test_malformed_files_are_refused_in_one_line(tmp_path, text, message):
    path = _write(tmp_path, text)
    with pytest.raises(JointTableError) as info:
        read_joint_table(path, NAMES, ("q",), ("qd",), what="trajectory file")
    assert message in str(info.value) and str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_comments_and_a_misspelt_column_get_a_suggestion(tmp_path):
    path = _write(tmp_path, "# logged by hand\ntime,q_shoulder,q_elbow,qd_shoulder,qd_elbw\n0,0,0,0,0\n1,1,1,1,1\n")
    with pytest.raises(JointTableError, match="did you mean 'qd_elbow'"):
        read_joint_table(path, NAMES, ("q",), ("qd",))
    good = _write(tmp_path, "# logged by hand\ntime,q_shoulder,q_elbow\n0,0,0\n\n1,1,2\n")
    np.testing.assert_array_equal(read_joint_table(good, NAMES, ("q",))["q"], [[0, 0], [1, 2]])
