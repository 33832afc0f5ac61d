"""Linearise the plant about an operating point into a ``control.StateSpace``.

States ``x = [q; qd]``, inputs the motor torques ``u`` (joint torque ``G u``),
outputs chosen by the caller. A and B are exact symbolic Jacobians of the one
plant's ``xdot = ode(x, u, p, m)`` (:mod:`model.plant`) with the friction modes
``m`` held, evaluated at ``(q0, qd0, u0)`` and the robot's parameters.

The modes linearised in: by default the sliding modes, ``m_i = sign(qd0_i)``,
and ``m_i = +1`` where ``qd0_i = 0``. A sliding joint's Coulomb torque ``|G| Tc``
is constant, so its derivative is 0 and only viscous friction enters A: the
small-signal model of a joint that moves, the model the joint-loop designs use.
At rest a joint with Coulomb friction may instead be stuck (the plant's start
and update rules decide it from the torques); ``modes`` with a 0 for that joint
gives the model of the stuck joint (its rows of A and B are zero: it does not
move under small inputs). Neither represents the dead zone of width ``2 |G| Tc``
between them, which no linear model does.

The symbolic plant and its Jacobians are built once per :class:`~model.robot.Robot`
model (kept while its :class:`~model.dynamics.Dynamics` lives, and shared by the robots that
``with_parameters`` makes from it); later calls only evaluate them at the robot's parameters.
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass
from typing import Any, Sequence

import casadi as ca
import control
import numpy as np

from .arm import DynamicArm
from .arrays import as_joint_vector
from .errors import InputError
from .drive_train import drive_layout, equilibrium_state
from .plant import build_plant

__all__ = ["linearise", "OUTPUT_KINDS"]

#: Output groups accepted by :func:`linearise`.
OUTPUT_KINDS: tuple[str, ...] = ("q", "qd", "qm")


@dataclass(frozen=True)
class _Linearisation:
    """The Jacobians of one robot's plant, ``(x, u, p) -> (A, B)``, and the plant's signal names."""

    jacobians: ca.Function
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]


# Keyed by the robot's Dynamics: robots made by ``with_parameters`` share it, and so share the Jacobians.
_BUILT: "weakref.WeakKeyDictionary[Any, _Linearisation]" = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def _linearisation(robot: DynamicArm) -> _Linearisation:
    """The cached :class:`_Linearisation` of ``robot``; built (plant, then exact Jacobians) on first use."""
    with _LOCK:
        built = _BUILT.get(robot.dynamics)
        if built is None:
            plant = build_plant(robot)
            x = ca.SX.sym("x", plant.nx)
            u = ca.SX.sym("u", plant.nu)
            p = ca.SX.sym("p", len(plant.param_names))
            m = ca.SX.sym("m", plant.nz)
            xdot = plant.ode(x, u, p, m)
            jac = ca.Function("linearisation", [x, u, p, m], [ca.jacobian(xdot, x), ca.jacobian(xdot, u)],
                              ["x", "u", "p", "m"], ["A", "B"])
            built = _Linearisation(jac, tuple(plant.state_names), tuple(plant.input_names))
            _BUILT[robot.dynamics] = built
        return built


def _output_matrix(robot: DynamicArm, outputs: str | Sequence[str] | Any) -> tuple[np.ndarray, list[str]]:
    n = robot.n
    G = robot.gear_ratio
    lay = drive_layout(robot.description)
    extra = np.zeros((n, lay.nx - 2 * n))  # the drive-train states: zero columns, but the rotor angles for "qm"
    if isinstance(outputs, str):
        outputs = [outputs]
    if isinstance(outputs, (list, tuple)) and all(isinstance(o, str) for o in outputs):
        blocks, names = [], []
        for kind in outputs:
            zero = np.zeros((n, n))
            if kind == "q":
                blocks.append(np.hstack([np.eye(n), zero, extra]))
            elif kind == "qd":
                blocks.append(np.hstack([zero, np.eye(n), extra]))
            elif kind == "qm":
                row = np.hstack([np.diag(G), zero, extra])
                for k, i in enumerate(lay.elastic):  # behind an elastic gear: the rotor's own angle
                    row[i, :] = 0.0
                    row[i, lay.qm_slice.start + k] = 1.0
                blocks.append(row)
            else:
                raise InputError(f"expected kinds from {OUTPUT_KINDS} or a (ny, {2 * n}) matrix, got {kind!r}",
                                 parameter="outputs")
            names += [f"{kind}[{i}]" for i in range(1, n + 1)]
        if not blocks:
            raise InputError("expected at least one output kind, got an empty list", parameter="outputs")
        return np.vstack(blocks), names
    C = np.atleast_2d(np.asarray(outputs, dtype=float))
    if C.ndim != 2 or C.shape[1] != lay.nx:
        raise InputError(f"expected a (ny, {lay.nx}) output matrix, got shape {np.shape(outputs)}", parameter="outputs")
    return C, [f"y[{i}]" for i in range(1, C.shape[0] + 1)]


def linearise(robot: DynamicArm, q0: Any, qd0: Any = None, u0: Any = None, outputs: str | Sequence[str] | Any = "q",
              modes: Any = None) -> control.StateSpace:
    """Linear model ``dx = A dx + B du``, ``dy = C dx`` of ``robot`` about ``(q0, qd0, u0)`` in friction ``modes``.

    Parameters
    ----------
    robot
        The robot (its motor model and its ``parameters`` are used).
    q0
        (n,) joint positions, rad / m.
    qd0
        (n,) joint velocities, rad/s / m/s; zeros by default.
    u0
        (n,) motor torques, N m; by default those giving zero acceleration at
        ``(q0, qd0)``: ``u0 = rne(q0, qd0, 0) / G``.
    outputs
        A kind from :data:`OUTPUT_KINDS` (``"q"``, ``"qd"``, ``"qm"`` = ``G q``), a
        list of kinds (stacked in order), or an explicit (ny, nx) matrix C (nx = 2n, more with drive trains:
        ``q_m``, ``qd_m`` of each elastic gear, ``tau_m``, ``xi`` of each current loop; ``"qm"`` is then the
        rotor's own angle behind an elastic gear).
    modes
        (n,) friction modes held (+1, -1 sliding, 0 stuck); default the sliding modes of ``qd0``
        (module docstring). A stuck joint needs ``qd0_i = 0``. The rotor behind an elastic gear takes its
        joint's mode (turned by the sign of G); the operating point is the drive trains' equilibrium
        (:func:`model.drive_train.equilibrium_state` for the torques ``G u0``).

    Returns
    -------
    control.StateSpace
        Named states ``q[i]``, ``qd[i]``, inputs ``u[i]`` and outputs; D = 0.
    """
    n = robot.n
    q0v = as_joint_vector(q0, n, "q0")
    qd0v = np.zeros(n) if qd0 is None else as_joint_vector(qd0, n, "qd0")
    G = robot.gear_ratio
    u0v = robot.rne(q0v, qd0v, np.zeros(n)) / G if u0 is None else as_joint_vector(u0, n, "u0")
    C, out_names = _output_matrix(robot, outputs)

    if modes is None:
        m = np.where(qd0v < 0, -1.0, 1.0)
    else:
        m = as_joint_vector(modes, n, "modes")
        if not np.all(np.isin(m, (-1.0, 0.0, 1.0))) or np.any((m == 0) & (qd0v != 0)):
            raise InputError(f"modes: expected -1, 0 or +1 per joint, 0 only where qd0 = 0, got {m.tolist()}")
    lin = _linearisation(robot)
    lay = drive_layout(robot.description)
    x0 = np.concatenate([q0v, qd0v])
    if lay.nx > 2 * n:  # drive trains: gears twisted and loops settled to give G u0, rotors at G qd0
        x0 = equilibrium_state(robot.description, q0v, G * u0v)
        x0[n:2 * n] = qd0v
        x0[lay.qdm_slice] = G[list(lay.elastic)] * qd0v[list(lay.elastic)]
        m = np.concatenate([m, [m[i] if G[i] > 0 else (-m[i] if m[i] != 0 else 0.0) for i in lay.elastic]])
    A, B = (np.array(j) for j in lin.jacobians(x0, u0v, robot.parameters.vector, m))
    D = np.zeros((C.shape[0], n))
    return control.ss(
        A, B, C, D,
        states=list(lin.state_names), inputs=list(lin.input_names), outputs=out_names,
        name=f"{robot.name}_linear",
    )
