"""Named CasADi Functions of the dynamic model, ready for evaluation and code generation.

Every Function takes dense column vectors and returns dense outputs; ``p`` is
the parameter vector of :mod:`model.dynamics.parameters`. Lagrange gives
``inertia``, ``coriolis``, ``gravload`` and the energies; Newton-Euler gives
``rne`` and the bias torques used by ``accel``:

* ``inertia(q, p) -> B``, ``coriolis(q, qd, p) -> C``, ``gravload(q, p) -> g``
* ``friction(qd, p) -> F``
* ``rne(q, qd, qdd, p) -> tau`` (Newton-Euler) and ``rne_lagrange`` (``B qdd + C qd + g + F``)
* ``accel(q, qd, tau, p) -> qdd``: ``B^-1 (tau - rne(q, qd, 0))`` with B from
  unit-acceleration Newton-Euler passes and an LDL^T solve; ``accel_lagrange``
  uses the Lagrange B, C and g instead.
* ``energy(q, qd, p) -> (T, U)``: kinetic (rotors included) and potential energy.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import casadi as ca
import numpy as np

from ..description import RobotDescription
from .lagrange import lagrange_model
from .linalg import ldl_solve_sx
from .motors import check_motor_model, friction_sx
from .newton_euler import rne_sx
from .parameters import parameter_layout, split_parameters

__all__ = ["DynamicsFunctions", "build_functions", "COMPILED_FUNCTIONS"]

#: The Functions compiled for the numeric API (see :mod:`model.codegen`).
COMPILED_FUNCTIONS: tuple[str, ...] = ("inertia", "coriolis", "gravload", "friction", "rne", "accel")


@dataclass(frozen=True)
class DynamicsFunctions:
    """The named CasADi Functions of one robot and motor model (SX, code-generatable)."""

    inertia: ca.Function
    coriolis: ca.Function
    gravload: ca.Function
    friction: ca.Function
    rne: ca.Function
    rne_lagrange: ca.Function
    accel: ca.Function
    accel_lagrange: ca.Function
    energy: ca.Function

    def as_dict(self) -> dict[str, ca.Function]:
        """Name -> Function."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


def build_functions(desc: RobotDescription, motor_model: str = "reflected") -> DynamicsFunctions:
    """Build the dynamics Functions of ``desc`` (link inertial data baked in as constants)."""
    check_motor_model(motor_model)
    n = desc.n
    layout = parameter_layout(desc)
    q = ca.SX.sym("q", n)
    qd = ca.SX.sym("qd", n)
    qdd = ca.SX.sym("qdd", n)
    tau = ca.SX.sym("tau", n)
    p = ca.SX.sym("p", layout.size)
    params = split_parameters(layout, p)
    G = np.array([lk.gear_ratio for lk in desc.links])

    lag = lagrange_model(desc, motor_model, q, qd, params)
    F = friction_sx(G, qd, params.viscous_friction, params.coulomb_friction_pos, params.coulomb_friction_neg)
    tau_ne = rne_sx(desc, motor_model, q, qd, qdd, params)
    tau_lag = lag.B @ qdd + lag.C @ qd + lag.g + F

    # accel from Newton-Euler: bias h = rne(q, qd, 0); column j of B = rne(q, 0, e_j) without gravity/friction
    zero = ca.SX.zeros(n, 1)
    h = rne_sx(desc, motor_model, q, qd, zero, params)
    no_gravity = params._replace(gravity=ca.SX.zeros(3, 1))
    B_ne = ca.horzcat(*[
        rne_sx(desc, motor_model, q, zero, ca.SX(ca.DM.eye(n)[:, j]), no_gravity, with_friction=False)
        for j in range(n)
    ])
    qdd_ne = ldl_solve_sx(B_ne, tau - h)  # reads the lower triangle only: the unused entries are pruned
    qdd_lag = ldl_solve_sx(lag.B, tau - lag.C @ qd - lag.g - F)

    d = ca.densify
    return DynamicsFunctions(
        inertia=ca.Function("inertia", [q, p], [d(lag.B)], ["q", "p"], ["B"]),
        coriolis=ca.Function("coriolis", [q, qd, p], [d(lag.C)], ["q", "qd", "p"], ["C"]),
        gravload=ca.Function("gravload", [q, p], [d(lag.g)], ["q", "p"], ["g"]),
        friction=ca.Function("friction", [qd, p], [d(F)], ["qd", "p"], ["F"]),
        rne=ca.Function("rne", [q, qd, qdd, p], [d(ca.cse(tau_ne))], ["q", "qd", "qdd", "p"], ["tau"]),
        rne_lagrange=ca.Function("rne_lagrange", [q, qd, qdd, p], [d(ca.cse(tau_lag))], ["q", "qd", "qdd", "p"], ["tau"]),
        accel=ca.Function("accel", [q, qd, tau, p], [d(ca.cse(qdd_ne))], ["q", "qd", "tau", "p"], ["qdd"]),
        accel_lagrange=ca.Function("accel_lagrange", [q, qd, tau, p], [d(ca.cse(qdd_lag))], ["q", "qd", "tau", "p"], ["qdd"]),
        energy=ca.Function("energy", [q, qd, p], [d(lag.T), d(lag.U)], ["q", "qd", "p"], ["T", "U"]),
    )
