"""The :class:`Robot`: one object a user holds, with the Robotics Toolbox's method names.

It owns a validated :class:`~model.description.RobotDescription` and the
CasADi Functions built from it; each method is a thin, shape-checked call into
the module that does the work (kinematics, ik, singularity, dynamics), so the
algorithms stay free functions that can be tested on their own.
"""

from __future__ import annotations

import dataclasses
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from .arrays import as_joint_vector
from .description import RobotDescription
from .loading import load_description
from .errors import InputError
from .point_call import point_call

if TYPE_CHECKING:  # pragma: no cover
    import control

    from .dynamics import Dynamics, DynamicsParameters, Payload, Workspace
    from .ik import IKResult, IKSolution
    from .compiled_kinematics import CompiledKinematics
    from .description import LinkDescription
    from .kinematics import KinematicsFunctions
    from .singularity import SingularityReport

__all__ = ["Robot", "load_robot"]

#: The single calls with a compiled fast path: library ("dynamics" or "kinematics"), joint arguments,
#: and whether the output is a matrix (returned Fortran-ordered, as the checked path returns it).
_FAST_CALLS: dict[str, tuple[str, int, bool]] = {
    "fkine": ("kinematics", 1, True), "jacob0": ("kinematics", 1, True),
    "inertia": ("dynamics", 1, True), "coriolis": ("dynamics", 2, True), "gravload": ("dynamics", 1, False),
    "rne": ("dynamics", 3, False), "accel": ("dynamics", 3, False),
}


def _no_call(*args: Any) -> None:
    """The stand-in where no compiled single call exists: every call takes the checked path."""
    return None


def _as_pose(T: Any) -> np.ndarray:
    arr = np.asarray(T, dtype=float)
    if arr.shape != (4, 4):
        raise InputError(f"expected a (4, 4) homogeneous transform, got shape {arr.shape}", parameter="T")
    return arr


