"""The plant of a robot with drive trains: elastic gears, rotor- or link-side friction with a peak, current loops.

A joint's drive train (robot-file keys in ``docs/robot-file.md``): a motor (rotor
inertia ``Jm``, motor side), a gear of ratio G, rigid (the default: rotor angle
``G q``) or elastic (a spring ``c`` and damper ``d`` on the motor side between
the rotor angle ``q_m`` and ``G q``), friction (viscous ``B``, Coulomb ``Tc`` and
the break-away factor ``peak``) on the rotor or on the joint, and optionally a
current loop that makes the motor torque ``tau_m`` follow the demand ``u``.

Equations (the Modelica Standard Library's ``RobotR3`` drive trains; the robot-file keys and these
equations: ``docs/robot-file.md``, "Drive trains"). With ``tau_s = c (q_m - G q) + d (qd_m - G qd)``:

* arm ``B(q) qdd + h(q, qd) + F_c = tau_j``, ``tau_j = G tau_m`` (rigid) or ``G tau_s`` (elastic);
  an elastic joint's rotor is not part of ``B`` (its ``G^2 Jm`` is not added);
* rotor of an elastic joint ``Jm qdd_m = tau_m - tau_s - B qd_m - F_c,m`` (friction on the rotor
  side) or ``Jm qdd_m = tau_m - tau_s`` (friction on the link side, reflected as ``G^2 B``, ``|G| Tc``);
* current loop (bandwidth ``w``, damping ``D``; with back-EMF when the armature resistance ``R`` is
  stated, ``kb = k^2 / R``, ``k`` the torque constant)::

      xi' = tau_m - u,   tau_m' = -w^2 xi - 2 D w tau_m - 2 D w kb w_m,

  ``w_m`` the rotor speed (``qd_m``, or ``G qd`` for a rigid gear). With ``w_m`` frozen
  ``tau_m / u = w^2 / (s^2 + 2 D w s + w^2)``; these are the MSL motor's ``La.i`` and ``C.v`` scaled:
  ``tau_m = k i_a`` and ``xi = 5 k v_C / (L_a w^2)``.

The generalised coordinates ``[q; q_m]`` (the rotors of the elastic joints appended) carry the
stick-slip law of :mod:`model.dynamics.stick_slip` unchanged: one mode per coordinate, a coordinate
without Coulomb friction never sticks; a stuck coordinate breaks loose at ``peak`` times its Coulomb
torque and slides with the Coulomb torque. State ``x = [q; qd; q_m; qd_m; tau_m; xi]`` (the last
four only for the joints that have them), inputs ``u`` the motor torque demands (N m; with a current
loop ``k i_ref``). The Functions are those of :class:`model.plant.Plant`, for the same fixed-step
rule (``plant_step.c``) and Model Exchange.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from .description import RobotDescription
from .errors import InputError

__all__ = ["DriveLayout", "drive_layout", "drive_substeps", "has_drive_trains", "rigid_arm_description",
           "equilibrium_state"]

#: Largest RK4 step times the fastest drive-train rate (current loop or rotor on its gear spring): 0.25 keeps the
#: step well inside RK4's stability bound (2.78) and its error per step small (~(h w)^5 / 120).
DRIVE_STEP_FACTOR = 0.25


def has_drive_trains(desc: RobotDescription) -> bool:
    """Whether any joint has an elastic gear, a current loop or a friction peak (else the rigid plant serves)."""
    return any(lk.is_elastic or lk.has_current_loop or lk.friction_peak != 1.0 for lk in desc.links)


@dataclass(frozen=True)
class DriveLayout:
    """Where each drive-train state sits in ``x`` (0-based joint indices, state offsets).

    Attributes
    ----------
    n
        Joints.
    elastic, loops
        Joints with an elastic gear, joints with a current loop, in joint order.
    nx, nz
        States ``2 n + 2 len(elastic) + 2 len(loops)``, friction modes ``n + len(elastic)``.
    """

    n: int
    elastic: tuple[int, ...]
    loops: tuple[int, ...]

    @property
    def ne(self) -> int:
        return len(self.elastic)

    @property
    def nc(self) -> int:
        return len(self.loops)

    @property
    def nx(self) -> int:
        return 2 * self.n + 2 * self.ne + 2 * self.nc

    @property
    def nz(self) -> int:
        return self.n + self.ne

    @property
    def qm_slice(self) -> slice:
        return slice(2 * self.n, 2 * self.n + self.ne)

    @property
    def qdm_slice(self) -> slice:
        return slice(2 * self.n + self.ne, 2 * self.n + 2 * self.ne)

    @property
    def tau_slice(self) -> slice:
        o = 2 * self.n + 2 * self.ne
        return slice(o, o + self.nc)

    @property
    def xi_slice(self) -> slice:
        o = 2 * self.n + 2 * self.ne + self.nc
        return slice(o, o + self.nc)

    def state_names(self) -> list[str]:
        """FMI-style names of ``x`` (1-based joint numbers)."""
        n = self.n
        return ([f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)]
                + [f"q_m[{i + 1}]" for i in self.elastic] + [f"qd_m[{i + 1}]" for i in self.elastic]
                + [f"tau_m[{i + 1}]" for i in self.loops] + [f"xi[{i + 1}]" for i in self.loops])

    def motor_state(self, x: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n,), (n,) rotor angles and speeds at ``x``: the states of an elastic joint, ``G q``, ``G qd`` else (rad, rad/s)."""
        n = self.n
        qm, qdm = G * x[:n], G * x[n:2 * n]
        idx = list(self.elastic)
        qm[idx], qdm[idx] = x[self.qm_slice], x[self.qdm_slice]
        return qm, qdm


