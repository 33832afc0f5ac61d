"""Robot-file keys of "bring your own robot": convention, base, tool, flip, units, tasks, any name.

Every bad input is a one-line RobotDescriptionError naming the file, the link
(when there is one), the field and the value; the tests match the messages.
The last test keeps ``docs/robot-file.md`` and the validator in step.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from model import Robot
from model.description import SI_UNITS, RobotDescriptionError, description_from_dict, identifier_from_name
from model.loading import load_description
from model.tasks import PICK_AND_PLACE, WaypointError, find_task, robot_tasks

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

LINK = '[[links]]\njoint = "revolute"\na = 1.0\nalpha = 0.0\nd = 0.0\ntheta = 0.0\nqlim = [-2.0, 2.0]\n'
PRISMATIC = '[[links]]\njoint = "prismatic"\na = 0.0\nalpha = 0.0\nd = 0.0\ntheta = 0.0\nqlim = [0.0, 0.5]\n'
DOCS = Path(__file__).resolve().parents[2] / "docs" / "robot-file.md"


def _load(tmp_path, top, links=LINK + PRISMATIC, name='name = "arm"\n'):
    path = tmp_path / "arm.toml"
    path.write_text(name + top + links)
    return path, load_description(path)


def _refused(tmp_path, top, message, links=LINK + PRISMATIC):
    path = tmp_path / "arm.toml"
    path.write_text('name = "arm"\n' + top + links)
    with pytest.raises(RobotDescriptionError, match="^" + re.escape(f"{path}{message}")) as info:
        load_description(path)
    assert "\n" not in str(info.value)


# ------------------------------------------------------------------ name and identifier

@pytest.mark.parametrize(("name", "identifier"), [
    ("Puma 560 (Unimation)", "Puma_560_Unimation"),
    ("scara", "scara"),
    ("6-axis arm", "r_6_axis_arm"),
    ("Bras articulé", "Bras_articul"),
    ("???", "robot"),
    ("a.b-c_d", "a_b_c_d"),
])
def test_identifier_from_name(name, identifier):
    assert identifier_from_name(name) == identifier
    assert re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", identifier)


def test_any_non_empty_name_is_accepted_and_gives_an_identifier(tmp_path):
    _, desc = _load(tmp_path, "", name='name = "Puma 560 (Unimation)"\n')
    assert desc.name == "Puma 560 (Unimation)"
    assert desc.identifier == "Puma_560_Unimation"


# ------------------------------------------------------------------ convention, base, tool, flip

def test_convention_base_tool_flip_are_read(tmp_path):
    top = ('convention = "modified"\nbase = { xyz = [0.1, 0.2, 0.3], rpy = [0.0, 0.0, 1.5707963267948966] }\n'
           'tool = { xyz = [0.0, 0.0, 0.1] }\n')
    _, desc = _load(tmp_path, top, LINK + "flip = true\n" + PRISMATIC)
    assert desc.convention == "modified"
    assert [lk.flip for lk in desc.links] == [True, False]
    np.testing.assert_allclose(desc.T_base, [[0, -1, 0, 0.1], [1, 0, 0, 0.2], [0, 0, 1, 0.3], [0, 0, 0, 1]], atol=1e-15)
    np.testing.assert_array_equal(desc.T_tool, [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]])


def test_defaults_are_standard_dh_without_base_or_tool(tmp_path):
    _, desc = _load(tmp_path, "")
    assert (desc.convention, desc.base, desc.tool, desc.tip) == ("standard", None, None, None)
    assert not any(lk.flip for lk in desc.links)


def test_physical_keys_change_the_digest(tmp_path):
    digests = {_load(tmp_path, top)[1].digest() for top in (
        "", 'convention = "modified"\n', "base = { xyz = [0.0, 0.0, 0.5] }\n", "tool = { rpy = [0.1, 0.0, 0.0] }\n")}
    assert len(digests) == 4


@pytest.mark.parametrize(("top", "links", "message"), [
    ('convention = "craig"\n', LINK, ": field 'convention' = 'craig': expected 'standard' or 'modified'"),
    ('convention = "urdf"\n', LINK, ": field 'convention' = 'urdf': expected 'standard' or 'modified' (URDF robots "),
    ("base = [0.0, 0.0, 0.5]\n", LINK, ": field 'base' = [0.0, 0.0, 0.5]: expected a table {xyz = [x, y, z], rpy = "),
    ("base = { xyz = [0.0, 0.5] }\n", LINK, ": field 'base.xyz' = [0.0, 0.5]: expected a list of 3 numbers"),
    ("tool = { rpy = [0.0, 0.0, \"x\"] }\n", LINK, ": field 'tool.rpy[2]' = 'x': expected a number"),
    ("tool = { xyz = [0.0, 0.0, 0.1], quat = [1, 0, 0, 0] }\n", LINK,
     ": field 'tool.quat' = [1, 0, 0, 0]: expected one of the known keys (xyz, rpy)"),
    ("", LINK + "flip = 1\n", ", link 1: field 'flip' = 1: expected true or false"),
])
def test_bad_convention_pose_or_flip(tmp_path, top, links, message):
    _refused(tmp_path, top, message, links)


# ------------------------------------------------------------------ units

def test_si_units_are_accepted(tmp_path):
    table = "\n".join(f'{k} = "{v[-1]}"' for k, v in SI_UNITS.items())
    _, desc = _load(tmp_path, f"[units]\n{table}\n\n")
    assert set(desc.extra["units"]) == set(SI_UNITS)


@pytest.mark.parametrize(("units", "message"), [
    ('angle = "deg"', ": field 'units.angle' = 'deg': expected the SI unit 'rad': robot files are in SI units only"),
    ('length = "mm"', ": field 'units.length' = 'mm': expected the SI unit 'm': robot files are in SI units only"),
    ('inertia = "g cm^2"', ": field 'units.inertia' = 'g cm^2': expected the SI unit 'kg m^2' or "),
    ('colour = "red"', ": field 'units.colour' = 'red': expected one of the known quantities (length, angle, "),
])
def test_non_si_units_are_refused(tmp_path, units, message):
    _refused(tmp_path, f"[units]\n{units}\n\n", message)


# ------------------------------------------------------------------ tasks

TASK = '[[tasks]]\nname = "wave"\nsegment_time = 2.0\nwaypoints = [[0.0, 0.1], [1.0, 0.2], [0.0, 0.1]]\n\n'


def test_tasks_are_read_and_found_by_name(tmp_path):
    path, desc = _load(tmp_path, TASK)
    tasks = robot_tasks(desc)
    assert list(tasks) == ["wave"]
    wave = find_task(desc, "wave")
    np.testing.assert_array_equal(wave.waypoints, [[0.0, 0.1], [1.0, 0.2], [0.0, 0.1]])
    assert wave.segment_time == 2.0 and wave.labels == ("waypoint 0", "waypoint 1", "waypoint 2")
    traj = wave.trajectory(dt=0.01)
    assert traj.t[-1] == pytest.approx(4.0)
    np.testing.assert_allclose(traj.q[-1], [0.0, 0.1], atol=1e-12)


def test_tour_only_by_name_and_never_called_pick_and_place(tmp_path):
    _, desc = _load(tmp_path, "")
    assert robot_tasks(desc) == {}
    tour = find_task(desc, "tour")
    assert tour.name == "tour" and tour.waypoints.shape == (4, 2)
    np.testing.assert_allclose(tour.waypoints[1], [-1.0, 0.125])  # 25 % of [-2, 2] and of [0, 0.5]
    with pytest.raises(WaypointError, match=re.escape("task 'pick-and-place': robot 'arm' has no such task; expected one of 'tour'")):
        find_task(desc, "pick-and-place")


def test_scara_pick_and_place_is_data_of_its_file():
    scara = robot_tasks("scara")
    assert list(scara) == ["pick_and_place"]
    assert find_task("scara", "pick-and-place") is not PICK_AND_PLACE
    np.testing.assert_array_equal(scara["pick_and_place"].waypoints, PICK_AND_PLACE.waypoints)
    half = 0.5 * np.pi
    np.testing.assert_array_equal(PICK_AND_PLACE.waypoints[[1, 4]], [[half, half, 1.0, 0.0], [half, 0.0, 1.0, 0.0]])
    assert PICK_AND_PLACE.labels == ("rest", "A", "B (pick)", "A", "C", "D (place)")


def test_reference_task_is_keyed_on_the_file_not_the_name():
    """A SCARA renamed keeps its task; the reference motion of a robot without tasks is the tour."""
    import dataclasses

    from control_design.reference import reference_task_name, task_trajectory

    scara = load_description("scara")
    renamed = Robot(dataclasses.replace(scara, name="my SCARA"))
    assert reference_task_name(renamed) == "pick_and_place"
    assert reference_task_name(Robot(load_description("planar2r"))) == "tour"
    with pytest.raises(WaypointError, match=r"robot 'planar2r' has no such task"):
        task_trajectory(Robot(load_description("planar2r")), "pick-and-place")


@pytest.mark.parametrize(("task", "message"), [
    ('[[tasks]]\nwaypoints = [[0.0, 0.1], [1.0, 0.2]]\n', ": field 'tasks[1].name' = None: expected this required key"),
    ('[[tasks]]\nname = "t"\nwaypoints = [[0.0, 0.1]]\n', ": field 'tasks[1].waypoints' = [[0.0, 0.1]]: expected a list of at least 2"),
    ('[[tasks]]\nname = "t"\nwaypoints = [[0.0, 0.1], [1.0]]\n', ": field 'tasks[1].waypoints[2]' = [1.0]: expected a list of 2 numbers"),
    ('[[tasks]]\nname = "t"\nwaypoints = [[0.0, 0.1], [1.0, 0.9]]\n',
     ", link 2: field 'tasks[1].waypoints[2]' = 0.9: expected a joint value within qlim [0.0, 0.5]"),
    ('[[tasks]]\nname = "t"\nsegment_time = 0.0\nwaypoints = [[0.0, 0.1], [1.0, 0.2]]\n',
     ": field 'tasks[1].segment_time' = 0.0: expected a duration > 0 (s)"),
    ('[[tasks]]\nname = "t"\nlabels = ["a"]\nwaypoints = [[0.0, 0.1], [1.0, 0.2]]\n',
     ": field 'tasks[1].labels' = ['a']: expected a list of 2 strings, one per waypoint"),
    ('[[tasks]]\nname = "t"\nspeed = 1\nwaypoints = [[0.0, 0.1], [1.0, 0.2]]\n', ": field 'tasks[1].speed' = 1: expected one of the known keys"),
    (TASK + TASK, ": field 'tasks[2].name' = 'wave': expected a task name not used by another [[tasks]] entry"),
])
def test_bad_tasks_are_refused(tmp_path, task, message):
    _refused(tmp_path, task + "\n", message)


# ------------------------------------------------------------------ docs/robot-file.md and the validator

def _documented_keys() -> dict[str, set[str]]:
    """Keys of each key table of the page: rows ``| `key` | ...`` under a ``### ... keys`` heading."""
    sections: dict[str, set[str]] = {}
    current = None
    for line in DOCS.read_text().splitlines():
        heading = re.match(r"### (.+) keys\b", line)
        if heading:
            current = heading.group(1).lower()
            sections[current] = set()
            continue
        row = re.match(r"\| `([A-Za-z_][A-Za-z0-9_.]*)` \|", line)
        if row and current is not None:
            sections[current].add(row.group(1))
    return sections


