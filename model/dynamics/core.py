"""The :class:`Dynamics` of one robot: parameters, symbolic Functions and the fast numeric API.

Numeric methods run compiled C (built on first use, or by :meth:`Dynamics.compile`,
cached on disk by :mod:`model.codegen`); without a C compiler they fall back to
CasADi's own evaluation and warn once.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import threading
import warnings
from functools import cached_property
from pathlib import Path
from typing import Any, Sequence

import casadi as ca
import numpy as np

from ..arrays import finite_vector, shaped_vector
from ..codegen import BuildInfo, CompiledLibrary, CompilerNotFoundError, PointEvaluator, Progress, build_library
from ..description import RobotDescription
from .motors import check_motor_model
from .parameters import ParameterLayout, parameter_layout
from .symbolic import COMPILED_FUNCTIONS, DynamicsFunctions, build_functions

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


def _description_key(description: RobotDescription) -> str:
    """Everything of ``description`` the generated code can depend on (not its name, path or notes)."""
    skip = ("name", "path", "description", "source", "extra", "rest", "links")
    data = {f.name: getattr(description, f.name) for f in dataclasses.fields(description) if f.name not in skip}
    data["links"] = [
        {k: v for k, v in dataclasses.asdict(link).items() if k not in ("name", "qlim", "torque_limit")}
        for link in description.links
    ]
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()


class NoCompilerWarning(RuntimeWarning):
    """No C compiler: the numeric API evaluates with CasADi (correct, but much slower)."""


_F64 = np.dtype(np.float64)


def _shaped(value: Any, size: int, name: str) -> np.ndarray:
    """A joint vector of shape (size,) (see :func:`model.arrays.shaped_vector`); finiteness not checked."""
    return shaped_vector(value, size, name, "joint values")


def _vector(value: Any, size: int, name: str, what: str = "values") -> np.ndarray:
    """A finite, contiguous vector of shape (size,) (see :func:`model.arrays.finite_vector`)."""
    return finite_vector(value, size, name, what)


def _batch(value: Any, n: int, name: str) -> np.ndarray:
    arr = np.ascontiguousarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != n:
        raise ValueError(f"{name}: expected an (N, {n}) array, got shape {np.shape(value)}")
    if not np.all(np.isfinite(arr)):
        rows = np.unique(np.nonzero(~np.isfinite(arr))[0])
        raise ValueError(f"{name}: expected finite values; rows {rows[:5].tolist()} are not")
    return arr


class Dynamics:
    """Dynamic model ``B(q) qdd + C(q, qd) qd + F(qd) + g(q) = tau`` of one robot.

    Parameters
    ----------
    description
        The robot; link inertial data are constants of the generated code.
    motor_model
        ``"reflected"`` (default, Robotics Toolbox) or ``"full"`` (rotors as bodies).

    Notes
    -----
    Payload, friction and gravity are the parameter vector :attr:`p`; change
    them with :meth:`set_payload`, :meth:`set_friction`, :meth:`set_gravity`
    or :meth:`set_parameters` without rebuilding anything. Joint quantities are
    in rad, m and their derivatives; torques in N m (revolute) or N (prismatic).
    """

    def __init__(self, description: RobotDescription, motor_model: str = "reflected") -> None:
        self.description = description
        self.motor_model = check_motor_model(motor_model)
        self.n = description.n
        self.layout: ParameterLayout = parameter_layout(description)
        self._p = self.layout.defaults.copy()
        self._library: CompiledLibrary | None = None
        self._build_info: BuildInfo | None = None
        self._fallback = False
        self._lock = threading.Lock()
        # Per-thread single-point evaluators (buffers are not shareable between threads); replaced on compile.
        self._points = threading.local()

    def __repr__(self) -> str:
        state = "compiled" if self._library else ("casadi" if self._fallback else "not built")
        return f"Dynamics({self.description.name!r}, motor_model={self.motor_model!r}, {state})"

    # ------------------------------------------------------------ parameters
    @property
    def p(self) -> np.ndarray:
        """(np,) copy of the current parameter vector (see :mod:`model.dynamics.parameters`)."""
        return self._p.copy()

    def set_parameters(self, p: Any) -> None:
        """Replace the whole parameter vector (layout :attr:`layout`), checked by the same rules as the setters.

        On a bad value nothing changes and the ValueError names the field.
        """
        p = _vector(p, self.layout.size, "p")
        sl, before = self.layout.slices, self._p
        try:
            self.set_payload(p[sl["payload_mass"]][0], p[sl["payload_com"]], p[sl["payload_inertia"]])
            self.set_friction(p[sl["viscous_friction"]], p[sl["coulomb_friction_pos"]], p[sl["coulomb_friction_neg"]])
            self.set_gravity(p[sl["gravity"]])
        except ValueError as exc:
            self._p = before
            raise ValueError(f"p: {exc}") from None

    def reset_parameters(self) -> None:
        """Back to the description's friction and gravity, no payload."""
        self._p = self.layout.defaults.copy()

    def _set(self, field: str, value: np.ndarray) -> None:
        p = self._p.copy()
        p[self.layout.slices[field]] = value
        self._p = p

    def set_payload(self, mass: float, com: Sequence[float] = (0.0, 0.0, 0.0),
                    inertia: Sequence[float] = (0.0,) * 6) -> None:
        """Rigid payload fixed to frame n.

        Parameters
        ----------
        mass
            kg, >= 0 (0 removes the payload).
        com
            (3,) centre of mass in frame n, m.
        inertia
            (6,) ``[Ixx Iyy Izz Ixy Iyz Ixz]`` about the payload COM, frame-n axes, kg m^2 (zeros: point mass).
        """
        m = float(mass)
        if not np.isfinite(m) or m < 0:
            raise ValueError(f"mass: expected a finite number >= 0 kg, got {m!r}")
        c = _vector(com, 3, "com")
        inertia6 = _vector(inertia, 6, "inertia")
        ixx, iyy, izz, ixy, iyz, ixz = inertia6
        eig = np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))
        if eig[0] < -1e-12 * max(1.0, abs(eig).max()):
            raise ValueError(f"inertia: expected a positive semi-definite inertia, got {inertia6.tolist()} (eigenvalues {eig.tolist()})")
        self._set("payload_mass", np.array([m]))
        self._set("payload_com", c)
        self._set("payload_inertia", inertia6)

    def set_friction(self, viscous: Any = None, coulomb_pos: Any = None, coulomb_neg: Any = None) -> None:
        """Motor-side friction per joint: viscous (N m s/rad, >= 0), Coulomb Tc+ (>= 0) and Tc- (<= 0), N m.

        Arguments left as None keep their current values.
        """
        checks = (
            ("viscous", "viscous_friction", viscous, 1.0, ">= 0"),
            ("coulomb_pos", "coulomb_friction_pos", coulomb_pos, 1.0, ">= 0"),
            ("coulomb_neg", "coulomb_friction_neg", coulomb_neg, -1.0, "<= 0"),
        )
        for name, field, value, sign, expect in checks:
            if value is None:
                continue
            v = _vector(value, self.n, name)
            if np.any(sign * v < 0):
                raise ValueError(f"{name}: expected values {expect}, got {v.tolist()}")
            self._set(field, v)

    def set_gravity(self, gravity: Any) -> None:
        """Gravitational acceleration in the base frame, (3,) m/s^2."""
        self._set("gravity", _vector(gravity, 3, "gravity"))

    # ------------------------------------------------------------- symbolic
    @cached_property
    def functions(self) -> DynamicsFunctions:
        """The named CasADi Functions (inputs ``q``, ``qd``, ``qdd``/``tau``, ``p``); built on first access."""
        return build_functions(self.description, self.motor_model)

    # -------------------------------------------------------------- compile
    @property
    def build_info(self) -> BuildInfo | None:
        """What the last :meth:`compile` did (None before it ran)."""
        return self._build_info

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
        with self._lock:
            if self._library is not None and not force:
                assert self._build_info is not None
                return self._build_info
            key = (f"{_description_key(self.description)}|{self.motor_model}|{','.join(COMPILED_FUNCTIONS)}"
                   f"|{source_fingerprint()}")
            stem = f"{self.description.name}-{self.motor_model}"
            funcs = lambda: [getattr(self.functions, name) for name in COMPILED_FUNCTIONS]  # noqa: E731
            self._library, self._build_info = build_library(stem, key, funcs, force=force, progress=progress)
            self._fallback = False
            self._points = threading.local()
            return self._build_info

    def _backend(self) -> CompiledLibrary | None:
        if self._library is None and not self._fallback:
            try:
                self.compile()
            except CompilerNotFoundError as exc:
                warnings.warn(f"{exc}; evaluating the dynamics with CasADi instead", NoCompilerWarning, stacklevel=3)
                self._fallback = True
        return self._library

    def _eval(self, name: str, inputs: Sequence[np.ndarray], n_points: int) -> np.ndarray:
        """(n_points, numel) first output of Function ``name``; rows are states, matrices column-major."""
        lib = self._backend()
        if lib is not None:
            return lib.evaluate(name, inputs, n_points)[0]
        f: ca.Function = getattr(self.functions, name)
        cols = [a.T if a.ndim == 2 else a for a in inputs]
        out = np.array(f.map(n_points)(*cols) if n_points > 1 else f(*cols))  # (rows, cols * n_points)
        rows, cols_per_point = f.size1_out(0), f.size2_out(0)
        return out.reshape(rows, n_points, cols_per_point).transpose(1, 2, 0).reshape(n_points, -1)

    def _new_point(self, name: str) -> PointEvaluator | None:
        """This thread's :class:`PointEvaluator` of ``name`` (parameter input bound to ``p``); None on the CasADi fallback."""
        lib = self._backend()
        if lib is None:
            return None
        points = self._points
        ev = lib.point_evaluator(name, {len(lib.signatures[name].in_sizes) - 1: self._p})
        setattr(points, name, ev)
        return ev

    def _point(self, name: str, values: tuple[Any, ...], names: tuple[str, ...]) -> np.ndarray:
        """(numel,) first output of Function ``name`` at one point: the joint vectors ``values`` and :attr:`p`.

        Same checks, messages and bits as ``_eval`` on ``_vector`` of each value, without per-call
        allocation: the values are copied into this thread's preallocated buffers (a float64 vector of
        the right shape directly, anything else through ``_shaped``), checked finite at once (a finite
        sum implies finite terms), and on any failure re-checked one by one by ``_vector`` in argument
        order so that the first bad argument raises its usual error. Returns a fresh array.
        """
        ev: PointEvaluator | None = getattr(self._points, name, None)
        if ev is None:
            ev = self._new_point(name)
            if ev is None:
                n = self.n
                return self._eval(name, [*(_vector(v, n, k, "joint values") for v, k in zip(values, names)), self._p], 1)[0]
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
        p = self._p
        if ev.bound[-1] is not p:
            ev.bind(len(ev.bound) - 1, p)
        ev()
        return ev.outputs[0].copy()

    # --------------------------------------------------------------- numeric
    def inertia(self, q: Any) -> np.ndarray:
        """(n, n) joint-space inertia B(q) (motor inertia included)."""
        n = self.n
        return self._point("inertia", (q,), ("q",)).reshape(n, n, order="F")

    def coriolis(self, q: Any, qd: Any) -> np.ndarray:
        """(n, n) Coriolis/centrifugal matrix C(q, qd) (Christoffel symbols of the first kind)."""
        n = self.n
        return self._point("coriolis", (q, qd), ("q", "qd")).reshape(n, n, order="F")

    def gravload(self, q: Any) -> np.ndarray:
        """(n,) gravity torque g(q) (payload included)."""
        return self._point("gravload", (q,), ("q",))

    def friction(self, qd: Any) -> np.ndarray:
        """(n,) friction torque F(qd) the joints must overcome (= -RTB ``Link.friction``)."""
        return self._point("friction", (qd,), ("qd",))

    def rne(self, q: Any, qd: Any, qdd: Any) -> np.ndarray:
        """(n,) joint torques ``B qdd + C qd + g + F`` (Newton-Euler)."""
        return self._point("rne", (q, qd, qdd), ("q", "qd", "qdd"))

    def accel(self, q: Any, qd: Any, tau: Any) -> np.ndarray:
        """(n,) joint accelerations ``B^-1 (tau - C qd - g - F)``."""
        return self._point("accel", (q, qd, tau), ("q", "qd", "tau"))

    def _batch3(self, name: str, A: Any, Bv: Any, Cv: Any, names: tuple[str, str, str]) -> np.ndarray:
        n = self.n
        arrays = [_batch(v, n, k) for v, k in zip((A, Bv, Cv), names)]
        N = arrays[0].shape[0]
        for arr, k in zip(arrays[1:], names[1:]):
            if arr.shape[0] != N:
                raise ValueError(f"{k}: expected {N} rows like {names[0]}, got shape {arr.shape}")
        if N == 0:
            return np.empty((0, n))
        return self._eval(name, [*arrays, self._p], N)

    def rne_batch(self, Q: Any, QD: Any, QDD: Any) -> np.ndarray:
        """(N, n) inverse dynamics of N states given as (N, n) arrays, one compiled call."""
        return self._batch3("rne", Q, QD, QDD, ("Q", "QD", "QDD"))

    def accel_batch(self, Q: Any, QD: Any, TAU: Any) -> np.ndarray:
        """(N, n) forward dynamics of N states given as (N, n) arrays, one compiled call."""
        return self._batch3("accel", Q, QD, TAU, ("Q", "QD", "TAU"))
