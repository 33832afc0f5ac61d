"""A controller delayed by one control period: the loop a Jacobi co-simulation master runs."""

from __future__ import annotations

import numpy as np

from control_design.controllers import Controller
from control_design.reference import Reference

__all__ = ["OnePeriodDelay"]


class OnePeriodDelay(Controller):
    """A controller whose torques reach the plant one control period late.

    ``update`` at ``t_k`` computes the inner controller's torques and returns those
    computed at ``t_k-1`` (at ``t_0`` its own, which are therefore held for two
    periods): the loop a Jacobi co-simulation master such as libcosim's runs.

    Parameters
    ----------
    inner
        The delayed controller (its rate, gear ratios and limits are this one's).
    """

    def __init__(self, inner: Controller) -> None:
        super().__init__(inner.n, inner.rate_hz, inner.G, inner.tau_m_max)
        self.inner = inner
        self.kind = inner.kind
        self._held: np.ndarray | None = None

    def reset(self) -> None:
        self.inner.reset()
        self._held = None

    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        new = self.inner.update(t, q, qd, ref)
        out = new if self._held is None else self._held
        self._held = new
        return out
