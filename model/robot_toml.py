"""Descriptions to robot TOML: a standard or modified DH :class:`~model.description.RobotDescription` written
as the robot file that reads back as it (every link field, base, tool, rest, gravity and tasks).

Numbers are written with ``repr`` (the shortest text that reads back as the same float), so links,
gravity and rest round-trip exactly; an inertia that breaks the triangle inequality (published
data kept as given) gets an ``inertia_note`` saying so; ``base`` and ``tool`` are written as ``{xyz, rpy}`` from
:func:`~model.description.tr2rpy`, and read back to rounding (1e-15). A URDF robot has no DH table:
:mod:`model.urdf_export` writes it as URDF plus a companion TOML.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .description import LinkDescription, RobotDescription, pose_matrix, tr2rpy
from .errors import InputError
from .files import write_atomic

__all__ = ["robot_toml_text", "write_robot_toml"]


def _num(x: float) -> str:
    return repr(float(x) + 0.0)


def _list(values) -> str:
    return "[" + ", ".join(_num(v) for v in values) + "]"


def _pose(key: str, pose: tuple[float, ...] | None) -> list[str]:
    if pose is None:
        return []
    T = pose_matrix(pose)
    return [f"{key} = {{ xyz = {_list(T[:3, 3])}, rpy = {_list(tr2rpy(T))} }}"]


def _link(link: LinkDescription) -> list[str]:
    ixx, iyy, izz, ixy, iyz, ixz = link.inertia
    lines = ["", "[[links]]"]
    if link.name:
        lines.append(f"name = {json.dumps(link.name)}")
    lines += [f"joint = {json.dumps(link.joint)}", f"a = {_num(link.a)}", f"alpha = {_num(link.alpha)}",
              f"d = {_num(link.d)}", f"theta = {_num(link.theta)}", f"mass = {_num(link.mass)}",
              f"com = {_list(link.com)}", f"inertia = {_list((ixx, iyy, izz, ixy, iyz, ixz))}",
              f"motor_inertia = {_num(link.motor_inertia)}", f"gear_ratio = {_num(link.gear_ratio)}",
              f"viscous_friction = {_num(link.viscous_friction)}",
              f"coulomb_friction = {_list(link.coulomb_friction)}"]
    lam = np.linalg.eigvalsh(link.inertia_matrix)
    if lam[0] + lam[1] < lam[2] - 1e-12 * max(1.0, float(np.abs(lam).max())):  # as the reader's check
        lines.append('inertia_note = "breaks the triangle inequality; kept as given in the file it was written from"')
    if link.rotor_mass:
        lines.append(f"rotor_mass = {_num(link.rotor_mass)}")
    if link.qlim is not None:
        lines.append(f"qlim = {_list(link.qlim)}")
    if link.torque_limit is not None:
        lines.append(f"torque_limit = {_num(link.torque_limit)}")
    if link.flip:
        lines.append("flip = true")
    return lines


def robot_toml_text(desc: RobotDescription, header: str = "") -> str:
    """The robot TOML of a standard or modified DH description (``header``: comment lines put first).

    Raises
    ------
    InputError
        A URDF description (write it with :func:`model.urdf_export.export_urdf`).
    """
    if desc.convention not in ("standard", "modified"):
        raise InputError(f"{desc.name}: convention {desc.convention!r}: a robot TOML holds standard or modified DH "
                         "links only (write a URDF robot with export-urdf)")
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    lines += [f"name = {json.dumps(desc.name)}"]
    if desc.description:
        lines.append(f"description = {json.dumps(desc.description)}")
    if desc.source:
        lines.append(f"source = {json.dumps(desc.source)}")
    if desc.convention != "standard":
        lines.append(f"convention = {json.dumps(desc.convention)}")
    lines.append(f"gravity = {_list(desc.gravity)}")
    if desc.rest is not None:
        lines.append(f"rest = {_list(desc.rest)}")
    lines += _pose("base", desc.base) + _pose("tool", desc.tool)
    for link in desc.links:
        lines += _link(link)
    for task in desc.tasks:
        lines += ["", "[[tasks]]", f"name = {json.dumps(task['name'])}",
                  "waypoints = [" + ", ".join(_list(w) for w in task["waypoints"]) + "]",
                  f"segment_time = {_num(task['segment_time'])}",
                  "labels = [" + ", ".join(json.dumps(x) for x in task["labels"]) + "]"]
        if task.get("description"):
            lines.append(f"description = {json.dumps(task['description'])}")
    return "\n".join(lines) + "\n"


def write_robot_toml(desc: RobotDescription, path: str | Path, header: str = "") -> Path:
    """Write :func:`robot_toml_text` of ``desc`` to ``path`` atomically; returns the path."""
    return write_atomic(path, robot_toml_text(desc, header))

