"""The workspace of the numeric dynamics: buffers of the single-point evaluators, apart from the model.

A :class:`~model.dynamics.core.Dynamics` is a constant model and a
:class:`~model.dynamics.parameters.DynamicsParameters` a constant value; what
changes during a call (input, output and work buffers of the compiled
functions) lives here, as Pinocchio keeps its ``Data`` apart from its
``Model``. A workspace holds no number that outlives a call: results never
depend on which workspace computed them.

One workspace serves one thread at a time. Pass your own to the numeric
methods (``ws=``) in a hot loop; without one, a method borrows one from its
model's pool for the length of the call.
"""

from __future__ import annotations

import numpy as np

from ..codegen import CompiledLibrary, PointEvaluator

__all__ = ["Workspace"]


class Workspace:
    """Single-point evaluators of one compiled library, built on first use of each function.

    Parameters
    ----------
    library
        The compiled library of the model (:meth:`~model.dynamics.core.Dynamics.compile`).
    """

    __slots__ = ("library", "_points")

    def __init__(self, library: CompiledLibrary) -> None:
        self.library = library
        self._points: dict[str, PointEvaluator] = {}

    def __repr__(self) -> str:
        return f"Workspace({sorted(self._points)})"

    def point(self, name: str) -> PointEvaluator:
        """The evaluator of Function ``name`` (its last input, the parameters, read in place)."""
        ev = self._points.get(name)
        if ev is None:
            sig = self.library.signatures[name]
            p_index = len(sig.in_sizes) - 1
            ev = self.library.point_evaluator(name, {p_index: np.zeros(sig.in_sizes[p_index])})
            self._points[name] = ev
        return ev

