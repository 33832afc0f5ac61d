"""Plain-text views shared by the console and the report: the one table formatter, numbers, a robot, a build.

:func:`format_table` is every command's console table: columns size to their
content (a long joint name widens its column instead of breaking the row), text
columns are left-aligned and number columns right-aligned. :func:`format_column`
gives one number format to a whole column (the report's HTML tables use it too),
and :func:`exact` writes a float as its shortest round-trip repr (what the robot
file says, not a rounding of it).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from model.errors import InputError

if TYPE_CHECKING:
    from closed_loop.result import TrackingMetrics
    from control_design.joint_model import TorqueLimits
    from model.codegen import BuildInfo
    from model.description import LinkDescription, RobotDescription

__all__ = ["SATURATION_HEADER", "exact", "format_build", "format_column", "format_info", "format_table", "is_number",
           "saturation_rows", "saturation_warnings", "table_cells"]

#: Significant digits of :func:`format_column`.
DIGITS = 4


def is_number(x: Any) -> bool:
    """True for an int or float (numpy scalars included), False for text, bool and None."""
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def exact(x: float) -> str:
    """The shortest text that reads back as exactly ``x`` (Python's repr; ``-0.0`` written ``0.0``)."""
    return repr(float(x) + 0.0)


def format_column(values: Sequence[Any], digits: int = DIGITS) -> list[str]:
    """The cells of one table column, its numbers in one format.

    Text, None and bool pass through as ``str``; NaN and infinities as ``nan``,
    ``inf``, ``-inf``. The numbers of the column get one format: integers when
    every one is a whole number below 1e5; else scientific (``digits`` significant)
    when any non-zero magnitude lies outside [1e-3, 1e5) or they span more than two
    decades; else fixed point with as many decimals as the smallest non-zero
    magnitude needs for ``digits`` significant digits.
    """
    finite = [float(v) for v in values if is_number(v) and math.isfinite(float(v))]
    mags = [abs(v) for v in finite if v != 0.0]
    if all(v.is_integer() and abs(v) < 1e5 for v in finite):
        fmt = "{:.0f}"
    elif mags and (min(mags) < 1e-3 or max(mags) >= 1e5 or max(mags) / min(mags) > 100.0):
        fmt = f"{{:.{digits - 1}e}}"
    else:
        smallest = min(mags) if mags else 1.0
        fmt = f"{{:.{max(0, digits - 1 - math.floor(math.log10(smallest)))}f}}"
    cells = []
    for v in values:
        if not is_number(v):
            cells.append(str(v))
        elif not math.isfinite(float(v)):
            cells.append(str(float(v)))
        else:
            cells.append(fmt.format(float(v) + 0.0))
    return cells


def table_cells(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> tuple[list[list[str]], list[bool]]:
    """The cells of a table as text (numbers formatted per column by :func:`format_column`) and, per column,
    whether it holds numbers only (numbers, or text that reads as one number, ``inf`` or ``-``).

    The one table layout of the console (:func:`format_table`) and of the report (:class:`workbench.report.Report`).
    """
    ncol = len(header)
    if any(len(row) != ncol for row in rows):
        raise InputError(f"expected {ncol} cells each like the header, got {sorted({len(r) for r in rows})}",
                         parameter="rows")
    columns = [format_column([row[c] for row in rows]) for c in range(ncol)]
    numeric = [bool(rows) and all(is_number(row[c]) or _reads_as_number(row[c]) for row in rows) for c in range(ncol)]
    return [[columns[c][r] for c in range(ncol)] for r in range(len(rows))], numeric


def format_table(header: Sequence[str], rows: Sequence[Sequence[Any]], indent: str = "") -> str:
    """A console table: a header line, then one line per row, each column as wide as its widest cell.

    Numbers are formatted per column by :func:`format_column` (pass text for a
    cell that needs its own format, e.g. :func:`exact`). A column of numbers is
    right-aligned, any other left-aligned.
    """
    cells, numeric = table_cells(header, rows)
    widths = [max([len(str(h))] + [len(row[c]) for row in cells]) for c, h in enumerate(header)]

    def line(texts: Sequence[str]) -> str:
        return indent + "  ".join(t.rjust(w) if num else t.ljust(w) for t, w, num in zip(texts, widths, numeric)).rstrip()

    return "\n".join([line([str(h) for h in header])] + [line(row) for row in cells])


def _reads_as_number(cell: Any) -> bool:
    """A text cell that holds one number (an :func:`exact` value, ``inf``, ``-``)."""
    if not isinstance(cell, str):
        return False
    if cell.strip() == "-":
        return True
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _vector(values: Sequence[float]) -> str:
    return "[" + ", ".join(exact(v) for v in values) + "]"


def _urdf_origin(lk: LinkDescription) -> tuple[np.ndarray, np.ndarray]:
    """The joint origin of a URDF link: xyz (m) and rpy (deg), ``R = Rz(y) Ry(p) Rx(r)``; yaw = 0 at gimbal lock."""
    from model.description import pose_matrix, tr2rpy

    T = pose_matrix(lk.origin)
    return T[:3, 3], tr2rpy(T) * (180.0 / np.pi)


def format_info(desc: RobotDescription) -> str:
    """The joint table, inertial data, motor data and torque limits of ``desc``, as plain text.

    The numbers of the robot file are written exactly (:func:`exact`: the
    shortest text that reads back as the same float); each friction value and
    torque limit names where it comes from (the robot file, the URDF, the
    default, or the design's default rule).
    """
    from model.description import TORQUE_LIMIT_FROM_FILE

    units = ["rad" if lk.is_revolute else "m" for lk in desc.links]
    lines = [f"{desc.name}: {desc.description}", *([f"source: {desc.source}"] if desc.source else []),
             f"gravity [m/s^2]: {_vector(desc.gravity)}", f"rest q [rad or m]: {_vector(desc.q_rest)}", ""]
    lims = ["-" if lk.qlim is None else _vector(lk.qlim) for lk in desc.links]
    if desc.convention == "urdf":
        lines.append("URDF joints: origin of joint i in link frame i-1 (xyz, rpy = URDF <origin>), unit axis")
        rows = []
        for i, lk in enumerate(desc.links):
            xyz, rpy = _urdf_origin(lk)
            rows.append([i + 1, lk.name, lk.joint, _vector(xyz), "[" + ", ".join(f"{v:.6g}" for v in rpy + 0.0) + "]",
                         _vector(lk.axis), lims[i], units[i]])
        lines.append(format_table(["j", "name", "type", "xyz [m]", "rpy [deg]", "axis", "qlim", "unit"], rows))
    else:
        lines.append({"standard": "Standard DH, A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)",
                      "modified": "Modified DH, A_i = Rx(alpha) Tx(a) Rz(theta) Tz(d)"}[desc.convention]
                     + "; q adds to theta (R) or d (P); values exactly as in the file")
        rows = [[i + 1, lk.name, lk.joint + (" (flip)" if lk.flip else ""), exact(lk.a), exact(lk.alpha),
                 f"{math.degrees(lk.alpha):.10g}", exact(lk.d), exact(lk.theta), f"{math.degrees(lk.theta):.10g}",
                 lims[i], units[i]]
                for i, lk in enumerate(desc.links)]
        lines.append(format_table(["j", "name", "type", "a [m]", "alpha [rad]", "alpha [deg]", "d [m]", "theta [rad]",
                                   "theta [deg]", "qlim", "unit"], rows))
    lines += ["", "Inertial data (centre of mass and inertia in frame i, inertia about the centre of mass)",
              format_table(["j", "name", "m [kg]", "com [m]", "[Ixx Iyy Izz Ixy Iyz Ixz] [kg m^2]"],
                           [[i + 1, lk.name, exact(lk.mass), _vector(lk.com), _vector(lk.inertia)]
                            for i, lk in enumerate(desc.links)])]
    lines += ["", "Motor data (motor side; motor angle = G q)",
              format_table(["j", "name", "Jm [kg m^2]", "G", "B [N m s/rad]", "Tc+ [N m]", "Tc- [N m]", "G^2 Jm"],
                           [[i + 1, lk.name, exact(lk.motor_inertia), exact(lk.gear_ratio), exact(lk.viscous_friction),
                             exact(lk.coulomb_friction[0]), exact(lk.coulomb_friction[1]),
                             f"{lk.gear_ratio ** 2 * lk.motor_inertia:.6g}"] for i, lk in enumerate(desc.links)])]
    rows = []
    for i, lk in enumerate(desc.links):
        G = lk.gear_ratio
        viscous_from, coulomb_from = desc.friction_source(i)
        rows.append([i + 1, lk.name, exact(G * G * lk.viscous_friction), viscous_from,
                     exact(abs(G) * lk.coulomb_friction[0]), exact(abs(G) * lk.coulomb_friction[1]), coulomb_from])
    lines += ["", "Joint friction (joint side, G^2 B qd + |G| Tc sign(qd)) and where each value comes from",
              format_table(["j", "name", "G^2 B [N m s/rad]", "viscous from", "|G| Tc+ [N m]", "|G| Tc- [N m]",
                            "Coulomb from"], rows)]
    if any(lk.velocity_limit is not None for lk in desc.links):
        lines += ["", "Joint velocity limits (joint side; velocity_limit)",
                  format_table(["j", "name", "qd_max", "unit"],
                               [[i + 1, lk.name, "-" if lk.velocity_limit is None else exact(lk.velocity_limit),
                                 f"{units[i]}/s"] for i, lk in enumerate(desc.links)])]
    if any(lk.is_elastic or lk.has_current_loop or lk.friction_peak != 1.0 for lk in desc.links):
        def opt(v: float | None) -> str:
            return "-" if v is None else exact(v)

        lines += ["", "Drive trains (motor side; docs/robot-file.md, Drive trains)",
                  format_table(["j", "name", "gear", "c [N m/rad]", "d [N m s/rad]", "friction on", "peak",
                                "k [N m/A]", "current loop w [rad/s]", "D", "Ra [Ohm]"],
                               [[i + 1, lk.name, "elastic" if lk.is_elastic else "rigid", opt(lk.gear_stiffness),
                                 exact(lk.gear_damping) if lk.is_elastic else "-",
                                 (lk.friction_side if lk.is_elastic else "rotor = joint"), exact(lk.friction_peak),
                                 opt(lk.torque_constant), opt(lk.current_bandwidth),
                                 exact(lk.current_damping) if lk.has_current_loop else "-", opt(lk.armature_resistance)]
                                for i, lk in enumerate(desc.links)])]
    file_name = Path(desc.path).name if desc.path else "the robot file"
    rows = []
    for i, lk in enumerate(desc.links):
        if desc.torque_limit_source(i) == TORQUE_LIMIT_FROM_FILE:
            rows.append([i + 1, lk.name, exact(lk.torque_limit), f"{TORQUE_LIMIT_FROM_FILE} ({file_name}: torque_limit)"])
        else:
            rows.append([i + 1, lk.name, "-", "default rule (no torque_limit in the file; manip design computes it)"])
    lines += ["", "Motor torque limits (motor side)", format_table(["j", "name", "tau_max [N m]", "from"], rows)]
    return "\n".join(lines)


def format_build(info: BuildInfo, full_path: bool = True) -> str:
    """One line per stage of a :class:`model.codegen.BuildInfo` (``full_path=False``: the library's file name only)."""
    library = info.library if full_path else Path(info.library).name
    if info.cached:
        return f"loaded from the cache in {info.seconds_total:.3f} s: {library}"
    levels = " ".join(sorted({u.optimisation for u in info.units}))
    return (f"cold build in {info.seconds_total:.2f} s (symbolic {info.seconds_symbolic:.2f} s, C generation "
            f"{info.seconds_generate:.2f} s, {info.c_bytes / 1e6:.2f} MB; {info.compiler} {' '.join(info.flags)} "
            f"{levels} {info.seconds_compile:.2f} s): {library}")


#: Columns of :func:`saturation_rows`.
SATURATION_HEADER = ("motor", "joint", "limit [N m]", "limit from", "peak |tau_m| [N m]", "at limit [%]",
                     "longest [s]", "from t [s]")


def saturation_rows(metrics: TrackingMetrics, limits: TorqueLimits) -> list[list[Any]]:
    """One row per motor (:data:`SATURATION_HEADER`): its limit and where it comes from, and how long it sat there."""
    rows = []
    for j, name in enumerate(metrics.joints):
        start = metrics.saturated_longest_start[j]
        rows.append([j + 1, name, float(limits.tau_m_max[j]), limits.provenance(j),
                     float(metrics.peak_motor_torque[j]), 100.0 * float(metrics.saturated_fraction[j]),
                     float(metrics.saturated_longest[j]), "-" if start != start else float(start)])
    return rows


def saturation_warnings(metrics: TrackingMetrics, limits: TorqueLimits) -> list[str]:
    """One sentence per motor that reached its torque limit, or went past it unclipped (none: an empty list)."""
    lines = []
    over = np.flatnonzero((metrics.saturated_fraction == 0) & (metrics.peak_motor_torque > limits.tau_m_max))
    for j in over:  # a run without clipping (manip track --no-saturation) that asks more than the motor gives
        lines.append(f"motor {j + 1} ({metrics.joints[j]}) peaks at {metrics.peak_motor_torque[j]:.4g} N m, above its "
                     f"torque limit {limits.tau_m_max[j]:.4g} N m (not clipped); limit from the "
                     f"{limits.provenance(j, detail=True)}")
    for j in metrics.saturated:
        lines.append(f"motor {j + 1} ({metrics.joints[j]}) at its torque limit {limits.tau_m_max[j]:.4g} N m for "
                     f"{100 * metrics.saturated_fraction[j]:.1f} % of the run, longest {metrics.saturated_longest[j]:.3g} s "
                     f"from t = {metrics.saturated_longest_start[j]:.3g} s; limit from the {limits.provenance(j, detail=True)}")
    return lines
