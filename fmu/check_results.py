"""Result types shared by the FMI 2.0 checks (:mod:`fmu.validate`) and their FMI 3.0 twins (:mod:`fmu.validate3`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["FD_LADDER", "RoundTrip", "fd_mismatch"]

#: Rungs of the finite-difference ladder of the directional-derivative checks: steps rel_step x 10^-k.
FD_LADDER = 4


def fd_mismatch(ad: np.ndarray, at: Callable[[float], np.ndarray], scale: float, rel_step: float) -> np.ndarray:
    """Per entry, ``min over the ladder of |ad - fd| / (1 + |fd|)``: ``fd`` the Richardson-combined central
    differences (error O(h^4)) of ``at`` (the unknowns with the known moved by h) at h = scale rel_step 10^-k.
    AD is exact, so the best rung (truncation against rounding) is the differences' own accuracy."""
    best = np.full(ad.shape, np.inf)
    for k in range(FD_LADDER):
        h = scale * rel_step * 10.0 ** -k
        fd_h = (at(h) - at(-h)) / (2.0 * h)
        fd_2h = (at(2.0 * h) - at(-2.0 * h)) / (4.0 * h)
        fd = (4.0 * fd_h - fd_2h) / 3.0
        best = np.minimum(best, np.abs(ad - fd) / (1.0 + np.abs(fd)))
    return best


@dataclass(frozen=True)
class RoundTrip:
    """FMU-state round trips of a Co-Simulation run (bit-for-bit comparisons)."""

    steps_before: int
    steps_after: int
    serialized_size: int
    get_set_identical: bool
    deserialized_identical: bool
    me_identical: bool

    @property
    def ok(self) -> bool:
        return self.get_set_identical and self.deserialized_identical and self.me_identical
