"""Robots to URDF: any :class:`~model.description.RobotDescription` written as a URDF file.

Each joint becomes a URDF joint whose frame is where the joint moves: for standard DH the
frame of the previous DH frame (the motion ``Rz(q)`` or ``Tz(q)`` comes first in ``A_i``),
so the constant rest of ``A_i`` moves to the next joint's origin and the inertial data
of link i are carried over to that frame; for modified DH the motion comes last and the
URDF link frame is DH frame i itself. ``flip`` reverses the axis, ``base`` becomes a fixed
joint from a ``world`` link, the tip and the tool fixed joints to the leaves ``flange``
and ``tool``. Joint limits become ``<limit>`` (a revolute joint without limits is
``continuous``, a prismatic one gets lower = upper = 0, which reads back as no limit).

URDF has no place for motor data or gravity: :func:`companion_toml` writes the robot
TOML that points at the URDF and restores them, so that URDF + TOML is the same model.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

from .description import RobotDescription, pose_matrix

__all__ = ["urdf_joints", "urdf_text", "companion_toml", "write_atomic", "export_urdf"]


def _dh_constant(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """``Rz(theta) Tz(d) Tx(a) Rx(alpha)`` as a 4x4 array."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]])


def _mdh_constant(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` (Craig's modified DH, link i holding alpha_{i-1} and a_{i-1})."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st, 0.0, a], [ca * st, ca * ct, -sa, -sa * d], [sa * st, sa * ct, ca, ca * d], [0.0, 0.0, 0.0, 1.0]])


def urdf_joints(desc: RobotDescription) -> tuple[list[dict], np.ndarray]:
    """Per joint the URDF data ``origin`` (4, 4, in the previous URDF link frame), ``axis``, ``mass``,
    ``com`` (m) and ``inertia`` (3, 3 about the com, kg m^2) in the URDF link frame; and the tip's pose
    (4, 4) in the last URDF link frame. The base and the tool are not included."""
    out = []
    if desc.convention == "standard":
        constants = [_dh_constant(lk.a, lk.alpha, lk.d, lk.theta) for lk in desc.links]
        origins = [np.eye(4), *constants[:-1]]
        to_link = constants  # DH frame i in URDF link frame i
        tip = constants[-1]
    elif desc.convention == "modified":
        origins = [_mdh_constant(lk.a, lk.alpha, lk.d, lk.theta) for lk in desc.links]
        to_link = [np.eye(4)] * desc.n
        tip = np.eye(4)
    elif desc.convention == "urdf":
        origins = [pose_matrix(lk.origin) for lk in desc.links]
        to_link = [np.eye(4)] * desc.n
        tip = pose_matrix(desc.tip)
    else:
        raise ValueError(f"{desc.path or desc.name}: convention {desc.convention!r}: expected standard, modified or urdf")
    for link, origin, M in zip(desc.links, origins, to_link):
        axis = np.array(link.axis if desc.convention == "urdf" else (0.0, 0.0, 1.0), dtype=float)
        R = M[:3, :3]
        out.append({
            "origin": origin, "axis": -axis if link.flip else axis, "mass": link.mass,
            "com": R @ np.array(link.com, dtype=float) + M[:3, 3], "inertia": R @ link.inertia_matrix @ R.T,
        })
    return out, tip


def _joint_names(desc: RobotDescription) -> list[str]:
    names = [lk.name for lk in desc.links]
    reserved = {"base_joint", "flange_joint", "tool_joint"}
    if all(names) and len(set(names)) == len(names) and not reserved & set(names):
        return names
    return [f"joint{i}" for i in range(1, desc.n + 1)]


def urdf_text(desc: RobotDescription) -> str:
    """The URDF XML of ``desc``: links ``base_link``, ``link1``..``linkN``, ``flange`` (the tip), ``tool``
    if the description has one, ``world`` if it has a base pose; inertials and limits included."""
    from yourdfpy import URDF, Inertial, Joint, Limit, Link, Robot

    specs, tip = urdf_joints(desc)
    links = [Link(name="base_link")]
    joints = []
    if desc.base is not None:
        links.insert(0, Link(name="world"))
        joints.append(Joint(name="base_joint", type="fixed", parent="world", child="base_link", origin=pose_matrix(desc.base)))
    parent = "base_link"
    for i, (name, link, spec) in enumerate(zip(_joint_names(desc), desc.links, specs), 1):
        child = f"link{i}"
        origin = np.eye(4)
        origin[:3, 3] = spec["com"]
        links.append(Link(name=child, inertial=Inertial(origin=origin, mass=float(spec["mass"]), inertia=spec["inertia"])))
        effort = 0.0 if link.torque_limit is None else abs(link.gear_ratio) * link.torque_limit
        if link.qlim is not None:
            kind, limit = link.joint, Limit(effort=effort, velocity=0.0, lower=link.qlim[0], upper=link.qlim[1])
        elif link.is_revolute:
            kind, limit = "continuous", None
        else:
            kind, limit = "prismatic", Limit(effort=effort, velocity=0.0, lower=0.0, upper=0.0)
        joints.append(Joint(name=name, type=kind, parent=parent, child=child, origin=spec["origin"], axis=spec["axis"], limit=limit))
        parent = child
    links.append(Link(name="flange"))
    joints.append(Joint(name="flange_joint", type="fixed", parent=parent, child="flange", origin=tip))
    if desc.tool is not None:
        links.append(Link(name="tool"))
        joints.append(Joint(name="tool_joint", type="fixed", parent="flange", child="tool", origin=pose_matrix(desc.tool)))
    robot = Robot(name=desc.name, links=links, joints=joints)
    urdf = URDF(robot=robot, build_scene_graph=False, load_meshes=False)
    return urdf.write_xml_string().decode()


def _toml_number(x: float) -> str:
    return repr(float(x))


def companion_toml(desc: RobotDescription, urdf_name: str) -> str:
    """A robot TOML pointing at ``urdf_name`` (relative to the TOML) that restores what URDF cannot hold:
    the name, gravity, rest pose and per-joint motor data."""
    names = _joint_names(desc)
    lines = [f"# {desc.name} as URDF ({urdf_name}) plus what URDF cannot hold: gravity, rest pose and motor data.",
             "# Written by manip export-urdf. SI units: m, rad, kg, kg m^2, N m s/rad, N m (motor side).",
             f"name = {json.dumps(desc.name)}",
             f"urdf = {json.dumps(urdf_name)}",
             f"tip_link = {json.dumps('tool' if desc.tool is not None else 'flange')}",
             f"gravity = [{', '.join(_toml_number(g) for g in desc.gravity)}]"]
    if desc.rest is not None:
        lines.append(f"rest = [{', '.join(_toml_number(v) for v in desc.rest)}]")
    for name, link in zip(names, desc.links):
        lines += ["", f"[joints.{name}]", f"motor_inertia = {_toml_number(link.motor_inertia)}",
                  f"gear_ratio = {_toml_number(link.gear_ratio)}", f"viscous_friction = {_toml_number(link.viscous_friction)}",
                  f"coulomb_friction = [{_toml_number(link.coulomb_friction[0])}, {_toml_number(link.coulomb_friction[1])}]",
                  f"rotor_mass = {_toml_number(link.rotor_mass)}"]
        if link.torque_limit is not None:
            lines.append(f"torque_limit = {_toml_number(link.torque_limit)}")
    return "\n".join(lines) + "\n"


def write_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def export_urdf(desc: RobotDescription, path: str | Path, toml: str | Path | None = None) -> list[Path]:
    """Write ``desc`` as URDF to ``path`` and, if ``toml`` is given, the companion robot TOML; returns the files.

    Raises
    ------
    FileNotFoundError
        The output folder does not exist.
    """
    path = Path(path)
    for target in (path, *(() if toml is None else (Path(toml),))):
        if not target.parent.is_dir():
            raise FileNotFoundError(f"{target}: the folder {target.parent} does not exist")
    written = [write_atomic(path, urdf_text(desc))]
    if toml is not None:
        toml = Path(toml)
        rel = os.path.relpath(path.resolve(), toml.resolve().parent)
        written.append(write_atomic(toml, companion_toml(desc, Path(rel).as_posix())))
    return written
