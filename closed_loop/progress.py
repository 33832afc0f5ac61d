"""Progress of a closed-loop run on a text stream."""

from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["ProgressLine"]


class ProgressLine:
    """Prints ``label: 40 % (t = 6.0 / 15.0 s)`` to a stream every ``every`` of the run."""

    def __init__(self, label: str = "simulate", stream: TextIO | None = None, every: float = 0.1) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.every = every
        self._next = 0.0

    def __call__(self, fraction: float, t: float, t_final: float) -> None:
        if fraction + 1e-12 >= self._next:
            print(f"{self.label}: {100 * fraction:3.0f} % (t = {t:.2f} / {t_final:.2f} s)", file=self.stream, flush=True)
            self._next += self.every
