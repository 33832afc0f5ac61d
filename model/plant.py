"""The robot as a plant: ``xdot = f(x, u, p)`` and ``y = h(x, u, p)`` as named CasADi Functions.

States ``x = [q; qd]`` (2n), inputs ``u`` the motor torques (n, N m; the joint
torque is ``G u``), parameters ``p`` as in :mod:`model.dynamics.parameters`.
Outputs ``y``, in this order::

    q[1..n]              joint positions, rad (revolute) / m (prismatic)
    qd[1..n]             joint velocities, rad/s / m/s
    qm[1..n]             motor positions G q, rad (a prismatic joint's G is in rad/m)
    tool_position[1..3]  origin of the tool frame E in the world frame (``fkine``), m
    tool_rpy[1..3]       roll, pitch, yaw of the tool frame, rad: R_WE = Rz(yaw) Ry(pitch) Rx(roll)
                         (ZYX angles; pitch in [-pi/2, pi/2], roll and yaw are not unique at pitch = +-pi/2)

Both Functions are pure SX (no external calls) and code-generatable.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .arm import DynamicArm

__all__ = ["Plant", "build_plant", "rpy_zyx_sx"]


@dataclass(frozen=True)
class Plant:
    """Contract between the dynamic model and its users (FMU export, simulation, control design).

    Attributes
    ----------
    n, nx, nu
        Joints, states (2n) and inputs (n).
    ode
        ``Function("ode", [x, u, p], [xdot])``.
    out
        ``Function("out", [x, u, p], [y])``.
    param_names, param_defaults, param_descriptions, param_units
        The parameter vector ``p`` (FMI-style 1-based names).
    state_names, input_names, output_names, output_units
        Names (and units of y) in vector order.
    x0
        (2n,) rest configuration with zero velocity.
    """

    name: str
    n: int
    nx: int
    nu: int
    ode: ca.Function
    out: ca.Function
    param_names: tuple[str, ...]
    param_defaults: np.ndarray
    param_descriptions: tuple[str, ...]
    param_units: tuple[str, ...]
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    output_units: tuple[str, ...]
    x0: np.ndarray

    @property
    def ny(self) -> int:
        """Number of outputs (3n + 6)."""
        return len(self.output_names)


def rpy_zyx_sx(R: ca.SX) -> ca.SX:
    """(3, 1) ``[roll, pitch, yaw]`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)``, rad."""
    roll = ca.atan2(R[2, 1], R[2, 2])
    pitch = ca.atan2(-R[2, 0], ca.sqrt(R[2, 1] ** 2 + R[2, 2] ** 2))
    yaw = ca.atan2(R[1, 0], R[0, 0])
    return ca.vertcat(roll, pitch, yaw)


def build_plant(robot: DynamicArm) -> Plant:
    """The plant of ``robot`` (its motor model included), built from ``robot.dynamics`` and ``robot.kinematics``."""
    n = robot.n
    desc = robot.description
    dyn = robot.dynamics
    layout = dyn.layout
    G = robot.gear_ratio
    x = ca.SX.sym("x", 2 * n)
    u = ca.SX.sym("u", n)
    p = ca.SX.sym("p", layout.size)
    q, qd = x[:n], x[n:]
    qdd = dyn.functions.accel(q, qd, ca.DM(G) * u, p)
    xdot = ca.vertcat(qd, qdd)
    T_WE = robot.kinematics.fkine(q)
    y = ca.vertcat(q, qd, ca.DM(G) * q, T_WE[0:3, 3], rpy_zyx_sx(T_WE[0:3, 0:3]))

    pos_unit = ["rad" if lk.is_revolute else "m" for lk in desc.links]
    vel_unit = ["rad/s" if lk.is_revolute else "m/s" for lk in desc.links]
    idx = range(1, n + 1)
    out_names = (
        [f"q[{i}]" for i in idx] + [f"qd[{i}]" for i in idx] + [f"qm[{i}]" for i in idx]
        + [f"tool_position[{k}]" for k in (1, 2, 3)] + [f"tool_rpy[{k}]" for k in (1, 2, 3)]
    )
    out_units = pos_unit + vel_unit + ["rad"] * n + ["m"] * 3 + ["rad"] * 3
    return Plant(
        name=robot.description.identifier,
        n=n,
        nx=2 * n,
        nu=n,
        ode=ca.Function("ode", [x, u, p], [ca.densify(xdot)], ["x", "u", "p"], ["xdot"]),
        out=ca.Function("out", [x, u, p], [ca.densify(y)], ["x", "u", "p"], ["y"]),
        param_names=layout.names,
        param_defaults=layout.defaults.copy(),
        param_descriptions=layout.descriptions,
        param_units=layout.units,
        state_names=tuple([f"q[{i}]" for i in idx] + [f"qd[{i}]" for i in idx]),
        input_names=tuple(f"u[{i}]" for i in idx),
        output_names=tuple(out_names),
        output_units=tuple(out_units),
        x0=np.concatenate([desc.q_rest, np.zeros(n)]),
    )
