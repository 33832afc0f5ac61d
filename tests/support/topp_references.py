"""Independent references for the retime (:mod:`model.retime`): toppra on the same path, grid and limits, and a
direct CasADi/IPOPT transcription of the same discretised problem.

Neither shares code with the solver under test: toppra (Pham & Pham's TOPP-RA, PyPI ``toppra``) computes its own
constraint coefficients by calling the inverse dynamics it is given and solves its own LPs; the IPOPT problem is
written here from the definition of the discretisation (``x_{i+1} = x_i + 2 delta_i u_i``, every grid point's
torque rows at both one-sided accelerations, the viscous term ``G^2 B q' sqrt(x)`` kept exact).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from model.retime import PathConstraints, Retiming
from model.robot import Robot
from model.trajectory import JointPath

__all__ = ["builtin", "design_limits", "reference_waypoints", "frictionless", "toppra_durations", "ipopt_duration"]


def builtin(name: str) -> Robot:
    """A built-in robot, its load-time notes (the seed SCARA's inertia, URDF dynamics) silenced."""
    import warnings

    from model.robot import load_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_robot(name)


def design_limits(robot: Robot, **kw: Any) -> Any:
    """:func:`model.retime.retime_limits` with the design's motor torque limits (what ``manip retime`` uses)."""
    from control_design.joint_model import sample_configurations, torque_limits
    from control_design.reference import reference_task
    from model.retime import retime_limits

    tau = torque_limits(robot, reference_task(robot), sample_configurations(robot)).tau_m_max
    return retime_limits(robot, tau, **kw)


def reference_waypoints(robot: Robot) -> np.ndarray:
    """The waypoints of the robot file's first task, else of the generic tour."""
    from model.tasks import TOUR, find_task

    tasks = robot.description.tasks
    return find_task(robot.description, tasks[0]["name"] if tasks else TOUR).waypoints


def frictionless(robot: Robot, coulomb: float | None = None) -> Robot:
    """``robot`` without viscous friction, and without Coulomb friction (``coulomb=None``) or with the symmetric
    ``Tc = +-coulomb`` N m on every motor (toppra's ``fs_coef`` is symmetric)."""
    n = robot.n
    c = np.zeros(n) if coulomb is None else np.full(n, float(coulomb))
    return robot.with_parameters(robot.parameters.with_friction(viscous=np.zeros(n), coulomb_pos=c, coulomb_neg=-c))


def _adapter(segment: JointPath) -> Any:
    """The segment as a toppra geometric path (toppra evaluates q, q', q'' through it: the same path)."""
    import toppra

    class SamePath(toppra.interpolator.AbstractGeometricPath):
        def __call__(self, path_positions: Any, order: int = 0) -> np.ndarray:
            s = np.atleast_1d(np.asarray(path_positions, dtype=float))
            out = segment.batch(s)[order]
            return out if np.ndim(path_positions) else out[0]

        @property
        def dof(self) -> int:
            return segment.n

        @property
        def path_interval(self) -> np.ndarray:
            return np.array([segment.t_start, segment.t_end])

        @property
        def waypoints(self) -> Any:
            return None

    return SamePath()


def toppra_durations(robot: Robot, motion: Retiming, coulomb: float | None = None) -> tuple[float, list[np.ndarray]]:
    """toppra on every segment of ``motion``'s path, on its grid, with its limits; the total duration and each
    segment's sd at the grid points.

    ``robot`` is the arm without viscous friction (:func:`frictionless`): toppra's torque constraint has no
    term in sd. Coulomb friction ``+-coulomb`` (motor side) is given to toppra as ``fs_coef = |G| coulomb``
    (joint side) and taken out of the inverse dynamics it calls. The discretisation is toppra's
    ``Interpolation`` (each stage's limits at both its ends), the solver its ``seidel`` LP solver.
    """
    import toppra
    import toppra.algorithm as ta
    import toppra.constraint as tc

    bare = frictionless(robot, None)
    lim = motion.limits
    fs = np.abs(robot.gear_ratio) * (0.0 if coulomb is None else float(coulomb))
    interp = tc.DiscretizationType.Interpolation
    total, profiles = 0.0, []
    for segment, sol in zip(motion.path.segments, motion.segments):
        cons: list[Any] = [tc.JointTorqueConstraint(lambda q, qd, qdd: bare.rne(q, qd, qdd),
                                                    np.column_stack([-lim.tau_max, lim.tau_max]), fs,
                                                    discretization_scheme=interp)]
        if np.isfinite(lim.velocity).any():
            v = np.where(np.isfinite(lim.velocity), lim.velocity, 1e12)
            cons.append(tc.JointVelocityConstraint(np.column_stack([-v, v])))
        if np.isfinite(lim.acceleration).any():
            a = np.where(np.isfinite(lim.acceleration), lim.acceleration, 1e12)
            cons.append(tc.JointAccelerationConstraint(np.column_stack([-a, a]), discretization_scheme=interp))
        inst = ta.TOPPRA(cons, _adapter(segment), gridpoints=sol.s, solver_wrapper="seidel",
                         parametrizer="ParametrizeConstAccel")
        _sdd, sd, _v = inst.compute_parameterization(0.0, 0.0)
        if sd is None:
            raise AssertionError(f"toppra found the segment infeasible ({toppra.__name__})")
        sd = np.asarray(sd, dtype=float)
        profiles.append(sd)
        total += float(np.sum(2.0 * np.diff(sol.s) / (sd[:-1] + sd[1:])))
    return total, profiles


def ipopt_duration(pc: PathConstraints, start: np.ndarray) -> tuple[float, np.ndarray]:
    """The same discretised problem as the retime, transcribed directly and solved by IPOPT (CasADi).

    Unknowns: the path speeds ``y_i = sd_i`` (``y_0 = y_N = 0``); ``u_i = (y_{i+1}^2 - y_i^2) / (2 delta_i)``.
    Every row ``lo <= alpha u + beta y^2 + gamma y + delta <= hi`` holds at point i with ``(y_i, u_i)`` and at
    point i+1 with ``(y_{i+1}, u_i)``, ``y_i <= y_max_i``; the objective is the duration
    ``sum 2 delta_i / (y_i + y_{i+1})``. ``start`` (N+1,) is the initial guess of y. Returns the duration and y.
    """
    import casadi as ca

    N = pc.s.size - 1
    d = np.diff(pc.s)
    y = ca.MX.sym("y", N + 1)
    u = (y[1:] ** 2 - y[:-1] ** 2) / (2.0 * d)
    g, lbg, ubg = [], [], []
    for at, yy in ((slice(0, N), y[:-1]), (slice(1, N + 1), y[1:])):
        for r in range(pc.alpha.shape[1]):
            val = pc.alpha[at, r] * u + pc.beta[at, r] * yy ** 2 + pc.gamma[at, r] * yy + pc.delta[at, r]
            g.append(val)
            lbg.append(pc.lo[at, r])
            ubg.append(pc.hi[at, r])
    T = ca.sum1(2.0 * d / (y[:-1] + y[1:] + 1e-12))
    lbx = np.zeros(N + 1)
    ubx = np.minimum(pc.y_max, 1e6)
    ubx[[0, -1]] = 0.0
    solver = ca.nlpsol("topp", "ipopt", {"x": y, "f": T, "g": ca.vertcat(*g)},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": 1e-12,
                        "ipopt.constr_viol_tol": 1e-12, "ipopt.max_iter": 3000})
    res = solver(x0=np.clip(start, lbx, ubx), lbx=lbx, ubx=ubx, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
    ys = np.array(res["x"]).ravel()
    return float(np.sum(2.0 * d / (ys[:-1] + ys[1:]))), ys
