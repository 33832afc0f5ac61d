"""Tiny URDF files written by the tests: each isolates one construct (a fixed joint mid-chain, a tilted
axis with a rotated inertial origin, a continuous joint, a finger hanging off the chain, refused joints)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["link", "joint", "urdf_text", "write_urdf"]


def link(name: str, mass: float = 0.0, xyz: str = "0 0 0", rpy: str = "0 0 0",
         inertia: tuple[float, float, float, float, float, float] = (0.0,) * 6) -> str:
    """A ``<link>``; ``inertia`` is (ixx, iyy, izz, ixy, iyz, ixz) about the com, in the inertial-origin axes."""
    if mass == 0.0 and not any(inertia):
        return f'<link name="{name}"/>'
    ixx, iyy, izz, ixy, iyz, ixz = inertia
    return (f'<link name="{name}"><inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass!r}"/>'
            f'<inertia ixx="{ixx!r}" iyy="{iyy!r}" izz="{izz!r}" ixy="{ixy!r}" iyz="{iyz!r}" ixz="{ixz!r}"/>'
            f'</inertial></link>')


def joint(name: str, kind: str, parent: str, child: str, xyz: str = "0 0 0", rpy: str = "0 0 0",
          axis: str | None = "0 0 1", limit: tuple[float, float] | None = (-3.0, 3.0), extra: str = "") -> str:
    """A ``<joint>``; ``limit`` (lower, upper) becomes ``<limit>`` with effort and velocity."""
    body = f'<parent link="{parent}"/><child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/>'
    if axis is not None and kind != "fixed":
        body += f'<axis xyz="{axis}"/>'
    if limit is not None and kind in ("revolute", "prismatic"):
        body += f'<limit lower="{limit[0]!r}" upper="{limit[1]!r}" effort="10" velocity="1"/>'
    return f'<joint name="{name}" type="{kind}">{body}{extra}</joint>'


def urdf_text(*elements: str, name: str = "tiny") -> str:
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n' + "\n".join(elements) + "\n</robot>\n"


def write_urdf(folder: Path, filename: str, *elements: str, name: str = "tiny") -> Path:
    path = Path(folder) / filename
    path.write_text(urdf_text(*elements, name=name))
    return path
