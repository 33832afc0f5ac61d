"""The reference an FMU is compared with: the one plant (:mod:`model.plant`) under the computed-torque
feed-forward of the robot's task, advanced by its fixed-step rule (:mod:`model.compiled_plant`).

* :func:`feedforward_profile`: the motor torques (a :class:`TorqueProfile`, piecewise constant);
* :func:`plant_states` and :func:`reference_response`: the plant's states under them, from
  :func:`start_state` (where the FMU starts), at the FMU's internal step / :data:`REFERENCE_REFINEMENT`;
* :func:`divergence_horizon`: how long the open-loop arm keeps a perturbation below :data:`DIVERGENCE_GAIN`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from model.errors import InputError

from .variables import substeps

__all__ = ["DIVERGENCE_GAIN", "REFERENCE_REFINEMENT", "TorqueProfile", "divergence_horizon", "feedforward_profile",
           "plant_states", "reference_response", "start_state"]

#: The reference is the plant's fixed-step rule at the FMU's internal step divided by this: RK4's error,
#: O(h^4), is then 8^4 = 4096 times smaller than the FMU's, below what the Co-Simulation check resolves.
REFERENCE_REFINEMENT = 8
#: The comparison horizon ends where the open-loop arm amplifies a perturbation of its state this much:
#: beyond it a tolerance-sized difference grows into anything and a comparison says nothing.
DIVERGENCE_GAIN = 1e3


@dataclass(frozen=True)
class TorqueProfile:
    """Piecewise-constant motor torques: ``tau_m[i]`` (N m, motor side) holds on ``[t_switch[i], t_switch[i+1])``."""

    t_switch: np.ndarray
    tau_m: np.ndarray
    t_end: float
    q_plan: np.ndarray  # (K + 1, n) planned joint positions at t_switch and t_end
    description: str

    def at(self, t: float) -> np.ndarray:
        """The torques held at time ``t``."""
        i = int(np.searchsorted(self.t_switch, t + 1e-12 * max(1.0, abs(t)), side="right")) - 1
        return self.tau_m[min(max(i, 0), self.tau_m.shape[0] - 1)]

    @property
    def hold(self) -> float:
        return float(self.t_switch[1] - self.t_switch[0]) if self.t_switch.size > 1 else self.t_end


def feedforward_profile(robot: Any, t_end: float = 3.0, hold: float = 0.01) -> TorqueProfile:
    """Computed-torque feed-forward of the robot's task, held for ``hold`` s at a time.

    A robot whose file has ``[[tasks]]`` follows its first task from the start
    (the SCARA: the seed's pick-and-place, first segment rest to above the pick
    point in 3 s); other robots a quintic from rest, +0.5 rad or m per joint
    (within the limits). Motor torques are ``robot.rne(q, qd, qdd) / G`` at the
    middle of each hold interval.
    """
    from model.tasks import robot_tasks
    from model.trajectory import jtraj

    k = int(round(t_end / hold))
    if k < 1 or abs(k * hold - t_end) > 1e-9 * t_end:
        raise InputError(f"expected a whole number of hold intervals of {hold} s, got {t_end}", parameter="t_end")
    tasks = robot_tasks(robot.description)
    if tasks:
        task = next(iter(tasks.values()))
        traj = task.trajectory(dt=0.01)
        what = f"task {task.name!r} of the robot file, from its start"
    else:
        lo, hi = robot.qlim
        q0 = robot.q_rest
        q1 = np.clip(q0 + 0.5, lo, hi)
        traj = jtraj(q0, q1, T=t_end, dt=hold)
        what = "quintic from rest, +0.5 per joint"
    t_switch = np.arange(k) * hold
    t_mid = t_switch + 0.5 * hold
    samples = [traj.sample(float(t)) for t in t_mid]
    Q, QD, QDD = (np.array([s[j] for s in samples]) for j in range(3))
    tau = robot.rne_batch(Q, QD, QDD)
    q_plan = np.array([traj.sample(float(t))[0] for t in np.append(t_switch, t_end)])
    return TorqueProfile(t_switch, tau / robot.gear_ratio, float(t_end), q_plan,
                         f"{what}: computed-torque feed-forward, held {hold * 1e3:g} ms")


def start_state(robot: Any) -> np.ndarray:
    """(nx,) the state the robot's plant FMU starts in: ``[q_rest, 0]`` (rad or m, rad/s or m/s) for a rigid
    arm, the static equilibrium at ``q_rest`` (:func:`model.drive_train.equilibrium_state`, the plant's
    ``x0``) for one with drive trains, its states ``[q, qd, q_m, qd_m, tau_motor, xi]``."""
    from model.drive_train import equilibrium_state, has_drive_trains

    desc = robot.description
    if not has_drive_trains(desc):
        return np.concatenate([robot.q_rest, np.zeros(robot.n)])
    return equilibrium_state(desc, desc.q_rest, np.asarray(robot.gravload(desc.q_rest), dtype=float))


def plant_states(robot: Any, t: np.ndarray, tau_m: np.ndarray, sub_step: float, p: np.ndarray | None = None,
                 x0: np.ndarray | None = None) -> np.ndarray:
    """(len(t), nx) states of the one plant at the times ``t`` under its inputs ``tau_m[k]`` (N m, the motor
    torques or torque demands) held on ``[t_k, t_k+1]``; ``q`` and ``qd`` are the first 2n columns.

    ``robot``'s plant (:mod:`model.plant`, parameters ``p``, default the robot's) is advanced by its
    fixed-step rule (:mod:`model.compiled_plant`) over each interval in sub-steps of at most ``sub_step``
    s (counted as the FMU counts them, :func:`fmu.variables.substeps`) from ``x0`` (default
    :func:`start_state`, where the FMU starts; nx = 2n for a rigid arm, more with drive trains). The
    modes start as an importer starts the FMU: the first torques set before initialisation ends. Rows
    after a divergence are NaN.
    """
    from model.compiled_plant import compiled_plant

    run = compiled_plant(robot).run(robot.parameters.vector if p is None else p)
    x_start = start_state(robot) if x0 is None else np.asarray(x0, dtype=float)
    X = np.full((len(t), run.x.size), np.nan)
    try:
        run.start(x_start, tau_m[0])
        X[0] = run.x
        for k in range(len(t) - 1):
            h = float(t[k + 1] - t[k])
            if not run.advance(tau_m[k], h, substeps(h, sub_step)):
                break
            X[k + 1] = run.x
    finally:
        run.close()
    return X


def reference_response(robot: Any, profile: TorqueProfile, p: np.ndarray | None = None,
                       x0: np.ndarray | None = None, internal_step: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """The one plant under ``profile``: times ``t_switch`` and ``t_end``, and the states there, by
    :func:`plant_states` at ``internal_step / REFERENCE_REFINEMENT``."""
    t = np.append(profile.t_switch, profile.t_end)
    return t, plant_states(robot, t, profile.tau_m, internal_step / REFERENCE_REFINEMENT, p=p, x0=x0)


def divergence_horizon(robot: Any, profile: TorqueProfile, X_ref: np.ndarray, delta: float = 1e-6,
                       internal_step: float = 1e-3) -> float:
    """Time (s, a switching time of ``profile``) until which the open-loop arm amplifies a perturbation
    of its initial joint positions at most :data:`DIVERGENCE_GAIN` times.

    The reference is integrated again from ``x0 + delta`` on every position (rad or m; positions,
    so that joints at rest stay at rest and stuck; an elastic gear's rotor turned with its link) and
    compared with ``X_ref`` on the links' ``q`` and ``qd`` (its first 2n columns); the horizon is the
    last switching time before the difference exceeds ``DIVERGENCE_GAIN * delta`` (the whole
    profile if it never does).
    """
    from model.drive_train import drive_layout

    n = robot.n
    lay = drive_layout(robot.description)
    x0 = X_ref[0].copy()
    x0[:n] += delta
    # an elastic gear's rotor turns with its link (G delta): the spring keeps its deflection, as it does on a rigid gear
    x0[lay.qm_slice] += np.asarray(robot.gear_ratio, dtype=float)[list(lay.elastic)] * delta
    t, X = reference_response(robot, profile, x0=x0, internal_step=internal_step)
    gain = np.max(np.abs(X[:, :2 * n] - X_ref[:, :2 * n]), axis=1) / delta
    beyond = np.flatnonzero(gain > DIVERGENCE_GAIN)
    return float(t[-1] if beyond.size == 0 else t[max(int(beyond[0]) - 1, 0)])