def drive_layout(desc: RobotDescription) -> DriveLayout:
    """The :class:`DriveLayout` of ``desc``."""
    return DriveLayout(desc.n, tuple(i for i, lk in enumerate(desc.links) if lk.is_elastic),
                       tuple(i for i, lk in enumerate(desc.links) if lk.has_current_loop))


def rigid_arm_description(desc: RobotDescription) -> RobotDescription:
    """``desc`` with the rotor of every elastic joint taken out of the arm (its ``Jm`` a body of its own)."""
    links = tuple(dataclasses.replace(lk, motor_inertia=0.0) if lk.is_elastic else lk for lk in desc.links)
    return dataclasses.replace(desc, links=links)


def drive_terms_sx(desc: RobotDescription, lay: DriveLayout, x: ca.SX, u: ca.SX, B_arm: ca.SX, h_arm: ca.SX,
                   viscous: Any, tc_pos: Any, tc_neg: Any) -> dict[str, Any]:
    """The symbolic pieces of the drive-train plant for :func:`model.plant.build_plant`.

    ``B_arm``, ``h_arm``: the arm's inertia (lower triangle) and ``h`` without the viscous friction of the
    joints whose friction is on the rotor; ``viscous``, ``tc_pos``, ``tc_neg``: the motor-side
    coefficients of ``p`` (n, 1). Returns ``B`` (N, N), ``r`` (N, 1), ``qd`` (N, 1) of the generalised
    coordinates, the Coulomb and break-away limits (N, 1) each, and ``extra`` (the current-loop derivatives).
    """
    n, ne = lay.n, lay.ne
    links = desc.links
    G = np.array([lk.gear_ratio for lk in links], dtype=float)
    q, qd = x[:n], x[n:2 * n]
    qm, qdm = x[lay.qm_slice], x[lay.qdm_slice]
    tau_a, xi = x[lay.tau_slice], x[lay.xi_slice]
    tau_m = [u[i] for i in range(n)]
    for k, i in enumerate(lay.loops):
        tau_m[i] = tau_a[k]
    w_m = [G[i] * qd[i] for i in range(n)]
    for k, i in enumerate(lay.elastic):
        w_m[i] = qdm[k]
    N = n + ne
    B = ca.SX(N, N)
    B[:n, :n] = ca.tril(B_arm)
    r_arm = [G[i] * tau_m[i] for i in range(n)]
    r_rot = []
    for k, i in enumerate(lay.elastic):
        lk = links[i]
        B[n + k, n + k] = lk.motor_inertia
        spring = lk.gear_stiffness * (qm[k] - G[i] * q[i]) + lk.gear_damping * (qdm[k] - G[i] * qd[i])
        r_arm[i] = G[i] * spring
        rot = tau_m[i] - spring
        if lk.friction_side == "motor":
            rot = rot - viscous[i] * qdm[k]
        r_rot.append(rot)
    r = ca.vertcat(ca.vertcat(*r_arm) - h_arm, *r_rot)
    absG = np.abs(G)
    on_rotor = [links[i].is_elastic and links[i].friction_side == "motor" for i in range(n)]
    lim_pos = [0 if on_rotor[i] else absG[i] * tc_pos[i] for i in range(n)] + \
              [tc_pos[i] if on_rotor[i] else 0 for i in lay.elastic]
    lim_neg = [0 if on_rotor[i] else absG[i] * tc_neg[i] for i in range(n)] + \
              [tc_neg[i] if on_rotor[i] else 0 for i in lay.elastic]
    peak = [links[i].friction_peak for i in range(n)] + [links[i].friction_peak for i in lay.elastic]
    tc_p, tc_n = ca.vertcat(*lim_pos), ca.vertcat(*lim_neg)
    hold_p = ca.vertcat(*[peak[j] * lim_pos[j] for j in range(N)])
    hold_n = ca.vertcat(*[peak[j] * lim_neg[j] for j in range(N)])
    extra = []
    for k, i in enumerate(lay.loops):  # d(tau_m), then d(xi) below
        lk = links[i]
        wb, D = lk.current_bandwidth, lk.current_damping
        kb = 0.0 if lk.armature_resistance is None else lk.torque_constant ** 2 / lk.armature_resistance
        extra.append(-wb * wb * xi[k] - 2 * D * wb * tau_a[k] - 2 * D * wb * kb * w_m[i])
    extra += [tau_a[k] - u[i] for k, i in enumerate(lay.loops)]
    return {"B": B, "r": r, "qd": ca.vertcat(qd, qdm), "tc_pos": tc_p, "tc_neg": tc_n, "hold_pos": hold_p,
            "hold_neg": hold_n, "extra": ca.vertcat(*extra) if extra else ca.SX(0, 1), "on_rotor": on_rotor}


