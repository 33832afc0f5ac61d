"""The :class:`Dynamics` of one robot: parameters, symbolic Functions and the fast numeric API.

Numeric methods run compiled C (built on first use, or by :meth:`Dynamics.compile`,
cached on disk by :mod:`model.codegen`); without a C compiler they fall back to
CasADi's own evaluation and warn once.
"""

from __future__ import annotations

import hashlib
import math
from functools import cached_property
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..arrays import finite_vector, joint_batch, shaped_vector
from ..codegen import (BuildInfo, CompiledLibrary, CompilerNotFoundError, LazyLibrary, NoCompilerWarning, Progress,
                       casadi_evaluate)
from ..description import RobotDescription
from .motors import check_motor_model
from .parameters import DynamicsParameters, ParameterLayout, parameter_layout
from .singular import singular_dynamics_error, singular_joint
from .symbolic import COMPILED_FUNCTIONS, DynamicsFunctions, build_functions
from .workspace import Workspace
from ..errors import InputError

__all__ = ["Dynamics", "NoCompilerWarning", "source_fingerprint"]


_MODEL_DIR = Path(__file__).resolve().parents[1]


def source_fingerprint() -> str:
    """SHA-256 of the modules that build the symbolic model and its code (``model/*.py``,
    ``model/dynamics/*.py``): editing any of them invalidates cached libraries."""
    h = hashlib.sha256()
    for path in (*sorted(_MODEL_DIR.glob("*.py")), *sorted((_MODEL_DIR / "dynamics").glob("*.py"))):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


_F64 = np.dtype(np.float64)


def _shaped(value: Any, size: int, name: str) -> np.ndarray:
    """A joint vector of shape (size,) (see :func:`model.arrays.shaped_vector`); finiteness not checked."""
    return shaped_vector(value, size, name, "joint values")


def _vector(value: Any, size: int, name: str, what: str = "values") -> np.ndarray:
    """A finite, contiguous vector of shape (size,) (see :func:`model.arrays.finite_vector`)."""
    return finite_vector(value, size, name, what)


