"""The P-PI cascade (:mod:`control_design.cascade`) as a controller FMU (FMI 2.0 Co-Simulation).

Built by the same variable table and C wrapper as every FMU (:func:`fmu.build.build_fmu`): no continuous
states, the PI integrators ``x[i]`` a sampled discrete state ticked once per period ``1 / rate_hz``, the
output computed from ``x_k`` and the inputs (direct feedthrough) by the law of
:func:`~control_design.cascade.cascade_law` (the compiled closed loop's), the operations of
:meth:`~control_design.cascade.CascadeController.update_motor`:

==============  ===========================================================================
inputs          ``q_ref[i]``, ``qd_ref[i]`` (joint side, rad, rad/s), ``q_m[i]``, ``qd_m[i]``
                (rotor angle and speed, motor side, rad, rad/s)
output          ``tau_m[i]``: the torque demand ``k ks (x + e)``, N m
parameters      ``kp[i]`` (1/s), ``ks[i]`` (A s/rad), ``ti[i]`` (s), ``torque_constant[i]``
                (N m/A), ``gear_ratio[i]``
discrete state  ``x_pi[i]`` (rad/s): the integral of the speed error over ``ti``; start: the
                controller's integrators when exported (e.g. after ``hold_from``)
==============  ===========================================================================
"""

from __future__ import annotations

import os
from pathlib import Path

import casadi as ca
import numpy as np

from control_design.cascade import CascadeController, cascade_law
from fmu.build import build_fmu
from fmu.variables import DiscreteStates, ModelSpec, Quantity, fmu_identifier
from model.robot import Robot

__all__ = ["cascade_spec", "export_cascade_fmu"]


def cascade_spec(controller: CascadeController, robot: Robot, *, model_identifier: str | None = None) -> ModelSpec:
    """The :class:`~fmu.variables.ModelSpec` of ``controller`` driving ``robot`` (module docstring)."""
    n = robot.n
    names = [lk.name or f"joint {i + 1}" for i, lk in enumerate(robot.description.links)]
    q_ref, qd_ref, qm, qdm = (ca.SX.sym(s, n) for s in ("q_ref", "qd_ref", "q_m", "qd_m"))
    kp, ks, ti, k, G = (ca.SX.sym(s, n) for s in ("kp", "ks", "ti", "torque_constant", "gear_ratio"))
    d = ca.SX.sym("xpi", n)
    # the one cascade law (the compiled closed loop's), the period a constant of this FMU
    tau, d_next = cascade_law(n).function(qm, qdm, q_ref, qd_ref, kp, ks, ti, k, G, controller.dt, d)
    x = ca.SX.sym("x", 0)
    u = ca.vertcat(q_ref, qd_ref, qm, qdm)
    p = ca.vertcat(kp, ks, ti, k, G)
    args, arg_names = [x, u, p, d], ["x", "u", "p", "d"]
    ode = ca.Function("ode", args, [ca.SX(0, 1)], arg_names, ["xdot"])
    out = ca.Function("out", args, [ca.densify(tau)], arg_names, ["y"])
    tick = ca.Function("tick", args, [ca.densify(d_next)], arg_names, ["d_next"])
    idx = range(n)
    inputs = tuple(
        [Quantity(f"q_ref[{i + 1}]", "rad", f"reference position of joint {i + 1} ({names[i]})") for i in idx]
        + [Quantity(f"qd_ref[{i + 1}]", "rad/s", f"reference velocity of joint {i + 1} ({names[i]})") for i in idx]
        + [Quantity(f"q_m[{i + 1}]", "rad", f"rotor angle of joint {i + 1} ({names[i]}), motor side") for i in idx]
        + [Quantity(f"qd_m[{i + 1}]", "rad/s", f"rotor speed of joint {i + 1} ({names[i]}), motor side")
           for i in idx])
    params, p_start = [], []
    for sym, values, unit, text in (("kp", controller.kp, "1/s", "position gain"),
                                    ("ks", controller.ks, "A.s/rad", "speed gain"),
                                    ("ti", controller.ti, "s", "PI time constant"),
                                    ("torque_constant", controller.k, "N.m/A", "motor torque constant"),
                                    ("gear_ratio", controller.G, "", "reduction ratio (motor angle = G q)")):
        params += [Quantity(f"{sym}[{i + 1}]", unit, f"{text}, joint {i + 1} ({names[i]})") for i in idx]
        p_start.append(np.asarray(values, dtype=float))
    states = tuple(Quantity(f"x_pi[{i + 1}]", "rad/s", f"PI integrator of joint {i + 1} ({names[i]}), sampled")
                   for i in idx)
    discrete = DiscreteStates(states, np.asarray(controller.x, dtype=float).copy(), controller.dt, tick)
    outputs = tuple(Quantity(f"tau_m[{i + 1}]", "N.m", f"motor torque demand of joint {i + 1} ({names[i]})")
                    for i in idx)
    ident = fmu_identifier(model_identifier, f"{robot.name}_cascade_controller")
    return ModelSpec(
        model_identifier=ident, model_name=f"{robot.name} cascade controller",
        description=(f"P-PI cascade of {robot.name} on the motor side, sampled at {controller.rate_hz:g} Hz: "
                     "e = G qd_ref + kp (G q_ref - q_m) - qd_m, tau_m = k ks (x + e), x += dt e / ti"),
        ode=ode, out=out, states=(), x_start=np.zeros(0), inputs=inputs,
        params=tuple(params), p_start=np.concatenate(p_start), p_tunable=(True,) * (5 * n),
        p_min=(None,) * (5 * n), p_max=(None,) * (5 * n),
        outputs=outputs, output_state=(-1,) * n, step=controller.dt, discrete=discrete,
    )


def export_cascade_fmu(controller: CascadeController, robot: Robot, path: str | os.PathLike[str], *,
                       platforms: str | None = None) -> Path:
    """Write ``controller`` (its gains, rate and present integrators as start values) as an FMU at ``path``."""
    return build_fmu(cascade_spec(controller, robot), path, platforms=platforms)
