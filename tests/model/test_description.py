"""Robot descriptions: every built-in loads; every bad input is refused with a message naming it."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

import model
from model.description import (
    BUILTIN_ROBOTS,
    InertiaConsistencyWarning,
    RobotDescription,
    RobotDescriptionError,
    description_from_dict,
)
from model.loading import load_description

# A valid two-link robot; each field is the TOML text of its value.
_LINK = {
    "joint": '"revolute"', "a": "1.0", "alpha": "0.0", "d": "0.0", "theta": "0.0",
    "mass": "2.0", "com": "[-0.5, 0.0, 0.0]", "inertia": "[0.01, 0.1, 0.1, 0.0, 0.0, 0.0]",
    "motor_inertia": "1e-4", "gear_ratio": "50.0", "viscous_friction": "1e-3",
    "coulomb_friction": "[0.1, -0.12]", "qlim": "[-3.0, 3.0]",
}


def _toml(link2: dict[str, str | None] | None = None, top: str = 'name = "bad"\n') -> str:
    """TOML text of the valid robot with link 2's fields replaced (None: removed)."""
    lines = [top]
    for i in range(2):
        fields = dict(_LINK)
        if i == 1 and link2:
            fields.update(link2)
        lines.append("[[links]]")
        lines += [f"{k} = {v}" for k, v in fields.items() if v is not None]
    return "\n".join(lines) + "\n"


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")
@pytest.mark.parametrize("name", BUILTIN_ROBOTS)
def test_every_builtin_robot_loads(name):
    desc = load_description(name)
    assert isinstance(desc, RobotDescription)
    assert desc.name == name
    assert desc.n == len(desc.links) >= 1
    assert set(desc.joint_types) <= {"R", "P"}
    assert desc.q_rest.shape == (desc.n,)
    lo, hi = desc.qlim
    assert np.all(lo < hi) and np.all(lo <= desc.q_rest) and np.all(desc.q_rest <= hi)


def test_the_valid_template_loads(tmp_path):
    desc = load_description(_write(tmp_path, _toml()))
    assert desc.n == 2 and desc.links[1].coulomb_friction == (0.1, -0.12)


@pytest.mark.parametrize(
    ("link2", "field", "value", "expected"),
    [
        ({"a": None}, "a", "None", "this required key (it is missing)"),
        ({"mass_kg": "2.0"}, "mass_kg", "2.0", "one of the known keys"),
        ({"mass": '"2.0"'}, "mass", "'2.0'", "a number"),
        ({"mass": "true"}, "mass", "True", "a number"),
        ({"d": "nan"}, "d", "nan", "a finite number"),
        ({"alpha": "-inf"}, "alpha", "-inf", "a finite number"),
        ({"mass": "-1.0"}, "mass", "-1.0", "a number >= 0"),
        ({"com": "[0.0, 0.0]"}, "com", "[0.0, 0.0]", "a list of 3 numbers"),
        ({"com": '[0.0, "x", 0.0]'}, "com[1]", "'x'", "a number"),
        ({"inertia": "[0.1, 0.1, 0.1, 0.0, 0.0]"}, "inertia", "[0.1, 0.1, 0.1, 0.0, 0.0]", "a list of 6 numbers"),
        ({"inertia": "[0.1, 0.1, 0.1, 0.2, 0.0, 0.0]"}, "inertia", "[0.1, 0.1, 0.1, 0.2, 0.0, 0.0]",
         "a positive semi-definite inertia (its eigenvalues are [-0.1, 0.1, 0.3])"),
        ({"inertia": "[-0.1, 0.1, 0.1, 0.0, 0.0, 0.0]"}, "inertia", "[-0.1, 0.1, 0.1, 0.0, 0.0, 0.0]",
         "a positive semi-definite inertia"),
        ({"joint": '"spherical"'}, "joint", "'spherical'", "'revolute' or 'prismatic'"),
        ({"qlim": "[3.0, -3.0]"}, "qlim", "[3.0, -3.0]", "[lower, upper] with lower < upper"),
        ({"qlim": "[1.0, 1.0]"}, "qlim", "[1.0, 1.0]", "[lower, upper] with lower < upper"),
        ({"gear_ratio": "0.0"}, "gear_ratio", "0.0", "a non-zero number"),
        ({"coulomb_friction": "[-0.1, -0.12]"}, "coulomb_friction", "[-0.1, -0.12]",
         "[Tc_pos, Tc_neg] with Tc_pos >= 0 and Tc_neg <= 0"),
        ({"coulomb_friction": "[0.1, 0.12]"}, "coulomb_friction", "[0.1, 0.12]",
         "[Tc_pos, Tc_neg] with Tc_pos >= 0 and Tc_neg <= 0"),
        ({"coulomb_friction": "-0.1"}, "coulomb_friction", "-0.1", "a number >= 0"),
        ({"viscous_friction": "-1e-3"}, "viscous_friction", "-0.001", "a number >= 0"),
        ({"motor_inertia": "-1e-4"}, "motor_inertia", "-0.0001", "a number >= 0"),
        ({"name": "3"}, "name", "3", "a string"),
    ],
)
def test_bad_link_field_names_file_link_field_value_and_expectation(tmp_path, link2, field, value, expected):
    path = _write(tmp_path, _toml(link2))
    message = f"{path}, link 2: field '{field}' = {value}: expected {expected}"
    with pytest.raises(RobotDescriptionError, match=re.escape(message)):
        load_description(path)