class Dynamics:
    """Dynamic model ``B(q) qdd + C(q, qd) qd + F(qd) + g(q) = tau`` of one robot: constant once built.

    Parameters
    ----------
    description
        The robot; link inertial data are constants of the generated code.
    motor_model
        ``"reflected"`` (default, Robotics Toolbox) or ``"full"`` (rotors as bodies).

    Notes
    -----
    Payload, friction and gravity are an explicit, immutable
    :class:`~model.dynamics.parameters.DynamicsParameters` value: every numeric
    method takes one as ``p`` (default :attr:`parameters`, the description's),
    and :meth:`~DynamicsParameters.with_payload` and friends make new values
    without rebuilding anything. Buffers live in a
    :class:`~model.dynamics.workspace.Workspace` (``ws=``; by default one is
    borrowed from this model's pool for the call). Joint quantities are in rad,
    m and their derivatives; torques in N m (revolute) or N (prismatic).
    """

    def __init__(self, description: RobotDescription, motor_model: str = "reflected") -> None:
        self.description = description
        self.motor_model = check_motor_model(motor_model)
        self.n = description.n
        self.layout: ParameterLayout = parameter_layout(description)
        self._defaults = DynamicsParameters.defaults(self.layout)
        key = lambda: (f"{description.digest()}|{self.motor_model}|{','.join(COMPILED_FUNCTIONS)}"  # noqa: E731
                       f"|{source_fingerprint()}")
        funcs = lambda: [getattr(self.functions, name) for name in COMPILED_FUNCTIONS]  # noqa: E731
        self._lazy = LazyLibrary(f"{description.identifier}-{self.motor_model}", key, funcs, "the dynamics")
        # Idle workspaces of the current library, borrowed for one call (list.pop / append are atomic).
        self._pool: list[Workspace] = []

    def __repr__(self) -> str:
        state = self._lazy.state()
        return f"Dynamics({self.description.name!r}, motor_model={self.motor_model!r}, {state})"

    # ------------------------------------------------------------ parameters
    @property
    def parameters(self) -> DynamicsParameters:
        """The description's parameters (no payload, its friction and gravity): the default ``p``."""
        return self._defaults

    def check_parameters(self, p: Any) -> DynamicsParameters:
        """``p`` if it is a :class:`DynamicsParameters` of this model's layout; a ValueError otherwise."""
        if type(p) is DynamicsParameters and p.layout is self.layout:
            return p
        if not isinstance(p, DynamicsParameters):
            raise InputError(f"expected DynamicsParameters (e.g. dynamics.parameters.with_payload(...)), "
                             f"got {type(p).__name__}", parameter="p")
        if p.layout.names != self.layout.names:
            raise InputError(f"expected the parameters of {self.description.name!r} ({self.layout.size} values), "
                             f"got a layout of {p.layout.size}", parameter="p")
        return p

    def workspace(self) -> Workspace:
        """A new :class:`~model.dynamics.workspace.Workspace` of this model (compiles it if needed).

        Raises :class:`~model.codegen.CompilerNotFoundError` without a C compiler.
        """
        if self._backend() is None:
            raise CompilerNotFoundError("no compiled library: a workspace needs the compiled dynamics")
        assert self._library is not None
        return Workspace(self._library)

    # ------------------------------------------------------------- symbolic
    @cached_property
    def functions(self) -> DynamicsFunctions:
        """The named CasADi Functions (inputs ``q``, ``qd``, ``qdd``/``tau``, ``p``); built on first access."""
        return build_functions(self.description, self.motor_model)

    # -------------------------------------------------------------- compile
    @property
    def build_info(self) -> BuildInfo | None:
        """What the last :meth:`compile` did (None before it ran)."""
        return self._lazy.build_info

    def compile(self, *, force: bool = False, progress: Progress | None = None) -> BuildInfo:
        """Build (or load from the cache) the compiled library of the numeric API.

        Parameters
        ----------
        force
            Generate and compile again even if this object or the disk cache has the library.
        progress
            Called with a :class:`~model.codegen.BuildEvent` at each stage (symbolic model,
            C generation with its size, compilation of each unit, link), or once for a cache hit.

        Raises :class:`~model.codegen.CompilerNotFoundError` without a C compiler.
        """
        before = self._lazy.library
        info = self._lazy.compile(force=force, progress=progress)
        if self._lazy.library is not before:
            self._pool = []
        return info

    @property
    def _library(self) -> CompiledLibrary | None:
        return self._lazy.library

    def _backend(self) -> CompiledLibrary | None:
        return self._lazy.backend(stacklevel=3)

    def _eval(self, name: str, inputs: Sequence[np.ndarray], n_points: int) -> np.ndarray:
        """(n_points, numel) first output of Function ``name``; rows are states, matrices column-major."""
        lib = self._backend()
        if lib is not None:
            return lib.evaluate(name, inputs, n_points)[0]
        return casadi_evaluate(getattr(self.functions, name), inputs, n_points)

    def _point(self, name: str, values: tuple[Any, ...], names: tuple[str, ...], p: DynamicsParameters | None,
               ws: Workspace | None) -> np.ndarray:
        """(numel,) first output of Function ``name`` at one point: the joint vectors ``values`` and ``p``.

        Same checks, messages and bits as ``_eval`` on ``_vector`` of each value, without per-call
        allocation: the values are copied into the workspace's preallocated buffers (a float64 vector
        of the right shape directly, anything else through ``_shaped``), checked finite at once (a
        finite sum implies finite terms), and on any failure re-checked one by one by ``_vector`` in
        argument order so that the first bad argument raises its usual error. The parameter vector
        is read in place. Returns a fresh array.
        """
        params = self._defaults if p is None else self.check_parameters(p)
        lib = self._library if self._library is not None else self._backend()
        if lib is None:
            n = self.n
            return self._eval(name, [*(_vector(v, n, k, "joint values") for v, k in zip(values, names)),
                                     params.vector], 1)[0]
        pool: list[Workspace] | None = None
        if ws is None:
            pool = self._pool  # a recompile replaces the list: a workspace of the old library goes back to the old one
            try:
                ws = pool.pop()
            except IndexError:
                ws = Workspace(lib)
        elif ws.library is not lib:
            raise InputError("expected a workspace of this model's current library (make it with workspace())",
                             parameter="ws")
        try:
            ev = ws._points.get(name) or ws.point(name)
            error: Exception | None = None
            try:
                for v, buf, k in zip(values, ev.inputs, names):
                    if type(v) is np.ndarray and v.dtype is _F64 and v.shape == buf.shape:
                        buf[...] = v
                    else:
                        buf[...] = _shaped(v, self.n, k)
                ok = math.isfinite(sum(ev.block.tolist()))
            except Exception as exc:  # noqa: BLE001 - re-raised below in argument order
                error, ok = exc, False
            if not ok:  # raises the error of the first bad argument; a mere overflow of the sum passes
                for v, k in zip(values, names):
                    _vector(v, self.n, k, "joint values")
                if error is not None:
                    raise error
            pv = params.vector
            if ev.bound[-1] is not pv:
                ev.bind(len(ev.bound) - 1, pv)
            ev()
            return ev.outputs[0].copy()
        finally:
            if pool is not None:
                pool.append(ws)

    # --------------------------------------------------------------- numeric
    def inertia(self, q: Any, p: DynamicsParameters | None = None, *, ws: Workspace | None = None) -> np.ndarray:
        """(n, n) joint-space inertia B(q) (motor inertia included); ``p`` default :attr:`parameters`."""
        n = self.n
        return self._point("inertia", (q,), ("q",), p, ws).reshape(n, n, order="F")

    def coriolis(self, q: Any, qd: Any, p: DynamicsParameters | None = None, *,
                 ws: Workspace | None = None) -> np.ndarray:
        """(n, n) Coriolis/centrifugal matrix C(q, qd) (Christoffel symbols of the first kind)."""
        n = self.n
        return self._point("coriolis", (q, qd), ("q", "qd"), p, ws).reshape(n, n, order="F")

    def gravload(self, q: Any, p: DynamicsParameters | None = None, *, ws: Workspace | None = None) -> np.ndarray:
        """(n,) gravity torque g(q) (payload included)."""
        return self._point("gravload", (q,), ("q",), p, ws)

    def friction(self, qd: Any, p: DynamicsParameters | None = None, *, ws: Workspace | None = None) -> np.ndarray:
        """(n,) friction torque F(qd) the joints must overcome (= -RTB ``Link.friction``)."""
        return self._point("friction", (qd,), ("qd",), p, ws)

    def rne(self, q: Any, qd: Any, qdd: Any, p: DynamicsParameters | None = None, *,
            ws: Workspace | None = None) -> np.ndarray:
        """(n,) joint torques ``B qdd + C qd + g + F`` (Newton-Euler)."""
        return self._point("rne", (q, qd, qdd), ("q", "qd", "qdd"), p, ws)

    def accel(self, q: Any, qd: Any, tau: Any, p: DynamicsParameters | None = None, *,
              ws: Workspace | None = None) -> np.ndarray:
        """(n,) joint accelerations ``B^-1 (tau - C qd - g - F)`` (the sliding law of friction: Coulomb 0 at
        ``qd_i = 0``; stick or slip at rest is the plant's, :mod:`model.plant`).

        Raises :class:`~model.dynamics.singular.SingularDynamicsError` (naming the joint and ``q``) where
        B(q) is singular.
        """
        out = self._point("accel", (q, qd, tau), ("q", "qd", "tau"), p, ws)
        if not math.isfinite(sum(out.tolist())):
            self._check_singular(q, p, "")
        return out

    def _check_singular(self, q: Any, p: DynamicsParameters | None, where: str) -> None:
        """Raise :class:`SingularDynamicsError` if B(q) is singular (called where a solve left finite numbers)."""
        qv = _vector(q, self.n, "q", "joint values")
        found = singular_joint(self.inertia(qv, p))
        if found is not None:
            raise singular_dynamics_error(self.description, found[0], qv, where)

    def _batch(self, name: str, values: tuple[Any, ...], names: tuple[str, ...],
               p: DynamicsParameters | None, width: int | None = None) -> np.ndarray:
        """(N, width) output of Function ``name`` (width: its size, default n) at the rows of the (N, n)
        arrays ``values``, one call."""
        params = self.parameters if p is None else self.check_parameters(p)
        n = self.n
        width = n if width is None else width
        arrays = [joint_batch(v, n, k) for v, k in zip(values, names)]
        N = arrays[0].shape[0]
        for arr, k in zip(arrays[1:], names[1:]):
            if arr.shape[0] != N:
                raise InputError(f"expected {N} rows like {names[0]}, got shape {arr.shape}", parameter=k)
        if N == 0:
            return np.empty((0, width))
        return self._eval(name, [*arrays, params.vector], N)

    def inertia_batch(self, Q: Any, p: DynamicsParameters | None = None) -> np.ndarray:
        """(N, n, n) joint-space inertia B(q) at the N rows of the (N, n) array ``Q``, one compiled call."""
        n = self.n
        return self._batch("inertia", (Q,), ("Q",), p, n * n).reshape(-1, n, n).transpose(0, 2, 1)  # rows are column-major

    def gravload_batch(self, Q: Any, p: DynamicsParameters | None = None) -> np.ndarray:
        """(N, n) gravity torque g(q) at the N rows of the (N, n) array ``Q``, one compiled call."""
        return self._batch("gravload", (Q,), ("Q",), p)

    def rne_batch(self, Q: Any, QD: Any, QDD: Any, p: DynamicsParameters | None = None) -> np.ndarray:
        """(N, n) inverse dynamics of N states given as (N, n) arrays, one compiled call."""
        return self._batch("rne", (Q, QD, QDD), ("Q", "QD", "QDD"), p)

    def accel_batch(self, Q: Any, QD: Any, TAU: Any, p: DynamicsParameters | None = None) -> np.ndarray:
        """(N, n) forward dynamics of N states given as (N, n) arrays, one compiled call.

        Raises :class:`~model.dynamics.singular.SingularDynamicsError` naming the first row, its joint and
        ``q`` where B(q) is singular.
        """
        out = self._batch("accel", (Q, QD, TAU), ("Q", "QD", "TAU"), p)
        bad = np.flatnonzero(~np.isfinite(out).all(axis=1))
        for k in bad:
            self._check_singular(joint_batch(Q, self.n, "Q")[k], p, f"row {k} of accel_batch")
        return out
