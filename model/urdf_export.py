"""Robots to URDF: any :class:`~model.description.RobotDescription` written as a URDF file.

The description's :class:`~model.chain.Chain` is already URDF's picture (joint placements,
unit axes, bodies in the moved joint frames): each joint becomes a URDF joint with that
placement as ``<origin>`` and that axis (flip applied), each body a link ``<inertial>``.
``base`` becomes a fixed joint from a ``world`` link, the tip and the tool fixed joints to
the leaves ``flange`` and ``tool``. Joint limits become ``<limit>`` (a revolute joint without limits is
``continuous``, a prismatic one gets lower = upper = 0, which reads back as no limit): ``effort`` is the
joint-side torque (or force) limit ``|G| torque_limit``, ``velocity`` the ``velocity_limit``; URDF requires
both, finite, so a limit the description does not state is written as :data:`~model.urdf.NO_LIMIT` (the
largest double), which :mod:`model.urdf` reads back as none. The URDF's ``<dynamics damping friction>``
are the joint-side friction ``G^2 B`` and ``|G| Tc`` (symmetric Coulomb friction only: URDF has one value).

URDF has no place for motor data, gravity or the description's text: :func:`companion_toml` writes
the robot TOML that points at the URDF and restores them (``description`` and ``source`` also go into
an XML comment of the URDF), so that URDF + TOML is the same model.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from .chain import build_chain
from .description import LinkDescription, RobotDescription
from .errors import InputError
from .files import write_atomic
from .urdf import NO_LIMIT

__all__ = ["urdf_text", "companion_toml", "export_urdf"]


def urdf_text(desc: RobotDescription) -> str:
    """The URDF XML of ``desc``: links ``base_link``, ``link1``..``linkN``, ``flange`` (the tip), ``tool``
    if the description has one, ``world`` if it has a base pose; inertials and limits included."""
    from lxml import etree
    from yourdfpy import URDF, Dynamics, Inertial, Joint, Limit, Link, Robot

    chain = build_chain(desc)
    links = [Link(name="base_link")]
    joints = []
    if desc.base is not None:
        links.insert(0, Link(name="world"))
        joints.append(Joint(name="base_joint", type="fixed", parent="world", child="base_link", origin=chain.base))
    parent = "base_link"
    for i, (name, link) in enumerate(zip(desc.joint_names, desc.links)):
        child = f"link{i + 1}"
        com = np.eye(4)
        com[:3, 3] = chain.com[i]
        links.append(Link(name=child, inertial=Inertial(origin=com, mass=float(chain.mass[i]), inertia=chain.inertia[i])))
        effort = NO_LIMIT if link.torque_limit is None else abs(link.gear_ratio) * link.torque_limit
        velocity = NO_LIMIT if link.velocity_limit is None else link.velocity_limit
        if link.qlim is not None:
            kind, limit = link.joint, Limit(effort=effort, velocity=velocity, lower=link.qlim[0], upper=link.qlim[1])
        elif link.is_revolute:
            stated = link.torque_limit is not None or link.velocity_limit is not None
            kind, limit = "continuous", Limit(effort=effort, velocity=velocity) if stated else None
        else:
            kind, limit = "prismatic", Limit(effort=effort, velocity=velocity, lower=0.0, upper=0.0)
        joints.append(Joint(name=name, type=kind, parent=parent, child=child, origin=chain.placements[i],
                            axis=chain.axes[i], limit=limit, dynamics=_dynamics(link, Dynamics)))
        parent = child
    links.append(Link(name="flange"))
    joints.append(Joint(name="flange_joint", type="fixed", parent=parent, child="flange", origin=chain.tip))
    if desc.tool is not None:
        links.append(Link(name="tool"))
        joints.append(Joint(name="tool_joint", type="fixed", parent="flange", child="tool", origin=chain.tool))
    robot = Robot(name=desc.name, links=links, joints=joints)
    urdf = URDF(robot=robot, build_scene_graph=False, load_meshes=False)
    root = urdf.write_xml().getroot()
    for key, text in (("source", desc.source), ("description", desc.description)):
        if text:  # for the reader; the companion TOML carries them back (an XML comment cannot hold "--")
            root.insert(0, etree.Comment(f" {key}: {text.replace('--', '- -')} "))
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8").decode()


def _dynamics(link: LinkDescription, Dynamics: type) -> object | None:
    """The joint-side ``<dynamics damping friction>`` of ``link`` (None when both are 0), from its motor-side
    friction: ``G^2 B`` and ``|G| Tc`` (URDF holds one Coulomb value: ``Tc+``; an asymmetric pair is kept by the TOML)."""
    G = link.gear_ratio
    damping, friction = G * G * link.viscous_friction, abs(G) * link.coulomb_friction[0]
    return Dynamics(damping=damping, friction=friction) if damping or friction else None


def _toml_number(x: float) -> str:
    return repr(float(x))


def companion_toml(desc: RobotDescription, urdf_name: str) -> str:
    """A robot TOML pointing at ``urdf_name`` (relative to the TOML) that restores what URDF cannot hold:
    the name, gravity, rest pose and per-joint motor data."""
    names = desc.joint_names
    lines = [f"# {desc.name} as URDF ({urdf_name}) plus what URDF cannot hold: gravity, rest pose and motor data.",
             "# Written by manip export-urdf. SI units: m, rad, kg, kg m^2, N m s/rad, N m (motor side).",
             f"name = {json.dumps(desc.name)}",
             *([f"description = {json.dumps(desc.description)}"] if desc.description else []),
             *([f"source = {json.dumps(desc.source)}"] if desc.source else []),
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


def export_urdf(desc: RobotDescription, path: str | Path, toml: str | Path | None = None) -> list[Path]:
    """Write ``desc`` as URDF to ``path`` and, if ``toml`` is given, the companion robot TOML; returns the files.

    Raises
    ------
    model.errors.InputError
        The output folder does not exist.
    """
    path = Path(path)
    for target in (path, *(() if toml is None else (Path(toml),))):
        if not target.parent.is_dir():
            raise InputError(f"{target}: the folder {target.parent} does not exist")
    written = [write_atomic(path, urdf_text(desc))]
    if toml is not None:
        toml = Path(toml)
        rel = os.path.relpath(path.resolve(), toml.resolve().parent)
        written.append(write_atomic(toml, companion_toml(desc, Path(rel).as_posix())))
    return written
