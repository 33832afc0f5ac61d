"""A controller FMU that carries its reference: the law of :mod:`closed_loop.controller_fmu` fed by its own clock.

The controller FMU of :func:`closed_loop.controller_fmu.controller_spec` takes the reference
``q_ref``, ``qd_ref`` (``qdd_ref``) as inputs. A closed loop handed over as one file (an SSP,
:mod:`fmu.ssp`) has nobody to feed them, so this spec replaces those inputs by the trajectory's
piecewise quintic :class:`~model.trajectory.JointPath` evaluated inside the FMU (the same
arithmetic as :meth:`JointPath.batch`, generated into C) at the control instant ``t_j = t0 + j h``
(integer j, never a running sum) counted by a sampled discrete state ``k`` (ticked once per period
``h``, :class:`fmu.variables.DiscreteStates`):

* the output ``tau_m = law(q, qd, ref(t_{max(k-1, 0)}))``: after the ``j``-th ``fmi2DoStep``
  (``k = j``) it is the law at the instant the step started, ``t_{j-1}``, with the measured state the
  importer set before that step; before any step (``k = 0``) at ``t_0``.

A path of more than :data:`MAX_SYMBOLIC_PIECES` pieces (a trajectory file: one per sample) is tabulated
instead, at the control instants (:func:`table_at`).

So an importer that sets the plant state sampled at ``t_j`` before the controller's step from
``t_j`` and reads ``tau_m`` after it runs the law of ``t_j`` on the state of ``t_j``: the loop
of a Jacobi master (the torque reaches the plant one period late, :class:`~closed_loop.delay.OnePeriodDelay`).

A law with its own sampled state ('pid': the integrator ``z``, ticked at the same period ``h``) shares the
clock: one :class:`~fmu.variables.DiscreteStates` holds ``k``, ``z_out[i]`` and ``z[i]`` with one tick. At the
start of the step from ``t_j`` (``k = j``) the tick runs the law's own update on the inputs held over that step
and the reference at ``t_j``: ``z_out <- z`` (``z_j``), ``z <- z_next(q, qd, ref(t_j), z_j)`` (``z_{j+1}``),
``k <- j + 1``; ``tau_m`` is the law on ``z_out``, so after the step it is the law of ``t_j`` with the
integrator of ``t_j``, as :meth:`~control_design.controllers.LawController.update` computes it at ``t_j``
(before any step ``z_out = z_0 = 0``).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import casadi as ca
import numpy as np

from control_design.controllers import Controller
from fmu.variables import DiscreteStates, ModelSpec, Quantity
from model.errors import InputError
from model.robot import Robot
from model.trajectory import JointPath, Trajectory, _basis

from .controller_fmu import controller_spec

__all__ = ["reference_controller_spec", "path_at", "table_at", "MAX_SYMBOLIC_PIECES"]

_REF_GROUPS = ("q_ref", "qd_ref", "qdd_ref")
#: A path of more pieces than this is tabulated at the control instants (:func:`table_at`): a trajectory file
#: (``manip retime``, ``manip excite``) has one piece per sample, thousands, and :func:`path_at`'s C grows with them.
MAX_SYMBOLIC_PIECES = 200
_CLOCK = Quantity("k", "1", "control periods since the start (the reference clock), sampled")


def path_at(path: JointPath, t: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Position, velocity and acceleration (n x 1 SX each) of ``path`` at the symbolic time ``t`` (s).

    The arithmetic of :meth:`JointPath.batch`: the piece ``k`` with ``breaks[k] <= t < breaks[k+1]``
    (the last piece at its end), ``s = (t - breaks[k]) / h_k`` clipped to [0, 1]; before the first
    break the start position at rest, after the last one the end position at rest.
    """
    b = path.breaks
    K = b.size - 1
    zero = ca.SX.zeros(path.n)
    q_end, q_start = ca.SX(ca.DM(path.q[-1])), ca.SX(ca.DM(path.q[0]))
    result = (q_end, zero, zero)  # t > breaks[-1]
    for k in reversed(range(K)):
        h = float(b[k + 1] - b[k])
        s = ca.fmin(ca.fmax((t - float(b[k])) / h, 0.0), 1.0)
        piece = path._piece(k, h, _basis(s))  # noqa: SLF001 - the path's own arithmetic, written once
        piece = tuple(ca.SX(p) if not isinstance(p, ca.SX) else p for p in piece)
        upper = t <= float(b[k + 1]) if k == K - 1 else t < float(b[k + 1])
        result = tuple(ca.if_else(upper, pc, r) for pc, r in zip(piece, result))
    before = t < float(b[0])
    return tuple(ca.if_else(before, s0, r) for s0, r in zip((q_start, zero, zero), result))  # type: ignore[return-value]


