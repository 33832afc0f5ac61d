"""The robot as a plant: the one definition every engine integrates, as named CasADi Functions.

States ``x = [q; qd]`` (2n), inputs ``u`` the motor torques (n, N m; the joint
torque is ``G u``), parameters ``p`` as in :mod:`model.dynamics.parameters`
(payload, friction, gravity; a kernel plant appends ``link_mass_scale``), and
``nz = n`` friction modes ``m`` (per joint +1 sliding forward, -1 sliding
backward, 0 stuck: the stick-slip law of :mod:`model.dynamics.stick_slip`).
The Functions, all pure SX and code-generatable::

    ode(x, u, p, m)      -> xdot        rigid-body dynamics, motors (reflected or full), payload,
                                        gravity, viscous friction, Coulomb friction of the modes
    ode_sliding(...)     -> xdot        the same where no joint is stuck, bit for bit, without the masking
    out(x, u, p)         -> y           the outputs below
    events(x, u, p, m)   -> z           event indicators, > 0 while the modes hold
    events_sliding(...)  -> z           the same where no joint is stuck, bit for bit, without holding torques
    update(x, u, p, m)   -> (m, x)      one pass of the mode update
    start(x, u, p, m)    -> m           the modes to begin from (m not read)
    active(x, u, p, m)   -> [a, quiet]  a: 1 if a mode can change, else 0 (no Coulomb friction, none stuck);
                                        quiet: 1 if an update pass would change nothing now
    pivots(x, u, p, m)   -> D           LDL^T pivots of the solve (not positive: B(q) singular there)
    friction(x, u, p, m) -> f           joint-side Coulomb (sliding) or holding (stuck) torque, N m or N

The fixed-step rule that integrates them (RK4 sub-steps, events located by
bisection, the settle loop) is ``model/dynamics/c/plant_step.c``, called by the
Python loop (:mod:`model.compiled_plant`), the compiled closed loop and the
FMU's Co-Simulation step; the FMU's Model Exchange gives ``ode``, ``events``
and ``update`` to the importer's solver. Outputs ``y``, in this order::

    q[1..n]              joint positions, rad (revolute) / m (prismatic)
    qd[1..n]             joint velocities, rad/s / m/s
    qm[1..n]             motor positions G q, rad (a prismatic joint's G is in rad/m)
    tool_position[1..3]  origin of the tool frame E in the world frame W (``fkine``: base and tool
                         included; W is the robot's frame 0 only when it states no ``base``), m
    tool_rpy[1..3]       roll, pitch, yaw of the tool frame in W, rad: R_WE = Rz(yaw) Ry(pitch) Rx(roll)
                         (ZYX angles; pitch in [-pi/2, pi/2], roll and yaw are not unique at pitch = +-pi/2)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .arm import DynamicArm
from .description import DRIVE_TRAIN_DEFAULTS
from .dynamics.motors import coulomb_limits_sx
from .dynamics.parameters import split_parameters
from .dynamics.stick_slip import sliding_accel_sx, sliding_indicators_sx, stick_slip_sx
from .dynamics.symbolic import plant_terms_sx
from .drive_train import (check_drive_trains, drive_layout, drive_terms_sx, equilibrium_state, has_drive_trains,
                          rigid_arm_description)

__all__ = ["Plant", "STEP_FUNCTIONS", "LINK_MASS_SCALE", "build_plant", "rpy_zyx_sx"]

#: The Functions of the fixed-step rule, in the order ``mw_plant_open`` of ``plant_step.c`` takes them.
STEP_FUNCTIONS: tuple[str, ...] = ("ode", "ode_sliding", "events", "events_sliding", "update", "start", "active",
                                   "pivots")
#: The name of the extra parameter of a kernel plant (``build_plant(..., link_mass_scale=True)``).
LINK_MASS_SCALE = "link_mass_scale"

_ARGS = ("x", "u", "p", "m")


@dataclass(frozen=True)
class Plant:
    """The plant of one robot: its Functions (module docstring), names, units and start values.

    Attributes
    ----------
    robot
        The robot it was built from: its motor model, and its :attr:`~model.Robot.parameters`
        as the parameters' start values (:attr:`param_defaults`).
    n, nx, nu, nz
        Joints, states (2n), inputs (n) and friction modes (n).
    ode, ode_sliding, out, events, events_sliding, update, start, active, pivots, friction
        The Functions of the module docstring.
    param_names, param_defaults, param_descriptions, param_units
        The parameter vector ``p`` (FMI-style 1-based names); the defaults are the robot's values.
    state_names, input_names, output_names, output_units, output_descriptions
        Names (and units and descriptions of y) in vector order; the descriptions name the frames.
    x0
        (2n,) rest configuration with zero velocity.
    link_mass_scale
        True for a kernel plant: ``p`` ends with the factor on every link's mass and inertia.
    """

    robot: DynamicArm
    name: str
    n: int
    nx: int
    nu: int
    nz: int
    ode: ca.Function
    ode_sliding: ca.Function
    out: ca.Function
    events: ca.Function
    events_sliding: ca.Function
    update: ca.Function
    start: ca.Function
    active: ca.Function
    pivots: ca.Function
    friction: ca.Function
    param_names: tuple[str, ...]
    param_defaults: np.ndarray
    param_descriptions: tuple[str, ...]
    param_units: tuple[str, ...]
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    output_units: tuple[str, ...]
    output_descriptions: tuple[str, ...]
    x0: np.ndarray
    link_mass_scale: bool = False

    @property
    def ny(self) -> int:
        """Number of outputs (3n + 6)."""
        return len(self.output_names)

    def step_functions(self, prefix: str) -> list[ca.Function]:
        """The Functions of :data:`STEP_FUNCTIONS`, in that order, named ``prefix + name`` (distinct C symbols)."""
        out = []
        for name in STEP_FUNCTIONS:
            f: ca.Function = getattr(self, name)
            ins = f.sx_in()
            out.append(ca.Function(prefix + name, ins, f.call(ins), f.name_in(), f.name_out()))
        return out

    def sliding_modes(self, qd: np.ndarray) -> np.ndarray:
        """(n,) the sliding modes at velocities ``qd``: ``sign(qd_i)``, and +1 where ``qd_i = 0``."""
        return np.where(np.asarray(qd, dtype=float) < 0, -1.0, 1.0)


def rpy_zyx_sx(R: ca.SX) -> ca.SX:
    """(3, 1) ``[roll, pitch, yaw]`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)``, rad."""
    roll = ca.atan2(R[2, 1], R[2, 2])
    pitch = ca.atan2(-R[2, 0], ca.sqrt(R[2, 1] ** 2 + R[2, 2] ** 2))
    yaw = ca.atan2(R[1, 0], R[0, 0])
    return ca.vertcat(roll, pitch, yaw)


def build_plant(robot: DynamicArm, *, link_mass_scale: bool = False) -> Plant:
    """The plant of ``robot``: its motor model, its parameters (payload, friction, gravity) as start values.

    With ``link_mass_scale`` the parameter vector gets one more entry, the factor on every link's mass
    and inertia (centres of mass, rotors and payload unchanged), so that one compiled plant serves a
    sweep over link masses (:func:`model.dynamics.symbolic.plant_terms_sx`).
    """
    if has_drive_trains(robot.description):
        return _build_drive_plant(robot, link_mass_scale=link_mass_scale)
    n = robot.n
    desc = robot.description
    dyn = robot.dynamics
    layout = dyn.layout
    G = np.asarray(robot.gear_ratio, dtype=float)
    x = ca.SX.sym("x", 2 * n)
    u = ca.SX.sym("u", n)
    p = ca.SX.sym("p", layout.size + (1 if link_mass_scale else 0))
    m = ca.SX.sym("m", n)
    q, qd = x[:n], x[n:]
    params = split_parameters(layout, p)
    scale = p[layout.size] if link_mass_scale else None
    B, h = plant_terms_sx(desc, dyn.motor_model, q, qd, params, scale)
    tc_pos, tc_neg = coulomb_limits_sx(G, params.coulomb_friction_pos, params.coulomb_friction_neg)
    r = ca.DM(G) * u - h
    law = stick_slip_sx(B, r, tc_pos, tc_neg, qd, m)
    xdot = ca.vertcat(law.qd_held, law.qdd)
    xdot_sliding = ca.vertcat(qd, sliding_accel_sx(B, r, tc_pos, tc_neg, m))
    T_WE = robot.kinematics.fkine(q)
    y = ca.vertcat(q, qd, ca.DM(G) * q, T_WE[0:3, 3], rpy_zyx_sx(T_WE[0:3, 0:3]))

    def fn(name: str, outputs: list[ca.SX], out_names: list[str], inputs: tuple = (x, u, p, m),
           in_names: tuple = _ARGS) -> ca.Function:
        return ca.Function(name, list(inputs), [ca.densify(ca.cse(o)) for o in outputs], list(in_names), out_names)

    idx = range(1, n + 1)
    pos_unit = ["rad" if lk.is_revolute else "m" for lk in desc.links]
    vel_unit = ["rad/s" if lk.is_revolute else "m/s" for lk in desc.links]
    joint = [f"joint {i} ({lk.name or f'link {i}'}, {'revolute' if lk.is_revolute else 'prismatic'})"
             for i, lk in zip(idx, desc.links)]
    out_names = (
        [f"q[{i}]" for i in idx] + [f"qd[{i}]" for i in idx] + [f"qm[{i}]" for i in idx]
        + [f"tool_position[{k}]" for k in (1, 2, 3)] + [f"tool_rpy[{k}]" for k in (1, 2, 3)]
    )
    world = "the world frame W" + (" (the robot's base pose stated: W is not frame 0)" if desc.base is not None
                                   else " (= frame 0: the robot states no base pose)")
    out_desc = (
        [f"{j} position" for j in joint] + [f"{j} velocity" for j in joint]
        + [f"motor {i} ({desc.links[i - 1].name or f'link {i}'}) position, G q" for i in idx]
        + [f"tool position {a} in {world}, fkine" for a in "xyz"]
        + [f"tool {a} in {world}, ZYX angles: R_WE = Rz(yaw) Ry(pitch) Rx(roll)" for a in ("roll", "pitch", "yaw")]
    )
    out_units = pos_unit + vel_unit + ["rad"] * n + ["m"] * 3 + ["rad"] * 3
    names, descriptions, units = list(layout.names), list(layout.descriptions), list(layout.units)
    defaults = np.array(robot.parameters.vector, dtype=float)
    if link_mass_scale:
        names.append(LINK_MASS_SCALE)
        descriptions.append("factor on every link's mass and inertia (centres of mass, rotors and payload unchanged)")
        units.append("")
        defaults = np.append(defaults, 1.0)
    return Plant(
        robot=robot,
        name=desc.identifier,
        n=n, nx=2 * n, nu=n, nz=n,
        ode=fn("ode", [xdot], ["xdot"]),
        ode_sliding=fn("ode_sliding", [xdot_sliding], ["xdot"]),
        out=fn("out", [y], ["y"], (x, u, p), _ARGS[:3]),
        events=fn("events", [law.z], ["z"]),
        events_sliding=fn("events_sliding", [sliding_indicators_sx(tc_pos, tc_neg, qd, m)], ["z"]),
        update=fn("update", [law.m_next, ca.vertcat(q, law.qd_next)], ["m_next", "x_next"]),
        start=fn("start", [law.m_start], ["m_start"]),
        active=fn("active", [law.active], ["active"]),
        pivots=fn("pivots", [law.pivots], ["D"]),
        friction=fn("friction", [law.friction], ["f"]),
        param_names=tuple(names),
        param_defaults=defaults,
        param_descriptions=tuple(descriptions),
        param_units=tuple(units),
        state_names=tuple([f"q[{i}]" for i in idx] + [f"qd[{i}]" for i in idx]),
        input_names=tuple(f"u[{i}]" for i in idx),
        output_names=tuple(out_names),
        output_units=tuple(out_units),
        output_descriptions=tuple(out_desc),
        x0=np.concatenate([desc.q_rest, np.zeros(n)]),
        link_mass_scale=link_mass_scale,
    )


def _build_drive_plant(robot: DynamicArm, *, link_mass_scale: bool = False) -> Plant:
    """:func:`build_plant` for a robot with drive trains (:mod:`model.drive_train`): more states and modes."""
    desc = robot.description
    dyn = robot.dynamics
    check_drive_trains(desc, dyn.motor_model)
    lay = drive_layout(desc)
    n, nx, nz = desc.n, lay.nx, lay.nz
    layout = dyn.layout
    G = np.asarray(robot.gear_ratio, dtype=float)
    x = ca.SX.sym("x", nx)
    u = ca.SX.sym("u", n)
    p = ca.SX.sym("p", layout.size + (1 if link_mass_scale else 0))
    m = ca.SX.sym("m", nz)
    q, qd = x[:n], x[n:2 * n]
    params = split_parameters(layout, p)
    scale = p[layout.size] if link_mass_scale else None
    rotor_side = [lk.is_elastic and lk.friction_side == "motor" for lk in desc.links]
    arm_viscous = ca.vertcat(*[0 if rotor_side[i] else params.viscous_friction[i] for i in range(n)])
    B_arm, h_arm = plant_terms_sx(rigid_arm_description(desc), dyn.motor_model, q, qd,
                                  params._replace(viscous_friction=arm_viscous), scale)
    t = drive_terms_sx(desc, lay, x, u, B_arm, h_arm, params.viscous_friction, params.coulomb_friction_pos,
                       params.coulomb_friction_neg)
    law = stick_slip_sx(t["B"], t["r"], t["tc_pos"], t["tc_neg"], t["qd"], m, t["hold_pos"], t["hold_neg"])
    ne = lay.ne

    def rows(v: ca.SX, a: int, b: int) -> ca.SX:  # v[a:b] as a column, also when v is 1 x 1 (its empty slice is 1 x 0)
        return ca.vertcat(*[v[i] for i in range(a, b)]) if b > a else ca.SX(0, 1)

    N = n + lay.ne

    def arrange(vel: ca.SX, acc: ca.SX) -> ca.SX:
        return ca.vertcat(rows(vel, 0, n), rows(acc, 0, n), rows(vel, n, N), rows(acc, n, N), t["extra"])

    xdot = arrange(law.qd_held, law.qdd)
    xdot_sliding = arrange(t["qd"], sliding_accel_sx(t["B"], t["r"], t["tc_pos"], t["tc_neg"], m))
    x_next = ca.vertcat(q, rows(law.qd_next, 0, n), x[lay.qm_slice], rows(law.qd_next, n, N), x[2 * n + 2 * ne:])
    qm = ca.vertcat(*[G[i] * q[i] for i in range(n)])
    for k, i in enumerate(lay.elastic):
        qm[i] = x[lay.qm_slice][k]
    T_WE = robot.kinematics.fkine(q)
    y = ca.vertcat(q, qd, qm, T_WE[0:3, 3], rpy_zyx_sx(T_WE[0:3, 0:3]))
    rigid = build_plant_rigid_names(robot, link_mass_scale)

    def fn(name: str, outputs: list[ca.SX], out_names: list[str], inputs: tuple = (x, u, p, m),
           in_names: tuple = _ARGS) -> ca.Function:
        return ca.Function(name, list(inputs), [ca.densify(ca.cse(o)) for o in outputs], list(in_names), out_names)

    g = np.asarray(robot.gravload(desc.q_rest), dtype=float)
    defaults = np.array(robot.parameters.vector, dtype=float)
    return dataclasses.replace(
        rigid,
        robot=robot,
        param_defaults=np.append(defaults, 1.0) if link_mass_scale else defaults,
        nx=nx, nz=nz,
        ode=fn("ode", [xdot], ["xdot"]),
        ode_sliding=fn("ode_sliding", [xdot_sliding], ["xdot"]),
        out=fn("out", [y], ["y"], (x, u, p), _ARGS[:3]),
        events=fn("events", [law.z], ["z"]),
        events_sliding=fn("events_sliding", [sliding_indicators_sx(t["tc_pos"], t["tc_neg"], t["qd"], m)], ["z"]),
        update=fn("update", [law.m_next, x_next], ["m_next", "x_next"]),
        start=fn("start", [law.m_start], ["m_start"]),
        active=fn("active", [law.active], ["active"]),
        pivots=fn("pivots", [law.pivots], ["D"]),
        friction=fn("friction", [law.friction], ["f"]),
        state_names=tuple(lay.state_names()),
        x0=equilibrium_state(desc, desc.q_rest, g),
    )


def build_plant_rigid_names(robot: DynamicArm, link_mass_scale: bool) -> Plant:
    """A :class:`Plant` holding the names, units and parameters of ``robot`` (its Functions those of the rigid
    arm: :func:`_build_drive_plant` replaces them)."""
    import dataclasses as _dc

    desc = robot.description
    bare = _dc.replace(desc, links=tuple(_dc.replace(lk, **{k: v for k, v in DRIVE_TRAIN_DEFAULTS.items()})
                                         for lk in desc.links))
    rigid = type(robot)(bare, motor_model=robot.dynamics.motor_model)  # type: ignore[call-arg]  # a Robot
    return build_plant(rigid, link_mass_scale=link_mass_scale)