class Robot:
    """A serial manipulator: description, kinematics, inverse kinematics and dynamics.

    Parameters
    ----------
    description
        The validated robot description.
    motor_model
        ``"reflected"`` (Robotics Toolbox convention, default) or ``"full"``
        (rotors as bodies carried by the preceding link); affects dynamics only.

    Notes
    -----
    A Robot is a constant model and one immutable parameter value
    (:attr:`parameters`: payload, friction, gravity; the description's by
    default). :meth:`with_parameters` gives another Robot with other values
    that shares this one's compiled model; nothing changes a Robot's numbers
    after it is made. Two Robots are equal when their descriptions (not the
    path they were read from), motor models and parameters are.
    """

    def __init__(self, description: RobotDescription, motor_model: str = "reflected") -> None:
        if motor_model not in ("reflected", "full"):
            raise InputError(f"expected 'reflected' or 'full', got {motor_model!r}", parameter="motor_model")
        self.description = description
        self.motor_model = motor_model
        self._parameters: "DynamicsParameters | None" = None  # None: the description's
        self._calls: dict[str, Any] = {}  # compiled single calls with these parameters (see _call)

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, n={self.n}, joints={self.description.joint_types!r}, motor_model={self.motor_model!r})"

    def __eq__(self, other: object) -> bool:
        """The same robot: equal descriptions (wherever they were read from), motor model and parameters."""
        if not isinstance(other, Robot):
            return NotImplemented
        if other is self:
            return True
        return (self.motor_model == other.motor_model and self.parameters == other.parameters
                and dataclasses.replace(self.description, path="") == dataclasses.replace(other.description, path=""))

    def __hash__(self) -> int:
        return hash((self.description.digest(), self.motor_model))

    # ------------------------------------------------------------------ basics
    @property
    def name(self) -> str:
        return self.description.name

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.description.n

    @property
    def qlim(self) -> np.ndarray:
        """(2, n) joint limits, rad or m; +-inf where none is stated."""
        return self.description.qlim

    @property
    def q_rest(self) -> np.ndarray:
        """(n,) rest configuration, rad or m."""
        return self.description.q_rest

    @property
    def links(self) -> "tuple[LinkDescription, ...]":
        """The description's links, joint 1 first (frozen: geometry m and rad, mass kg, COM m and
        inertia kg m^2 in link frame i, motor and friction data); read-only."""
        return self.description.links

    @property
    def gear_ratio(self) -> np.ndarray:
        """(n,) reduction ratios G (motor angle = G q)."""
        return np.array([lk.gear_ratio for lk in self.description.links])

    def _q(self, q: Any, name: str = "q") -> np.ndarray:
        return as_joint_vector(q, self.n, name)

    def _call(self, name: str) -> Any:
        """The compiled single call of ``name`` (:mod:`model.point_call`) with this robot's parameters,
        made on first use; :func:`_no_call` where there is none (no compiler, no Python headers).

        It returns the checked path's numbers for arguments it accepts and None for every other
        argument, which the method then hands to the checked path (same errors, same results)."""
        kind, n_args, matrix = _FAST_CALLS[name]
        if kind == "dynamics":
            library, fixed = self.dynamics._backend(), (self.parameters.vector,)
        else:
            lazy = self.compiled_kinematics._lazy
            library, fixed = lazy.library or lazy.backend(stacklevel=3), ()
        call = point_call(library, name, n_args, self.n, fixed, matrix) or _no_call
        self._calls[name] = call
        return call

    # -------------------------------------------------------------- kinematics
    @cached_property
    def compiled_kinematics(self) -> "CompiledKinematics":
        """The numeric kinematics (compiled C, built or loaded from the cache on first use)."""
        from .compiled_kinematics import CompiledKinematics  # CasADi: imported when kinematics is first used

        return CompiledKinematics(self.description)

    @property
    def kinematics(self) -> "KinematicsFunctions":
        """Named CasADi Functions ``fkine``, ``fkine_all``, ``jacob0``, ``jacobe`` (symbolic)."""
        return self.compiled_kinematics.functions

    def fkine(self, q: Any) -> np.ndarray:
        """(4, 4) pose ``T_WE`` of the tool frame in the world frame (base and tool included); q in rad / m."""
        out = (self._calls.get("fkine") or self._call("fkine"))(q)
        return self.compiled_kinematics.fkine(q) if out is None else out

    def fkine_all(self, q: Any) -> np.ndarray:
        """(n+1, 4, 4) world poses of frame 0 (the base) and of every link frame (DH frame i for DH tables)."""
        return self.compiled_kinematics.fkine_all(q)

    def jacob0(self, q: Any) -> np.ndarray:
        """(6, n) geometric Jacobian of the tool origin, rows [v; w], world-frame axes (m/s and rad/s per joint rate)."""
        out = (self._calls.get("jacob0") or self._call("jacob0"))(q)
        return self.compiled_kinematics.jacob0(q) if out is None else out

    def jacobe(self, q: Any) -> np.ndarray:
        """(6, n) geometric Jacobian of the tool origin, rows [v; w], tool-frame axes."""
        return self.compiled_kinematics.jacobe(q)

    def fkine_batch(self, Q: Any) -> np.ndarray:
        """(N, 4, 4) tool poses ``T_WE`` at the N configurations of the (N, n) array ``Q``, one compiled call."""
        return self.compiled_kinematics.fkine_batch(Q)

    def jacob0_batch(self, Q: Any) -> np.ndarray:
        """(N, 6, n) world-frame geometric Jacobians at the N rows of the (N, n) array ``Q``, one compiled call."""
        return self.compiled_kinematics.jacob0_batch(Q)

    # ----------------------------------------------------------- singularities
    def manipulability(self, q: Any, axes: Sequence[bool] | str = "task") -> float:
        """Yoshikawa manipulability ``sqrt(det(J J^T))`` of the rows of ``jacob0`` chosen by ``axes``.

        The default ``"task"`` uses the rows the structure controls (x, y, z, yaw for a SCARA),
        so an arm with fewer than six joints does not read as always singular.
        """
        from .singularity import manipulability

        return manipulability(self, self._q(q), axes)

    def singularities(self, q: Any, tol: float = 1e-6) -> "SingularityReport":
        """Whether ``q`` is singular, why, and the joint motion that loses effect."""
        from .singularity import singularities

        return singularities(self, self._q(q), tol)

    # ------------------------------------------------------ inverse kinematics
    def ikine_a(self, T: Any) -> "list[IKSolution]":
        """Every closed-form IK solution of pose ``T`` (4, 4), each labelled with its branch."""
        from .ik import ikine_a

        return ikine_a(self, _as_pose(T))

    def ikine(self, T: Any, q0: Any = None, mask: Sequence[float] | None = None, **options: Any) -> "IKResult":
        """Numeric IK (Levenberg-Marquardt) of pose ``T``; see :func:`model.ik.ikine` for options."""
        from .ik import ikine

        q0v = None if q0 is None else self._q(q0, "q0")
        return ikine(self, _as_pose(T), q0=q0v, mask=mask, **options)

    # ---------------------------------------------------------------- dynamics
    @cached_property
    def dynamics(self) -> "Dynamics":
        """The dynamic model (symbolic CasADi Functions and compiled C); built on first use."""
        from .dynamics import Dynamics

        return Dynamics(self.description, motor_model=self.motor_model)

    @property
    def parameters(self) -> "DynamicsParameters":
        """This robot's dynamics parameters (payload, friction, gravity): an immutable value."""
        p = self._parameters
        return self.dynamics.parameters if p is None else p

    def with_parameters(self, parameters: "DynamicsParameters") -> "Robot":
        """A Robot with other dynamics parameters, sharing this one's model (and its compiled code).

        ``parameters`` is a :class:`~model.dynamics.DynamicsParameters` of this robot's layout,
        e.g. ``robot.parameters.with_payload(2.0)``; ``self`` is left unchanged.
        """
        p = self.dynamics.check_parameters(parameters)
        other = Robot.__new__(Robot)
        other.__dict__.update(self.__dict__)  # description, motor model, kinematics and the same Dynamics
        other._parameters = p
        other._calls = {}  # bound to the parameters
        return other

    @property
    def payload(self) -> "Payload":
        """The payload of :attr:`parameters`: ``.mass`` kg, ``.com`` (3,) m and ``.inertia`` (3, 3) kg m^2
        about the COM, both in frame n (the tip frame); mass 0 without one. Change it with :meth:`with_payload`."""
        return self.parameters.payload

    def with_payload(self, mass: float, com: Sequence[float] = (0.0, 0.0, 0.0),
                     inertia: Sequence[float] = (0.0,) * 6) -> "Robot":
        """A Robot carrying a rigid payload fixed to frame n (replacing any other), sharing this one's model.

        The immutable counterpart of the Robotics Toolbox's ``robot.payload(m, p)``: ``mass`` kg,
        ``com`` (3,) m in frame n, ``inertia`` (6,) ``[Ixx Iyy Izz Ixy Iyz Ixz]`` about the COM,
        frame-n axes, kg m^2. Same as ``with_parameters(parameters.with_payload(...))``.
        """
        return self.with_parameters(self.parameters.with_payload(mass, com, inertia))

    def inertia(self, q: Any, p: "DynamicsParameters | None" = None, *, ws: "Workspace | None" = None) -> np.ndarray:
        """(n, n) joint-space inertia matrix B(q), kg m^2 / kg, motor inertia included.

        ``p`` (every dynamics method): parameters to use instead of :attr:`parameters`; ``ws``: a
        :class:`~model.dynamics.Workspace` of ``self.dynamics`` for a hot loop.
        """
        if p is None and ws is None:
            out = (self._calls.get("inertia") or self._call("inertia"))(q)
            if out is not None:
                return out
        return self.dynamics.inertia(q, self._parameters if p is None else p, ws=ws)

    def coriolis(self, q: Any, qd: Any, p: "DynamicsParameters | None" = None, *,
                 ws: "Workspace | None" = None) -> np.ndarray:
        """(n, n) Coriolis/centrifugal matrix C(q, qd) from Christoffel symbols."""
        if p is None and ws is None:
            out = (self._calls.get("coriolis") or self._call("coriolis"))(q, qd)
            if out is not None:
                return out
        return self.dynamics.coriolis(q, qd, self._parameters if p is None else p, ws=ws)

    def gravload(self, q: Any, p: "DynamicsParameters | None" = None, *, ws: "Workspace | None" = None) -> np.ndarray:
        """(n,) gravity torque g(q): the joint torque that holds the arm still."""
        if p is None and ws is None:
            out = (self._calls.get("gravload") or self._call("gravload"))(q)
            if out is not None:
                return out
        return self.dynamics.gravload(q, self._parameters if p is None else p, ws=ws)

    def friction(self, qd: Any, p: "DynamicsParameters | None" = None, *, ws: "Workspace | None" = None) -> np.ndarray:
        """(n,) friction torque F(qd) the joints must overcome: G^2 B qd + |G| Tc(sign qd).

        Note the sign: the Robotics Toolbox's ``Link.friction`` returns ``-F``.
        """
        return self.dynamics.friction(qd, self._parameters if p is None else p, ws=ws)

    def rne(self, q: Any, qd: Any, qdd: Any, p: "DynamicsParameters | None" = None, *,
            ws: "Workspace | None" = None) -> np.ndarray:
        """(n,) joint torques for the motion (inverse dynamics), motor and friction terms included."""
        if p is None and ws is None:
            out = (self._calls.get("rne") or self._call("rne"))(q, qd, qdd)
            if out is not None:
                return out
        return self.dynamics.rne(q, qd, qdd, self._parameters if p is None else p, ws=ws)

    def accel(self, q: Any, qd: Any, tau: Any, p: "DynamicsParameters | None" = None, *,
              ws: "Workspace | None" = None) -> np.ndarray:
        """(n,) joint accelerations under joint torques ``tau`` (forward dynamics)."""
        if p is None and ws is None:
            out = (self._calls.get("accel") or self._call("accel"))(q, qd, tau)
            if out is not None:
                return out
        return self.dynamics.accel(q, qd, tau, self._parameters if p is None else p, ws=ws)

    def linearise(self, q0: Any, qd0: Any = None, u0: Any = None,
                  outputs: str | Sequence[str] | Any = "q", modes: Any = None) -> "control.StateSpace":
        """Linear model about ``(q0, qd0, u0)`` as a ``control.StateSpace``, in the plant's friction ``modes``
        (default sliding); see :func:`model.linearise.linearise`.

        The symbolic plant and its Jacobians are built on the first call and reused.
        """
        from .linearise import linearise

        return linearise(self, q0, qd0, u0, outputs, modes)

    def inertia_batch(self, Q: Any, p: "DynamicsParameters | None" = None) -> np.ndarray:
        """(N, n, n) joint-space inertia B(q) at the N rows of the (N, n) array ``Q``, one compiled call."""
        return self.dynamics.inertia_batch(Q, self._parameters if p is None else p)

    def gravload_batch(self, Q: Any, p: "DynamicsParameters | None" = None) -> np.ndarray:
        """(N, n) gravity torque g(q) at the N rows of the (N, n) array ``Q``, one compiled call."""
        return self.dynamics.gravload_batch(Q, self._parameters if p is None else p)

    def rne_batch(self, Q: Any, QD: Any, QDD: Any, p: "DynamicsParameters | None" = None) -> np.ndarray:
        """(N, n) inverse dynamics of N states given as (N, n) arrays."""
        return self.dynamics.rne_batch(Q, QD, QDD, self._parameters if p is None else p)

    def accel_batch(self, Q: Any, QD: Any, TAU: Any, p: "DynamicsParameters | None" = None) -> np.ndarray:
        """(N, n) forward dynamics of N states given as (N, n) arrays."""
        return self.dynamics.accel_batch(Q, QD, TAU, self._parameters if p is None else p)


def load_robot(name_or_path: str | Path, motor_model: str = "reflected") -> Robot:
    """A :class:`Robot` from a built-in name (:data:`model.BUILTIN_ROBOTS`) or a TOML path."""
    return Robot(load_description(name_or_path), motor_model=motor_model)
