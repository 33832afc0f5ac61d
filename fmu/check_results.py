"""Result types shared by the FMI 2.0 checks (:mod:`fmu.validate`) and their FMI 3.0 twins (:mod:`fmu.validate3`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["FD_LADDER", "RoundTrip"]

#: Rungs of the finite-difference ladder of the directional-derivative checks: steps rel_step x 10^-k.
FD_LADDER = 4


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