@pytest.mark.parametrize(
    ("top", "field", "value", "expected"),
    [
        ("", "name", "None", "this required key (it is missing)"),
        ('name = "bad"\nowner = "me"\n', "owner", "'me'", "one of the known keys"),
        ('name = ""\n', "name", "''", "a non-empty string"),
        ('name = "   "\n', "name", "'   '", "a non-empty string"),
        ('name = "bad"\ngravity = [0.0, -9.81]\n', "gravity", "[0.0, -9.81]", "a list of 3 numbers"),
        ('name = "bad"\nrest = [0.0]\n', "rest", "[0.0]", "a list of 2 numbers"),
    ],
)
def test_bad_top_level_field(tmp_path, top, field, value, expected):
    path = _write(tmp_path, _toml(top=top))
    with pytest.raises(RobotDescriptionError, match=re.escape(f"{path}: field '{field}' = {value}: expected {expected}")):
        load_description(path)


def test_no_links(tmp_path):
    path = _write(tmp_path, 'name = "bad"\nlinks = []\n')
    with pytest.raises(RobotDescriptionError, match=re.escape(f"{path}: field 'links' = []: expected at least one [[links]] table")):
        load_description(path)


def test_bad_toml_syntax(tmp_path):
    path = _write(tmp_path, _toml({"mass": "2.0 kg"}))
    with pytest.raises(RobotDescriptionError, match=re.escape(f"{path}: not valid TOML: ") + r".*line \d+"):
        load_description(path)


def test_unknown_robot_name():
    with pytest.raises(RobotDescriptionError, match=r"robot 'scaara': expected a built-in name \(scara, .*\) or a TOML file path; no such file"):
        load_description("scaara")


def test_errors_are_value_errors():
    assert issubclass(RobotDescriptionError, ValueError)


def test_triangle_inequality_breaking_psd_inertia_warns_and_loads(tmp_path):
    # Principal moments 0.01 + 0.02 < 0.1: positive definite, but no rigid body has them.
    path = _write(tmp_path, _toml({"inertia": "[0.01, 0.02, 0.1, 0.0, 0.0, 0.0]"}))
    with pytest.warns(InertiaConsistencyWarning, match=re.escape(f"{path}, link 2: field 'inertia'") + ".*triangle inequality"):
        desc = load_description(path)
    assert desc.links[1].inertia == (0.01, 0.02, 0.1, 0.0, 0.0, 0.0)


def test_a_consistent_inertia_does_not_warn(tmp_path, recwarn):
    load_description(_write(tmp_path, _toml()))
    assert not [w for w in recwarn if issubclass(w.category, InertiaConsistencyWarning)]


def test_description_is_frozen(tmp_path):
    desc = load_description(_write(tmp_path, _toml()))
    with pytest.raises(dataclasses.FrozenInstanceError):
        desc.name = "other"  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        desc.links[0].mass = 3.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        desc.links[0] = desc.links[1]  # type: ignore[index]


