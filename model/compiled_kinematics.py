"""The numeric kinematics of one robot: ``fkine``, ``fkine_all``, ``jacob0``, ``jacobe`` as compiled C.

The CasADi Functions of :mod:`model.kinematics` go through the one code-generation
pipeline, :func:`model.codegen.build_library`, and its on-disk cache, as the
dynamics do (:class:`model.dynamics.Dynamics`): built on first use or by
:meth:`CompiledKinematics.compile`; without a C compiler the same Functions are
evaluated by CasADi, with one :class:`~model.codegen.NoCompilerWarning`.
Single-point calls reuse preallocated buffers; the batch forms
(:meth:`~CompiledKinematics.fkine_batch`, ...) evaluate N configurations in one
C call. Frames and units as in :mod:`model.kinematics`: world frame W, tool frame
E, m and rad, Jacobian rows ``[v; w]``.
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import numpy as np

from .arrays import as_joint_vector, joint_batch
from .codegen import BuildInfo, LazyLibrary, PointEvaluator, Progress, casadi_evaluate
from .description import RobotDescription
from .kinematics import KinematicsFunctions, build_kinematics

__all__ = ["COMPILED_KINEMATICS", "CompiledKinematics"]

#: The kinematic Functions compiled for the numeric API, one translation unit each.
COMPILED_KINEMATICS: tuple[str, ...] = ("fkine", "fkine_all", "jacob0", "jacobe")
_F64 = np.dtype(np.float64)


class CompiledKinematics:
    """Forward kinematics and Jacobians of one robot, compiled on first use; constant once built.

    Parameters
    ----------
    description
        The robot (its geometry, base, tool and tip are constants of the generated code).

    Notes
    -----
    Thread-safe: a call borrows a set of single-point buffers from a pool for its duration.
    """

    def __init__(self, description: RobotDescription) -> None:
        from .dynamics.core import source_fingerprint  # the model sources, as in the dynamics' key

        self.description = description
        self.n = description.n
        key = lambda: (f"kinematics|{description.digest()}|{','.join(COMPILED_KINEMATICS)}"  # noqa: E731
                       f"|{source_fingerprint()}")
        funcs = lambda: [getattr(self.functions, name) for name in COMPILED_KINEMATICS]  # noqa: E731
        self._lazy = LazyLibrary(f"{description.identifier}-kinematics", key, funcs, "the kinematics")
        self._pool: list[dict[str, PointEvaluator]] = []  # idle buffer sets of the current library

    def __repr__(self) -> str:
        return f"CompiledKinematics({self.description.name!r}, {self._lazy.state()})"

    @cached_property
    def functions(self) -> KinematicsFunctions:
        """The named CasADi Functions (input ``q``); built on first access."""
        return build_kinematics(self.description)

    @property
    def build_info(self) -> BuildInfo | None:
        """What the last :meth:`compile` did (None before it ran)."""
        return self._lazy.build_info

    def compile(self, *, force: bool = False, progress: Progress | None = None) -> BuildInfo:
        """Build (or load from the cache) the compiled library of :data:`COMPILED_KINEMATICS`.

        ``force`` and ``progress`` as in :meth:`model.dynamics.Dynamics.compile`. Raises
        :class:`~model.codegen.CompilerNotFoundError` without a C compiler.
        """
        before = self._lazy.library
        info = self._lazy.compile(force=force, progress=progress)
        if self._lazy.library is not before:
            self._pool = []
        return info

    def _point(self, name: str, q: Any) -> np.ndarray:
        """(numel,) output of Function ``name`` at one ``q`` (column-major), a fresh array.

        A float64 (n,) array whose sum is finite (so every entry is) skips the general check of
        :func:`~model.arrays.as_joint_vector`, which every other input, and an overflowing sum, goes through.
        """
        if type(q) is np.ndarray and q.dtype is _F64 and q.shape == (self.n,) and math.isfinite(sum(q.tolist())):
            qv = q
        else:
            qv = as_joint_vector(q, self.n)
        lib = self._lazy.library or self._lazy.backend(stacklevel=3)
        if lib is None:
            return casadi_evaluate(getattr(self.functions, name), [qv], 1)[0]
        pool = self._pool  # a recompile replaces the list: buffers of the old library go back to the old one
        try:
            buffers = pool.pop()
        except IndexError:
            buffers = {}
        try:
            ev = buffers.get(name)
            if ev is None:
                ev = buffers[name] = lib.point_evaluator(name)
            ev.inputs[0][...] = qv
            ev()
            return ev.outputs[0].copy()
        finally:
            pool.append(buffers)

    def _batch(self, name: str, Q: Any) -> tuple[np.ndarray, int]:
        """(N, numel) output of Function ``name`` at the rows of ``Q`` (column-major rows), and N."""
        arr = joint_batch(Q, self.n, "Q")
        N = arr.shape[0]
        if N == 0:
            return np.empty((0, 0)), 0
        lib = self._lazy.backend(stacklevel=3)
        if lib is None:
            return casadi_evaluate(getattr(self.functions, name), [arr], N), N
        return lib.evaluate(name, [arr], N)[0], N

    # ------------------------------------------------------------ one point
    def fkine(self, q: Any) -> np.ndarray:
        """(4, 4) pose ``T_WE`` of the tool frame in the world frame; q (n,) in rad / m."""
        return self._point("fkine", q).reshape(4, 4, order="F")

    def fkine_all(self, q: Any) -> np.ndarray:
        """(n+1, 4, 4) world poses of frame 0 (the base) and of every reported link frame."""
        n = self.n
        return self._point("fkine_all", q).reshape(4, 4 * (n + 1)).T.reshape(n + 1, 4, 4)

    def jacob0(self, q: Any) -> np.ndarray:
        """(6, n) geometric Jacobian of the tool origin, rows [v; w], world-frame axes."""
        return self._point("jacob0", q).reshape(6, self.n, order="F")

    def jacobe(self, q: Any) -> np.ndarray:
        """(6, n) geometric Jacobian of the tool origin, rows [v; w], tool-frame axes."""
        return self._point("jacobe", q).reshape(6, self.n, order="F")

    # --------------------------------------------------------------- batches
    def fkine_batch(self, Q: Any) -> np.ndarray:
        """(N, 4, 4) tool poses ``T_WE`` at the N rows of the (N, n) array ``Q``, one compiled call."""
        out, N = self._batch("fkine", Q)
        return out.reshape(N, 4, 4).transpose(0, 2, 1)

    def fkine_all_batch(self, Q: Any) -> np.ndarray:
        """(N, n+1, 4, 4) world poses of frame 0 and every link frame at the N rows of ``Q``."""
        n = self.n
        out, N = self._batch("fkine_all", Q)
        return out.reshape(N, 4, 4 * (n + 1)).transpose(0, 2, 1).reshape(N, n + 1, 4, 4)

    def jacob0_batch(self, Q: Any) -> np.ndarray:
        """(N, 6, n) world-frame geometric Jacobians at the N rows of the (N, n) array ``Q``."""
        out, N = self._batch("jacob0", Q)
        return out.reshape(N, self.n, 6).transpose(0, 2, 1)

    def jacobe_batch(self, Q: Any) -> np.ndarray:
        """(N, 6, n) tool-frame geometric Jacobians at the N rows of the (N, n) array ``Q``."""
        out, N = self._batch("jacobe", Q)
        return out.reshape(N, self.n, 6).transpose(0, 2, 1)