def check_drive_trains(desc: RobotDescription, motor_model: str) -> None:
    """InputError if the drive trains cannot be built with ``motor_model`` (elastic gears: ``"reflected"`` only)."""
    if motor_model != "reflected" and any(lk.is_elastic for lk in desc.links):
        raise InputError(f"{desc.name}: an elastic gear needs the 'reflected' motor model (the rotor is a body of "
                         f"its own on the gear's axis), got {motor_model!r}", parameter="motor_model")
    for i, lk in enumerate(desc.links):
        if lk.armature_resistance is not None and lk.torque_constant is None:
            raise InputError(f"{desc.name}, joint {i + 1}: armature_resistance needs torque_constant",
                             parameter="torque_constant")


def equilibrium_state(desc: RobotDescription, q: np.ndarray, g: np.ndarray) -> np.ndarray:
    """(nx,) the static equilibrium at joint positions ``q`` with zero friction torque: the motors hold ``g``.

    ``g`` (n,) is the joint torque that holds the arm at rest at ``q`` (gravity, N m). Every speed is 0,
    each motor gives ``g_i / G_i``, an elastic gear is deflected by ``g_i / (G_i c_i)`` (rotor angle
    ``G_i q_i + g_i / (G_i c_i)``), a current loop is at rest with ``tau_m = g_i / G_i`` and
    ``xi = -2 D tau_m / w`` (the MSL model's initial equations: spring, motor and loop in steady state).
    """
    lay = drive_layout(desc)
    n = desc.n
    G = np.array([lk.gear_ratio for lk in desc.links], dtype=float)
    q = np.asarray(q, dtype=float)
    tau = np.asarray(g, dtype=float) / G
    x = np.zeros(lay.nx)
    x[:n] = q
    for k, i in enumerate(lay.elastic):
        x[lay.qm_slice.start + k] = G[i] * q[i] + tau[i] / desc.links[i].gear_stiffness
    for k, i in enumerate(lay.loops):
        lk = desc.links[i]
        x[lay.tau_slice.start + k] = tau[i]
        x[lay.xi_slice.start + k] = -2.0 * lk.current_damping * tau[i] / lk.current_bandwidth
    return x


def drive_substeps(desc: RobotDescription, dt: float) -> int | None:
    """RK4 sub-steps per control period ``dt`` (s) for the drive trains' fastest rate; None without drive trains.

    The rate: a current loop's bandwidth ``w``, an elastic gear's rotor frequency ``sqrt(c / Jm)`` and its damper's
    ``d / Jm`` (1/s); sub-steps ``ceil(dt max_rate / DRIVE_STEP_FACTOR)``, at least 1.
    """
    rates = []
    for lk in desc.links:
        if lk.has_current_loop:
            rates.append(lk.current_bandwidth)
        if lk.is_elastic:
            rates += [math.sqrt(lk.gear_stiffness / lk.motor_inertia), lk.gear_damping / lk.motor_inertia]
    if not rates:
        return None
    return max(1, math.ceil(dt * max(rates) / DRIVE_STEP_FACTOR - 1e-9))