def test_digest_follows_physics_not_names(tmp_path):
    base = load_description(_write(tmp_path, _toml()))
    renamed = load_description(_write(tmp_path, _toml(top='name = "other"\ndescription = "same arm"\n')))
    relabelled = load_description(_write(tmp_path, _toml({"name": '"elbow"'})))
    heavier = load_description(_write(tmp_path, _toml({"mass": "2.5"})))
    assert len(base.digest()) == 64
    assert renamed.digest() == base.digest() == relabelled.digest()
    assert heavier.digest() != base.digest()


def test_model_package_exports():
    assert model.BUILTIN_ROBOTS == BUILTIN_ROBOTS
    assert model.RobotDescriptionError is RobotDescriptionError


def test_digest_does_not_depend_on_how_zero_coulomb_friction_is_written(tmp_path):
    omitted = load_description(_write(tmp_path, _toml({"coulomb_friction": None})))
    scalar = load_description(_write(tmp_path, _toml({"coulomb_friction": "0.0"})))
    pair = load_description(_write(tmp_path, _toml({"coulomb_friction": "[0.0, 0.0]"})))
    assert omitted.digest() == scalar.digest() == pair.digest()


def test_rest_outside_qlim_names_link_and_limits(tmp_path):
    path = _write(tmp_path, _toml({"qlim": "[-1.0, 1.0]"}, top='name = "bad"\nrest = [0.0, 1.5]\n'))
    message = f"{path}, link 2: field 'rest' = 1.5: expected a rest position within qlim [-1.0, 1.0]"
    with pytest.raises(RobotDescriptionError, match=re.escape(message)):
        load_description(path)


def test_extra_metadata_is_read_only():
    desc = load_description("scara")
    with pytest.raises(TypeError):
        desc.extra["units"] = {}  # type: ignore[index]


def test_torque_limit_must_be_positive(tmp_path):
    path = _write(tmp_path, _toml({"torque_limit": "0.0"}))
    message = f"{path}, link 2: field 'torque_limit' = 0.0: expected a motor torque rating > 0 (N m)"
    with pytest.raises(RobotDescriptionError, match=re.escape(message)):
        load_description(path)


@pytest.mark.parametrize(("key", "value", "expected"), [
    ("velocity_limit", "0.0", "a joint speed limit > 0 (rad/s or m/s)"),
    ("velocity_limit", '"fast"', "a number"),
    ("acceleration_limit", "-2.0", "a joint acceleration limit > 0 (rad/s^2 or m/s^2)"),
])
def test_velocity_and_acceleration_limits_must_be_positive(tmp_path, key, value, expected):
    path = _write(tmp_path, _toml({key: value}))
    shown = "'fast'" if value.startswith('"') else value
    message = f"{path}, link 2: field '{key}' = {shown}: expected {expected}"
    with pytest.raises(RobotDescriptionError, match=re.escape(message)):
        load_description(path)
    good = load_description(_write(tmp_path, _toml({key: "2.5"})))
    assert getattr(good.links[1], key) == 2.5 and getattr(good.links[0], key) is None
    assert good.digest() == load_description(_write(tmp_path, _toml())).digest()  # not physics: same compiled code


def test_inertia_note_acknowledges_a_triangle_inequality_break():
    import warnings

    link = {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "mass": 1.0,
            "inertia": [0.1, 0.02, 0.2, 0.0, 0.0, 0.0]}
    with pytest.warns(InertiaConsistencyWarning, match="breaks the triangle inequality"):
        description_from_dict({"name": "x", "links": [link]})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        description_from_dict({"name": "x", "links": [{**link, "inertia_note": "published data, kept"}]})
    with pytest.raises(RobotDescriptionError, match="field 'inertia_note' = '': expected a non-empty text"):
        description_from_dict({"name": "x", "links": [{**link, "inertia_note": ""}]})


@pytest.mark.parametrize("name", BUILTIN_ROBOTS)
def test_builtin_robots_load_without_warnings(name):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_description(name)
