"""Timing shared by the benchmarks: the best wall time of repeated calls."""

from __future__ import annotations

import time
from typing import Callable

__all__ = ["best_time"]


def best_time(run: Callable[[], object], repeat: int = 3) -> float:
    """Best wall time of ``repeat`` calls of ``run``, s."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best