def test_docs_list_every_key_the_validator_knows_and_no_other():
    from model import description as d

    docs = _documented_keys()
    assert docs["robot"] == set(d._TOP_REQUIRED) | set(d._TOP_OPTIONAL)
    assert docs["link"] == set(d._LINK_REQUIRED) | set(d._LINK_OPTIONAL)
    assert docs["pose"] == set(d._POSE_KEYS)
    assert docs["task"] == set(d._TASK_REQUIRED) | set(d._TASK_OPTIONAL)
    assert docs["units"] == set(SI_UNITS)
    text = DOCS.read_text()
    for quantity, spellings in SI_UNITS.items():
        for unit in spellings:
            assert f"`{unit}`" in text, f"SI spelling {unit!r} of {quantity} is not documented"
    for key in ("urdf", "base_link", "tip_link", "joints.NAME"):
        assert f"`{key}`" in text


def test_every_example_of_the_docs_loads(tmp_path):
    blocks = re.findall(r"```toml\n(.*?)```", DOCS.read_text(), flags=re.S)
    examples = [b for b in blocks if b.lstrip().startswith("name =") and "urdf =" not in b]
    assert examples, "docs/robot-file.md has no complete robot example"
    for k, text in enumerate(examples):
        path = tmp_path / f"example{k}.toml"
        path.write_text(text)
        desc = load_description(path)
        assert Robot(desc).fkine(desc.q_rest).shape == (4, 4)


def test_descriptions_built_in_code_take_the_same_keys():
    desc = description_from_dict({"name": "x", "convention": "modified", "tool": {"xyz": [0, 0, 0.2]},
                                  "links": [{"joint": "revolute", "a": 0, "alpha": 0, "d": 0, "theta": 0, "flip": True}]})
    assert desc.convention == "modified" and desc.links[0].flip and desc.T_tool[2, 3] == 0.2
