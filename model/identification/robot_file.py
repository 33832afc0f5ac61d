"""Identified parameters to a robot file: the description with the consistent fit's values, written so
that every command takes it.

:func:`identified_description` puts the standard parameters ``pi`` of a physically consistent fit into
a copy of the robot's description, per link (link frame i, as the file states them):

* ``mass = m``, ``com = mc / m`` (0 for a link below :data:`MASSLESS` of the arm's mass) and ``inertia`` about the centre of mass
  ``I_o - m (|c|^2 1 - c c^T)``;
* ``motor_inertia = Ia / G^2``, ``viscous_friction = fv / G^2`` and the symmetric
  ``coulomb_friction = [fc / |G|, -fc / |G|]`` on the motor side, with the file's gear ratio ``G``;
* the torque offset is not a parameter of the model (a sensor bias, or the Coulomb asymmetry, which
  motion data cannot tell apart; see :mod:`model.identification.parameters`): it is reported in
  ``identification.json``, not written.

Geometry, limits, motor ratings, gear ratios, rest pose and tasks are the robot's. :func:`write_identified`
writes a DH robot as one TOML (:mod:`model.robot_toml`) and a URDF robot as a URDF with the identified
inertials plus the TOML that points at it and holds the motor data (:mod:`model.urdf_export`).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..description import RobotDescription
from ..files import write_atomic
from ..robot_toml import write_robot_toml
from ..urdf_export import export_urdf
from .parameters import PER_JOINT, link_inertia_about_com

__all__ = ["IDENTIFIED_TOML", "IDENTIFIED_URDF", "identified_description", "write_identified"]

#: File names in the output folder of ``manip identify``.
IDENTIFIED_TOML = "identified.toml"
IDENTIFIED_URDF = "identified.urdf"
#: A link lighter than this fraction of the arm's mass is written massless (a fit drives a mass the torques do
#: not see towards 0, and its centre of mass, a ratio of two vanishing numbers, means nothing).
MASSLESS = 1e-9


def _six(I: np.ndarray) -> tuple[float, ...]:
    """``[Ixx, Iyy, Izz, Ixy, Iyz, Ixz]`` of a symmetric matrix, its eigenvalues at least 0 (rounding of a
    positive semi-definite fit)."""
    lam, V = np.linalg.eigh(0.5 * (I + I.T))
    I = (V * np.maximum(lam, 0.0)) @ V.T
    return tuple(float(v) + 0.0 for v in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2]))


def identified_description(desc: RobotDescription, pi: npt.ArrayLike, *, source: str = "") -> RobotDescription:
    """``desc`` with the link and motor parameters of the standard parameters ``pi`` (see the module docstring).

    ``source`` replaces the description's source (e.g. the data file it was identified from).
    """
    p = np.asarray(pi, dtype=float)
    tiny = MASSLESS * max(float(np.sum(np.abs(p[0::PER_JOINT]))), 1e-300)
    links = []
    for i, lk in enumerate(desc.links):
        o = PER_JOINT * i
        m, c, I_c = link_inertia_about_com(p[o:o + 10], tiny)
        G = lk.gear_ratio
        ia, fv, fc = (max(float(v), 0.0) for v in p[o + 10:o + 13])
        links.append(dataclasses.replace(
            lk, mass=max(m, 0.0) + 0.0, com=tuple(float(v) + 0.0 for v in c), inertia=_six(I_c),
            motor_inertia=ia / G ** 2, viscous_friction=fv / G ** 2,
            coulomb_friction=(fc / abs(G) + 0.0, -fc / abs(G) + 0.0)))
    return dataclasses.replace(desc, links=tuple(links), name=desc.name,
                               description=f"{desc.description or desc.name}, identified",
                               source=source or desc.source, path="")


def write_identified(desc: RobotDescription, out: str | Path, header: str = "") -> list[Path]:
    """Write the identified description into the folder ``out``: ``identified.toml`` (DH robots), or
    ``identified.urdf`` and the ``identified.toml`` that points at it (URDF robots). Returns the files."""
    out = Path(out)
    if desc.convention == "urdf":
        files = export_urdf(desc, out / IDENTIFIED_URDF, out / IDENTIFIED_TOML)
        if header:  # say where the companion TOML comes from above what export_urdf writes
            lines = "".join(f"# {line}\n" for line in header.splitlines())
            write_atomic(files[-1], lines + files[-1].read_text())
        return files
    return [write_robot_toml(desc, out / IDENTIFIED_TOML, header)]
