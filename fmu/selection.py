"""Scalar names of an FMU resolved to value references (:class:`Selection`), made by
:meth:`fmu.opened.OpenedFmu.select` and taken by :class:`fmu.instance.Instance`."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Selection"]


@dataclass(frozen=True)
class Selection:
    """Scalar names resolved to value references.

    ``vrs``: the distinct value references to pass to a get/set call, in order; ``sizes``: the number of
    values behind each (1 for a scalar, the array's size in FMI 3.0); ``where``: the position of each
    requested name in the concatenated values (``values[where]`` is the request's order).

    >>> sel = Selection(("q[2]", "q[1]"), vrs=(7,), sizes=(2,), where=(1, 0))   # FMI 3.0: one array q
    >>> sel.total, sel.whole
    (2, False)
    """

    names: tuple[str, ...]
    vrs: tuple[int, ...]
    sizes: tuple[int, ...]
    where: tuple[int, ...]

    @property
    def total(self) -> int:
        """Number of values a get call over :attr:`vrs` returns."""
        return int(sum(self.sizes))

    @property
    def whole(self) -> bool:
        """True when the names are whole variables in order (a set call may pass the values as they are)."""
        return self.where == tuple(range(self.total))
