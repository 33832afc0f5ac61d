"""Plain-text views of a robot description and of a build, shared by ``manip info``/``build`` and the demo report."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from model.codegen import BuildInfo
    from model.description import RobotDescription

__all__ = ["format_build", "format_info"]


def format_info(desc: RobotDescription) -> str:
    """The DH table (a URDF robot: joint origins and axes) with units, then inertial and motor data, as plain text."""
    deg = 180.0 / np.pi
    lines = [f"{desc.name}: {desc.description}", f"source: {desc.source}" if desc.source else "",
             f"gravity [m/s^2]: {list(desc.gravity)}", f"rest q: {desc.q_rest.tolist()}", ""]
    if desc.convention == "urdf":
        lines += ["URDF joints: origin of joint i in link frame i-1 (xyz, rpy = URDF <origin>), unit axis",
                  f"{'j':>2} {'type':<9} {'xyz [m]':>26} {'rpy [deg]':>24} {'axis':>22} {'qlim':>22}"]
    else:
        lines += [{"standard": "Standard DH, A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)",
                   "modified": "Modified DH, A_i = Rx(alpha) Tx(a) Rz(theta) Tz(d)"}[desc.convention]
                  + "; q adds to theta (R) or d (P)",
                  f"{'j':>2} {'type':<9} {'a [m]':>9} {'alpha [deg]':>11} {'d [m]':>9} {'theta [deg]':>11} {'qlim':>22}"]
    for i, lk in enumerate(desc.links, 1):
        if lk.qlim is None:
            lim = "-"
        elif lk.is_revolute:
            lim = f"[{lk.qlim[0] * deg:.1f}, {lk.qlim[1] * deg:.1f}] deg"
        else:
            lim = f"[{lk.qlim[0]:.3f}, {lk.qlim[1]:.3f}] m"
        if desc.convention == "urdf":
            from model.description import pose_matrix, tr2rpy

            T = pose_matrix(lk.origin)
            xyz, rpy = T[:3, 3], tr2rpy(T) * deg  # R = Rz(y) Ry(p) Rx(r); yaw = 0 at gimbal lock
            row = [", ".join(f"{v:.{k}f}" for v in np.round(vec, k) + 0.0) for vec, k in ((xyz, 4), (rpy, 2), (lk.axis, 4))]
            lines.append(f"{i:>2} {lk.joint:<9} {'[' + row[0] + ']':>26} {'[' + row[1] + ']':>24} {'[' + row[2] + ']':>22} {lim:>22}")
            continue
        lines.append(f"{i:>2} {lk.joint:<9} {lk.a:>9.4f} {lk.alpha * deg:>11.2f} {lk.d:>9.4f} {lk.theta * deg:>11.2f} {lim:>22}")
    lines += ["", "Inertial data (centre of mass and inertia in frame i, inertia about the centre of mass)",
              f"{'j':>2} {'m [kg]':>8} {'com [m]':>26} {'[Ixx Iyy Izz Ixy Iyz Ixz] [kg m^2]':>44}"]
    for i, lk in enumerate(desc.links, 1):
        com = "[" + ", ".join(f"{c:.4g}" for c in lk.com) + "]"
        inertia = "[" + ", ".join(f"{c:.4g}" for c in lk.inertia) + "]"
        lines.append(f"{i:>2} {lk.mass:>8.4g} {com:>26} {inertia:>44}")
    lines += ["", "Motor data (motor side; motor angle = G q)",
              f"{'j':>2} {'Jm [kg m^2]':>12} {'G':>10} {'B [N m s/rad]':>14} {'Tc+ [N m]':>10} {'Tc- [N m]':>10} {'G^2 Jm':>10}"]
    for i, lk in enumerate(desc.links, 1):
        lines.append(f"{i:>2} {lk.motor_inertia:>12.4g} {lk.gear_ratio:>10.6g} {lk.viscous_friction:>14.4g} "
                     f"{lk.coulomb_friction[0]:>10.4g} {lk.coulomb_friction[1]:>10.4g} {lk.gear_ratio ** 2 * lk.motor_inertia:>10.4g}")
    return "\n".join(line for line in lines)


def format_build(info: BuildInfo) -> str:
    """One line per stage of a :class:`model.codegen.BuildInfo`."""
    if info.cached:
        return f"loaded from the cache in {info.seconds_total:.3f} s: {info.library}"
    levels = " ".join(sorted({u.optimisation for u in info.units}))
    return (f"cold build in {info.seconds_total:.2f} s (symbolic {info.seconds_symbolic:.2f} s, C generation "
            f"{info.seconds_generate:.2f} s, {info.c_bytes / 1e6:.2f} MB; {info.compiler} {' '.join(info.flags)} "
            f"{levels} {info.seconds_compile:.2f} s): {info.library}")