def table_at(robot: Robot, trajectory: Trajectory, dt: float) -> Callable[[ca.SX], tuple[ca.SX, ca.SX, ca.SX]]:
    """``k -> `` position, velocity and acceleration (n x 1 SX each) of ``trajectory`` at the control instant
    ``t0 + k dt`` (``k`` a symbolic whole number >= 0 of periods ``dt``, s), looked up in a table.

    The table holds the reference :class:`~closed_loop.schedule.Schedule` samples at ``t0 + j dt``
    (``j = 0 .. N``, the numbers ``manip track`` runs on, :meth:`JointPath.batch`) and one row after the end
    (the end position at rest); ``k`` past it is clipped to it. It is a linear interpolant on the integers
    0 .. N + 1 (:func:`casadi.interpolant`, its data generated into the C), read at whole ``k`` only, where
    its weights are exactly 0 and 1: the lookup returns the samples bit for bit.
    """
    from .schedule import Schedule

    path = trajectory.path
    sched = Schedule.build(robot, trajectory, dt, substeps=1)
    after = path.batch([path.t_start + (sched.steps + 1) * dt])
    rows = np.hstack([np.vstack([a, b]) for a, b in zip((sched.q_ref, sched.qd_ref, sched.qdd_ref), after)])
    grid = np.arange(rows.shape[0], dtype=float)
    table = ca.interpolant("reference_table", "linear", [grid], rows.ravel().tolist())
    n = path.n

    def at(k: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
        y = table(ca.fmin(k, grid[-1]))
        return y[:n], y[n:2 * n], y[2 * n:]

    return at


def reference_controller_spec(controller: Controller, robot: Robot, trajectory: Trajectory, *,
                              model_identifier: str | None = None) -> ModelSpec:
    """The spec of a controller FMU running ``controller`` along ``trajectory`` with no reference inputs.

    Inputs ``q[i]``, ``qd[i]``; output ``tau_m[i]`` (N m); parameters those of
    :func:`~closed_loop.controller_fmu.controller_spec`; one sampled discrete state ``k`` (the
    count of periods ``1 / rate_hz`` since the start); the reference at ``t0 + (k - 1) h``
    (``t0`` the trajectory's start, s); 'pid' adds the sampled ``z_out[i]``, ``z[i]`` (motor rad s) on the
    same clock (module docstring).

    Raises
    ------
    model.errors.InputError
        A trajectory that is not a joint path (a Cartesian one is sampled first), a law whose sampled
        state has another period than the control period.
    """
    path = trajectory.path
    if not isinstance(path, JointPath):
        raise InputError(f"expected a joint-space trajectory (piecewise quintic), got {type(path).__name__}",
                         parameter="trajectory")
    base = controller_spec(controller, robot, model_identifier=model_identifier)
    dt = float(controller.dt)
    own = base.discrete
    if own is not None and own.period != dt:
        raise InputError(f"the {controller.kind!r} law's sampled state has the period {own.period!r} s, expected the "
                         f"control period {dt!r} s", parameter="controller")
    n = robot.n
    names = [q.name for q in base.inputs]
    ref_count = sum(1 for nm in names if nm.split("[")[0] in _REF_GROUPS)
    groups = [g for g in _REF_GROUPS if f"{g}[1]" in names]
    measured = base.inputs[ref_count:]
    nz = 0 if own is None else len(own.states)
    x = ca.SX.sym("x", 0)
    u = ca.SX.sym("u", len(measured))
    p = ca.SX.sym("p", base.p_start.size)
    d = ca.SX.sym("d", 1 + 2 * nz)  # k, then (with a sampled law) z_out and z

    tabulated = table_at(robot, trajectory, dt) if path.breaks.size - 1 > MAX_SYMBOLIC_PIECES else None

    def law_input(k: ca.SX) -> ca.SX:
        at = path_at(path, path.t_start + k * dt) if tabulated is None else tabulated(k)
        signals = dict(zip(_REF_GROUPS, at))
        ref = ca.vertcat(*[signals[g] for g in groups])
        assert ref.numel() == ref_count == len(groups) * n
        return ca.vertcat(ref, u)

    k_out = ca.fmax(d[0] - 1.0, 0.0)  # the instant the last step started (t_0 before any step)
    if own is None:
        tau = base.out(x, law_input(k_out), p)
        d_next = d + 1.0
        states = (_CLOCK,)
        start = np.zeros(1)
    else:
        z_out, z = d[1:1 + nz], d[1 + nz:]
        tau = base.out(x, law_input(k_out), p, z_out)
        d_next = ca.vertcat(d[0] + 1.0, z, own.tick(x, law_input(d[0]), p, z))
        states = (_CLOCK,) + tuple(
            replace(s, name=s.name.replace("z[", "z_out[", 1),
                    description=s.description.replace(", sampled", "") + ", the one tau_m uses (of the instant the "
                                                                          "last step started), sampled")
            for s in own.states) + own.states
        start = np.concatenate([np.zeros(1), own.start, own.start])
    ode = ca.Function("ode", [x, u, p, d], [ca.SX(0, 1)], ["x", "u", "p", "d"], ["xdot"])
    out = ca.Function("out", [x, u, p, d], [tau], ["x", "u", "p", "d"], ["y"])
    tick = ca.Function("tick", [x, u, p, d], [d_next], ["x", "u", "p", "d"], ["d_next"])
    clock = DiscreteStates(states, start, dt, tick)
    return ModelSpec(
        model_identifier=base.model_identifier + "_ref",
        model_name=base.model_name + " with its reference",
        description=base.description + f"; reference: the trajectory from t0 = {path.t_start:g} s to "
                    f"{path.t_end:g} s at t0 + (k - 1) h, k the periods counted",
        ode=ode, out=out, states=(), x_start=np.zeros(0), inputs=tuple(measured),
        params=base.params, p_start=base.p_start, p_tunable=base.p_tunable, p_min=base.p_min, p_max=base.p_max,
        outputs=base.outputs, output_state=base.output_state, step=base.step, discrete=clock,
    )
