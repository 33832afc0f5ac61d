"""Each joint seen from its motor: effective inertia, friction and the coupling it must reject.

Joint i of ``B(q) qdd + C(q, qd) qd + F(qd) + g(q) = tau`` (joint side, ``B``
with the rotor term ``G_i^2 Jm_i`` on its diagonal) divided by ``G_i`` and
written in the motor angle ``theta_m = G_i q_i`` reads::

    J_eff_m theta_m'' + B_m theta_m' = tau_m - d_i / G_i

with the motor-side effective inertia ``J_eff_m(q) = B_ii(q) / G_i^2``
(``= Jm_i + B_link,ii(q) / G_i^2``: the rotor plus the link inertia reflected
through the gear), the motor viscous friction ``B_m`` and the joint-side
disturbance ``d_i`` that a decoupled loop ignores::

    d_i = sum_{j != i} B_ij qdd_j            (inertial coupling)
        + (B_ii(q) - G_i^2 J_eff_m) qdd_i      (own inertia away from the design value)
        + (C(q, qd) qd)_i                      (Coriolis / centrifugal)
        + g_i(q)                               (gravity)
        + F_i(qd) - G_i^2 B_m qd_i             (Coulomb friction)

Seen at the motor it is divided by ``|G_i|``: the reduction ratio is what makes
independent-joint control work. All of this is evaluated on the model
(``robot.inertia``, ``robot.coriolis``, ``robot.gravload``, ``robot.friction``
and ``robot.rne_batch``), never by hand.

The inertia range is taken over seeded uniform samples of the joint limits
(unlimited joints: [-pi, pi] rad or [-1, 1] m) plus the reference task's
samples; the design value is the maximum (rule ``"max"``: the designed
bandwidth is then a lower bound over the workspace and the damping too, since
a lighter joint under the same gains is faster and better damped) or the mean.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from model.description import TORQUE_LIMIT_FROM_FILE, TORQUE_LIMIT_FROM_RULE
from model.robot import Robot
from model.trajectory import Trajectory

from .errors import DesignSpecError
from .loops import JointPlant
from .reference import finite_limits

__all__ = [
    "INERTIA_RULES",
    "DEFAULT_SAMPLES",
    "DEFAULT_SEED",
    "TORQUE_LIMIT_FACTOR",
    "TORQUE_LIMIT_RULE",
    "CouplingTorques",
    "JointModel",
    "TorqueLimits",
    "DecoupledModel",
    "sample_configurations",
    "effective_inertia_m",
    "coupling_torques",
    "torque_limits",
    "decoupled_model",
]

INERTIA_RULES = ("max", "mean")
#: Workspace samples for the inertia range and the gravity hold torque.
DEFAULT_SAMPLES = 256
#: Seed of the workspace samples (numpy default_rng).
DEFAULT_SEED = 0
#: Headroom of the torque limit over the reference task's need.
TORQUE_LIMIT_FACTOR = 2.0
TORQUE_LIMIT_RULE = (
    "tau_m_max_i = k Jm_i: a motor's torque rating is taken proportional to its rotor inertia "
    "(one motor family; equal rotors, equal ratings), k chosen so that the most demanding motor has "
    f"{TORQUE_LIMIT_FACTOR:g}x headroom over its need = max(peak |tau_i / G_i| along the reference task "
    "by inverse dynamics, peak |g_i / G_i| over the workspace samples); without rotor data "
    f"{TORQUE_LIMIT_FACTOR:g}x each joint's own need (or the largest need if its own is zero); "
    "a torque_limit stated in the robot file overrides the rule for its motor"
)


def sample_configurations(robot: Robot, n_samples: int = DEFAULT_SAMPLES, seed: int = DEFAULT_SEED) -> np.ndarray:
    """(n_samples, n) configurations drawn uniformly within the joint limits (seeded).

    Unlimited joints are drawn in [-pi, pi] rad or [-1, 1] m.
    """
    if n_samples < 1:
        raise DesignSpecError(f"expected at least 1 workspace sample, got {n_samples!r}", parameter="n_samples")
    lim = finite_limits(robot)
    rng = np.random.default_rng(seed)
    return lim[0] + rng.random((n_samples, robot.n)) * (lim[1] - lim[0])


def effective_inertia_m(robot: Robot, Q: np.ndarray) -> np.ndarray:
    """(N, n) motor-side effective inertia ``B_ii(q) / G_i^2`` (kg m^2) at the (N, n) configurations ``Q``."""
    G2 = robot.gear_ratio ** 2
    return np.array([np.diag(robot.inertia(q)) for q in np.atleast_2d(Q)]) / G2


@dataclass(frozen=True)
class CouplingTorques:
    """Joint-side disturbance of the decoupled model along a motion, by cause (each (N, n), N m or N).

    ``total`` is computed independently from inverse dynamics
    (``rne - G^2 (J_eff_m qdd + B_m qd)``) and equals the sum of the parts.
    """

    t: np.ndarray
    inertial: np.ndarray
    inertia_variation: np.ndarray
    coriolis: np.ndarray
    gravity: np.ndarray
    friction: np.ndarray
    total: np.ndarray

    def parts_sum(self) -> np.ndarray:
        """(N, n) sum of the five parts (a check on ``total``)."""
        return self.inertial + self.inertia_variation + self.coriolis + self.gravity + self.friction

    def peak(self) -> dict[str, np.ndarray]:
        """Per-joint max |.| of every part and of the total, joint side."""
        return {name: np.max(np.abs(getattr(self, name)), axis=0)
                for name in ("inertial", "inertia_variation", "coriolis", "gravity", "friction", "total")}


def coupling_torques(robot: Robot, traj: Trajectory, J_eff_m: np.ndarray) -> CouplingTorques:
    """The joint-side disturbance of the decoupled model along the samples of ``traj``.

    Parameters
    ----------
    robot
        The model.
    traj
        Motion (its samples ``t, q, qd, qdd`` are used).
    J_eff_m
        (n,) motor-side inertias the decoupled loops assume, kg m^2.
    """
    G = robot.gear_ratio
    G2 = G * G
    B_m = robot.parameters.viscous_friction
    N, n = traj.q.shape
    parts = {k: np.zeros((N, n)) for k in ("inertial", "inertia_variation", "coriolis", "gravity", "friction")}
    for k in range(N):
        q, qd, qdd = traj.q[k], traj.qd[k], traj.qdd[k]
        B = robot.inertia(q)
        diag = np.diag(B)
        parts["inertial"][k] = B @ qdd - diag * qdd
        parts["inertia_variation"][k] = (diag - G2 * J_eff_m) * qdd
        parts["coriolis"][k] = robot.coriolis(q, qd) @ qd
        parts["gravity"][k] = robot.gravload(q)
        parts["friction"][k] = robot.friction(qd) - G2 * B_m * qd
    total = robot.rne_batch(traj.q, traj.qd, traj.qdd) - G2 * (J_eff_m * traj.qdd + B_m * traj.qd)
    return CouplingTorques(t=np.array(traj.t), total=total, **parts)


@dataclass(frozen=True)
class TorqueLimits:
    """Per-motor torque limits and where they come from (N m, motor side).

    Attributes
    ----------
    tau_m_max
        (n,) the limits.
    tau_m_peak_task
        (n,) peak |tau_i / G_i| along the reference task.
    tau_m_hold
        (n,) peak |g_i / G_i| over the workspace samples.
    source
        (n,) where each limit comes from: :data:`~model.description.TORQUE_LIMIT_FROM_FILE`
        (the robot file's ``torque_limit``) or :data:`~model.description.TORQUE_LIMIT_FROM_RULE`.
    file
        Name of the robot file (no folder), or "".
    rule
        The rule in words.
    """

    tau_m_max: np.ndarray
    tau_m_peak_task: np.ndarray
    tau_m_hold: np.ndarray
    source: tuple[str, ...] = ()
    file: str = ""
    rule: str = TORQUE_LIMIT_RULE

    def provenance(self, i: int, detail: bool = False) -> str:
        """Where motor ``i``'s (0-based) limit comes from, in words: "robot file scara.toml" or "default rule";
        ``detail``: the rule's headroom added (a console line that stands alone)."""
        if self.source and self.source[i] == TORQUE_LIMIT_FROM_FILE:
            return f"{TORQUE_LIMIT_FROM_FILE} {self.file}".rstrip() + (" (its torque_limit)" if detail else "")
        return TORQUE_LIMIT_FROM_RULE + (f" ({TORQUE_LIMIT_FACTOR:g}x headroom over the reference task's need; "
                                         "the robot file rates no motor)" if detail else "")

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict: the limits, their sources, the needs they were sized on, the rule."""
        return {"tau_m_max": self.tau_m_max.tolist(), "source": list(self.source),
                "provenance": [self.provenance(i, detail=True) for i in range(self.tau_m_max.size)],
                "tau_m_peak_task": self.tau_m_peak_task.tolist(), "tau_m_hold": self.tau_m_hold.tolist(),
                "rule": self.rule}


def torque_limits(robot: Robot, reference: Trajectory, Q_workspace: np.ndarray,
                  factor: float = TORQUE_LIMIT_FACTOR) -> TorqueLimits:
    """Default per-motor torque limits by :data:`TORQUE_LIMIT_RULE`.

    Parameters
    ----------
    robot
        The model (exact, no payload).
    reference
        The reference task.
    Q_workspace
        (N, n) workspace samples for the gravity hold torque.
    factor
        Headroom factor (default 2).
    """
    aG = np.abs(robot.gear_ratio)
    peak = np.max(np.abs(robot.rne_batch(reference.q, reference.qd, reference.qdd)), axis=0) / aG
    hold = np.max(np.abs(np.array([robot.gravload(q) for q in Q_workspace])), axis=0) / aG
    need = np.maximum(peak, hold)
    Jm = np.array([lk.motor_inertia for lk in robot.description.links])
    if np.all(Jm > 0):
        limit = factor * float(np.max(need / Jm)) * Jm
    else:
        fallback = float(np.max(need)) if np.max(need) > 0 else 1.0
        limit = factor * np.where(need > 0, need, fallback)
    desc = robot.description
    stated = [lk.torque_limit for lk in desc.links]
    limit = np.array([rule if rated is None else rated for rule, rated in zip(limit, stated)])
    return TorqueLimits(tau_m_max=limit, tau_m_peak_task=peak, tau_m_hold=hold,
                        source=tuple(desc.torque_limit_source(i) for i in range(desc.n)),
                        file=Path(desc.path).name if desc.path else "")


@dataclass(frozen=True)
class JointModel:
    """Decoupled motor-side model of one joint.

    Attributes
    ----------
    index, name, unit
        0-based joint index, name, unit of q ('rad' or 'm').
    G
        Reduction ratio.
    Jm, B_m
        Rotor inertia (kg m^2) and motor viscous friction (N m s/rad).
    J_eff_m_min, J_eff_m_mean, J_eff_m_max
        Range of ``B_ii(q) / G^2`` over the samples, kg m^2.
    J_eff_m
        The design value (by ``rule``).
    rule
        'max' or 'mean'.
    coupling_peak_j
        Peak joint-side disturbance along the reference task by cause (see :class:`CouplingTorques`), N m or N.
    gravity_workspace_j
        Peak |g_i| over the workspace samples, N m or N.
    """

    index: int
    name: str
    unit: str
    G: float
    Jm: float
    B_m: float
    J_eff_m_min: float
    J_eff_m_mean: float
    J_eff_m_max: float
    J_eff_m: float
    rule: str
    coupling_peak_j: dict[str, float]
    gravity_workspace_j: float

    @property
    def coupling_tau_m(self) -> float:
        """Peak total disturbance at the motor along the reference task, N m (joint side / |G|)."""
        return self.coupling_peak_j["total"] / abs(self.G)

    def plant(self) -> JointPlant:
        """The decoupled plant ``1 / (J_eff_m s^2 + B_m s)`` used for the design."""
        return JointPlant(J_m=self.J_eff_m, B_m=self.B_m, G=self.G, name=self.name, unit=self.unit)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict (motor-side values, and the coupling both joint and motor side)."""
        return {
            "name": self.name, "unit": self.unit, "G": self.G, "Jm": self.Jm, "B_m": self.B_m,
            "J_eff_m": {"min": self.J_eff_m_min, "mean": self.J_eff_m_mean, "max": self.J_eff_m_max,
                        "design": self.J_eff_m, "rule": self.rule},
            "coupling_peak_j": self.coupling_peak_j,
            "coupling_peak_m": {k: v / abs(self.G) for k, v in self.coupling_peak_j.items()},
            "gravity_workspace_j": self.gravity_workspace_j,
            "gravity_workspace_m": self.gravity_workspace_j / abs(self.G),
        }


@dataclass(frozen=True)
class DecoupledModel:
    """The decoupled models of all joints of a robot, with the data they were derived from."""

    robot: str
    joints: tuple[JointModel, ...]
    n_samples: int
    seed: int
    coupling: CouplingTorques
    limits: TorqueLimits
    reference_name: str

    def plants(self) -> list[JointPlant]:
        """One :class:`JointPlant` per joint (design inertias)."""
        return [j.plant() for j in self.joints]

    @property
    def J_eff_m(self) -> np.ndarray:
        """(n,) design inertias, kg m^2."""
        return np.array([j.J_eff_m for j in self.joints])

    @property
    def B_m(self) -> np.ndarray:
        """(n,) motor viscous friction, N m s/rad."""
        return np.array([j.B_m for j in self.joints])


def decoupled_model(robot: Robot, reference: Trajectory, n_samples: int = DEFAULT_SAMPLES, seed: int = DEFAULT_SEED,
                    rule: str = "max", reference_name: str = "") -> DecoupledModel:
    """Derive every joint's decoupled model from the robot's dynamics.

    Parameters
    ----------
    robot
        The model.
    reference
        The reference task (its samples join the workspace samples for the inertia range,
        and the coupling and torque limits are measured along it).
    n_samples, seed
        Workspace samples within the joint limits.
    rule
        Design inertia: 'max' (default) or 'mean' of the range.
    reference_name
        Name of the reference task, for reports.

    Raises
    ------
    DesignSpecError
        Unknown rule.
    """
    if rule not in INERTIA_RULES:
        raise DesignSpecError(f"expected one of {', '.join(INERTIA_RULES)}, got {rule!r}", parameter="rule")
    Q = sample_configurations(robot, n_samples, seed)
    J_all = effective_inertia_m(robot, np.vstack([Q, reference.q]))
    J_min, J_mean, J_max = J_all.min(axis=0), J_all.mean(axis=0), J_all.max(axis=0)
    J_design = J_max if rule == "max" else J_mean
    coupling = coupling_torques(robot, reference, J_design)
    peaks = coupling.peak()
    g_ws = np.max(np.abs(np.array([robot.gravload(q) for q in Q])), axis=0)
    limits = torque_limits(robot, reference, Q)
    B_m = robot.parameters.viscous_friction
    joints = []
    for i, link in enumerate(robot.description.links):
        joints.append(JointModel(
            index=i, name=link.name or f"joint{i + 1}", unit="rad" if link.is_revolute else "m",
            G=float(link.gear_ratio), Jm=float(link.motor_inertia), B_m=float(B_m[i]),
            J_eff_m_min=float(J_min[i]), J_eff_m_mean=float(J_mean[i]), J_eff_m_max=float(J_max[i]),
            J_eff_m=float(J_design[i]), rule=rule,
            coupling_peak_j={k: float(v[i]) for k, v in peaks.items()},
            gravity_workspace_j=float(g_ws[i]),
        ))
    if any(not (math.isfinite(j.J_eff_m) and j.J_eff_m > 0) for j in joints):
        bad = next(j for j in joints if not (math.isfinite(j.J_eff_m) and j.J_eff_m > 0))
        raise DesignSpecError(f"robot {robot.name!r}: joint {bad.name} has effective inertia {bad.J_eff_m!r}; expected > 0")
    return DecoupledModel(robot=robot.name, joints=tuple(joints), n_samples=n_samples, seed=seed,
                          coupling=coupling, limits=limits, reference_name=reference_name or reference.name)
