"""Named CasADi Functions of the dynamic model, ready for evaluation and code generation.

Every Function takes dense column vectors and returns dense outputs; ``p`` is
the parameter vector of :mod:`model.dynamics.parameters`. The compiled set
(:data:`COMPILED_FUNCTIONS`) is built from recursive algorithms only (Newton-Euler, the
composite-rigid-body algorithm, a recursive Coriolis matrix), each Function from the formulation
of fewest operations (from :data:`RECURSIVE_MIN_JOINTS` joints; smaller arms keep the
Newton-Euler forms and their numbers bit for bit), so its size grows like n^2 (``coriolis``, ``inertia``) or n^3 (the LDL^T
solve of ``accel``), never like the n^4 of the expanded Lagrange model:

* ``inertia(q, p) -> B``: by the composite-rigid-body algorithm (:mod:`model.dynamics.crba`,
  reflected motors, in body frames or in frame 0) or from the columns ``rne(q, 0, e_j)``
  without gravity and friction (lower triangle mirrored), whichever has fewer operations (:attr:`DynamicsFunctions.formulations`
  says which); B is exactly symmetric either way, and ``coriolis`` and ``accel`` use the same B.
* ``coriolis(q, qd, p) -> C``: the recursion of :mod:`model.dynamics.coriolis_recursive` in frame 0
  (reflected motors) or ``C = 1/2 (Bdot + J - J^T)``, whichever has fewer operations, the latter with
  ``J = d(B(q) v)/dq`` at ``v = qd``, ``B(q) v = rne(q, 0, v)`` (one pass, no
  gravity, no friction) and ``Bdot = dB/dq . qd``; both forward-mode
  derivatives (see ``docs/model-equations.md``). This is the Christoffel C.
* ``gravload(q, p) -> g``: ``rne(q, 0, 0)`` without friction.
* ``friction(qd, p) -> F``
* ``rne(q, qd, qdd, p) -> tau``: ``B qdd + C qd + g + F`` by Newton-Euler.
* ``accel(q, qd, tau, p) -> qdd``: ``B^-1 (tau - rne(q, qd, 0))`` by an LDL^T solve of the chosen B,
  or by the articulated-body algorithm in frame 0 (:mod:`model.dynamics.aba`, reflected motors),
  whichever has fewer operations.

The Lagrange model stays available as the independent check, built on first
access only (its size grows like n^4): ``inertia_lagrange``,
``coriolis_lagrange``, ``gravload_lagrange``, ``rne_lagrange`` (``B qdd + C qd
+ g + F``), ``accel_lagrange`` and ``energy(q, qd, p) -> (T, U)`` (kinetic,
rotors included, and potential energy).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from ..description import RobotDescription
from .lagrange import lagrange_model
from .linalg import ldl_solve_sx
from .motors import check_motor_model, friction_sx, viscous_friction_sx
from .aba import aba_world_sx
from .coriolis_recursive import coriolis_world_sx
from .crba import crba_sx, crba_world_sx
from .newton_euler import rne_sx
from .parameters import SymbolicParameters, parameter_layout, split_parameters

__all__ = [
    "COMPILED_FUNCTIONS",
    "DynamicsFunctions",
    "LagrangeFunctions",
    "build_functions",
    "build_lagrange_functions",
    "RECURSIVE_MIN_JOINTS",
    "coriolis_ne_sx",
    "plant_terms_sx",
]

#: The fewest joints for which the recursive forms (CRBA, ABA, recursive Coriolis) compete with the Newton-Euler ones.
RECURSIVE_MIN_JOINTS = 6

#: The Functions compiled for the numeric API (see :mod:`model.codegen`).
COMPILED_FUNCTIONS: tuple[str, ...] = ("inertia", "coriolis", "gravload", "friction", "rne", "accel")


@dataclass(frozen=True)
class LagrangeFunctions:
    """The Functions of the symbolic Lagrange model (independent of Newton-Euler; O(n^4) in size)."""

    inertia_lagrange: ca.Function
    coriolis_lagrange: ca.Function
    gravload_lagrange: ca.Function
    rne_lagrange: ca.Function
    accel_lagrange: ca.Function
    energy: ca.Function


@dataclass(frozen=True)
class DynamicsFunctions:
    """The named CasADi Functions of one robot and motor model (SX, code-generatable).

    The Newton-Euler Functions are built with the object; the Lagrange ones
    (:attr:`lagrange`, and the shortcuts ``rne_lagrange``, ``accel_lagrange``,
    ``energy``) on first access.
    """

    inertia: ca.Function
    coriolis: ca.Function
    gravload: ca.Function
    friction: ca.Function
    rne: ca.Function
    accel: ca.Function
    description: RobotDescription = field(repr=False, compare=False)
    motor_model: str = "reflected"
    #: How B(q) was formed, with the operation counts the choice was made on (one line for ``manip build``).
    formulations: str = field(default="", compare=False)

    @cached_property
    def lagrange(self) -> LagrangeFunctions:
        """The Lagrange Functions (built on first access: slow beyond ~8 joints)."""
        return build_lagrange_functions(self.description, self.motor_model)

    @property
    def rne_lagrange(self) -> ca.Function:
        return self.lagrange.rne_lagrange

    @property
    def accel_lagrange(self) -> ca.Function:
        return self.lagrange.accel_lagrange

    @property
    def energy(self) -> ca.Function:
        return self.lagrange.energy

    def as_dict(self, *, lagrange: bool = True) -> dict[str, ca.Function]:
        """Name -> Function: the compiled set, and the Lagrange Functions unless ``lagrange`` is False."""
        named = {name: getattr(self, name) for name in COMPILED_FUNCTIONS}
        if lagrange:
            named.update({name: getattr(self.lagrange, name) for name in LagrangeFunctions.__dataclass_fields__})
        return named


class _Symbols:
    """The symbolic inputs shared by the Functions of one robot."""

    def __init__(self, desc: RobotDescription) -> None:
        n = desc.n
        self.q = ca.SX.sym("q", n)
        self.qd = ca.SX.sym("qd", n)
        self.qdd = ca.SX.sym("qdd", n)
        self.tau = ca.SX.sym("tau", n)
        self.p = ca.SX.sym("p", parameter_layout(desc).size)
        self.params = split_parameters(parameter_layout(desc), self.p)
        self.gear = np.array([lk.gear_ratio for lk in desc.links])

    def friction(self, qd: ca.SX) -> ca.SX:
        prm = self.params
        return friction_sx(self.gear, qd, prm.viscous_friction, prm.coulomb_friction_pos, prm.coulomb_friction_neg)


def _without_gravity(params: SymbolicParameters) -> SymbolicParameters:
    return params._replace(gravity=ca.SX.zeros(3, 1))


def _inertia_columns_ne(desc: RobotDescription, motor_model: str, q: ca.SX, params: SymbolicParameters,
                        link_mass_scale: ca.SX | None = None) -> ca.SX:
    """(n, n) ``[rne(q, 0, e_1) ... rne(q, 0, e_n)]`` without gravity and friction (its lower triangle is B's)."""
    n = desc.n
    zero = ca.SX.zeros(n, 1)
    no_gravity = _without_gravity(params)
    return ca.horzcat(*[
        rne_sx(desc, motor_model, q, zero, ca.SX(ca.DM.eye(n)[:, j]), no_gravity, with_friction=False,
               link_mass_scale=link_mass_scale)
        for j in range(n)
    ])


def _accel_sx(desc: RobotDescription, motor_model: str, s: "_Symbols", B_cols: ca.SX | None = None) -> ca.SX:
    """``B^-1 (tau - rne(q, qd, 0))`` by an LDL^T solve of the Newton-Euler inertia columns."""
    zero = ca.SX.zeros(desc.n, 1)
    h = rne_sx(desc, motor_model, s.q, s.qd, zero, s.params)
    if B_cols is None:
        B_cols = _inertia_columns_ne(desc, motor_model, s.q, s.params)
    return ldl_solve_sx(B_cols, s.tau - h)  # reads the lower triangle only: the unused entries are pruned


def plant_terms_sx(desc: RobotDescription, motor_model: str, q: ca.SX, qd: ca.SX, params: SymbolicParameters,
                   link_mass_scale: ca.SX | None = None) -> tuple[ca.SX, ca.SX]:
    """The pieces of the plant's dynamics: ``(B, h)``.

    ``B`` (n, n): the Newton-Euler inertia columns (their lower triangle is B's, as ``accel`` reads it);
    ``h`` (n, 1): ``rne(q, qd, 0)`` without Coulomb friction (Coriolis, gravity and viscous
    friction), the torque the stick-slip law of :mod:`model.dynamics.stick_slip` takes from ``G u``.
    ``link_mass_scale``: None (the description's links), or a symbolic factor on every link's mass and
    inertia (centres of mass, rotors and payload unchanged): one compiled plant then serves a sweep over
    link masses, where a scaled description would need a build per value.
    """
    zero = ca.SX.zeros(desc.n, 1)
    gear = np.array([lk.gear_ratio for lk in desc.links])
    B_cols = _inertia_columns_ne(desc, motor_model, q, params, link_mass_scale)
    rigid = rne_sx(desc, motor_model, q, qd, zero, params, with_friction=False, link_mass_scale=link_mass_scale)
    h = rigid + ca.vertcat(*viscous_friction_sx(gear, qd, params.viscous_friction))
    return B_cols, h


def coriolis_ne_sx(desc: RobotDescription, motor_model: str, q: ca.SX, qd: ca.SX, params: SymbolicParameters,
                   B: ca.SX) -> ca.SX:
    """(n, n) Christoffel ``C(q, qd) = 1/2 (Bdot + J - J^T)`` from Newton-Euler passes.

    ``J = d(B(q) v)/dq`` at ``v = qd``, where ``B(q) qd = rne(q, 0, qd)`` without
    gravity and friction (``qd`` enters as an acceleration, so it is
    independent of ``q``), and ``Bdot = sum_k dB/dq_k qd_k`` the forward-mode
    directional derivative of ``B`` (the (n, n) inertia expression in ``q``).
    """
    zero = ca.SX.zeros(desc.n, 1)
    B_qd = rne_sx(desc, motor_model, q, zero, qd, _without_gravity(params), with_friction=False)
    J = ca.jacobian(B_qd, q)
    Bdot = ca.jtimes(B, q, qd)
    return 0.5 * (Bdot + J - J.T)


def _smallest(candidates: dict[str, ca.SX], inputs: list[ca.SX]) -> tuple[str, ca.SX, str]:
    """The candidate expression of fewest operations (after CSE): its name, itself, and a line giving every count."""
    ops = {k: int(ca.Function("candidate", inputs, [ca.densify(ca.cse(e))]).n_instructions())
           for k, e in candidates.items()}
    best = min(ops, key=lambda k: (ops[k], list(ops).index(k)))
    others = ", ".join(f"{k} {v:,}" for k, v in ops.items() if k != best)
    return best, candidates[best], f"{best} ({ops[best]:,} operations{'; ' + others if others else ''})"


def build_functions(desc: RobotDescription, motor_model: str = "reflected") -> DynamicsFunctions:
    """Build the dynamics Functions of ``desc`` (link inertial data baked in as constants)."""
    check_motor_model(motor_model)
    s = _Symbols(desc)
    q, qd, qdd, tau, p, params = s.q, s.qd, s.qdd, s.tau, s.p, s.params
    zero = ca.SX.zeros(desc.n, 1)

    tau_ne = rne_sx(desc, motor_model, q, qd, qdd, params)
    B_cols = _inertia_columns_ne(desc, motor_model, q, params)
    B = ca.tril(B_cols) + ca.tril(B_cols, False).T  # the lower triangle, mirrored: exactly symmetric
    # CRBA, ABA and the recursive C carry rotors as G^2 Jm only; arms of fewer than RECURSIVE_MIN_JOINTS joints
    # keep the Newton-Euler forms (a few dozen operations apart there) and so their numbers bit for bit
    reflected = motor_model == "reflected" and desc.n >= RECURSIVE_MIN_JOINTS
    candidates = {"Newton-Euler columns": B}
    if reflected:
        candidates["composite-rigid-body"] = crba_sx(desc, q, params)
        candidates["composite-rigid-body in frame 0"] = crba_world_sx(desc, q, params)
    name_B, B, said_B = _smallest(candidates, [q, p])
    if name_B != "Newton-Euler columns":
        B_cols = B
    candidates = {"LDL^T of B": _accel_sx(desc, motor_model, s, B_cols=B_cols)}
    if reflected:
        candidates["articulated-body in frame 0"] = aba_world_sx(desc, q, qd, tau - s.friction(qd), params)
    _, qdd_ne, said_A = _smallest(candidates, [q, qd, tau, p])
    g = rne_sx(desc, motor_model, q, zero, zero, params, with_friction=False)
    candidates = {"1/2 (Bdot + J - J^T)": coriolis_ne_sx(desc, motor_model, q, qd, params, B)}
    if reflected:
        candidates["recursive in frame 0"] = coriolis_world_sx(desc, q, qd, params)
    _, C, said_C = _smallest(candidates, [q, qd, p])
    formulations = f"inertia: {said_B}; accel: {said_A}; coriolis: {said_C}"
    F = s.friction(qd)

    d = ca.densify
    return DynamicsFunctions(
        inertia=ca.Function("inertia", [q, p], [d(ca.cse(B))], ["q", "p"], ["B"]),
        coriolis=ca.Function("coriolis", [q, qd, p], [d(ca.cse(C))], ["q", "qd", "p"], ["C"]),
        gravload=ca.Function("gravload", [q, p], [d(ca.cse(g))], ["q", "p"], ["g"]),
        friction=ca.Function("friction", [qd, p], [d(F)], ["qd", "p"], ["F"]),
        rne=ca.Function("rne", [q, qd, qdd, p], [d(ca.cse(tau_ne))], ["q", "qd", "qdd", "p"], ["tau"]),
        accel=ca.Function("accel", [q, qd, tau, p], [d(ca.cse(qdd_ne))], ["q", "qd", "tau", "p"], ["qdd"]),
        description=desc,
        motor_model=motor_model,
        formulations=formulations,
    )


def build_lagrange_functions(desc: RobotDescription, motor_model: str = "reflected") -> LagrangeFunctions:
    """The Lagrange model's Functions (Jacobians, Christoffel symbols, dU/dq): the independent check."""
    check_motor_model(motor_model)
    s = _Symbols(desc)
    q, qd, qdd, tau, p = s.q, s.qd, s.qdd, s.tau, s.p
    lag = lagrange_model(desc, motor_model, q, qd, s.params)
    F = s.friction(qd)
    tau_lag = lag.B @ qdd + lag.C @ qd + lag.g + F
    qdd_lag = ldl_solve_sx(lag.B, tau - lag.C @ qd - lag.g - F)
    d = ca.densify
    return LagrangeFunctions(
        inertia_lagrange=ca.Function("inertia_lagrange", [q, p], [d(lag.B)], ["q", "p"], ["B"]),
        coriolis_lagrange=ca.Function("coriolis_lagrange", [q, qd, p], [d(lag.C)], ["q", "qd", "p"], ["C"]),
        gravload_lagrange=ca.Function("gravload_lagrange", [q, p], [d(lag.g)], ["q", "p"], ["g"]),
        rne_lagrange=ca.Function("rne_lagrange", [q, qd, qdd, p], [d(ca.cse(tau_lag))], ["q", "qd", "qdd", "p"], ["tau"]),
        accel_lagrange=ca.Function("accel_lagrange", [q, qd, tau, p], [d(ca.cse(qdd_lag))], ["q", "qd", "tau", "p"], ["qdd"]),
        energy=ca.Function("energy", [q, qd, p], [d(lag.T), d(lag.U)], ["q", "qd", "p"], ["T", "U"]),
    )
