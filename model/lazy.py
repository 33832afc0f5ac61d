"""Lazy package exports (PEP 562): a package's ``__init__`` names what it exports and the submodule of each.

A name is imported from its submodule on first use and then kept in the package, so that
``import model`` (and ``manip robots``, ``manip --help``) reads no heavy layer: CasADi,
python-control, matplotlib, FMPy and Dask are imported by the submodules that use them, when
they are used. ``from model import Robot`` and ``model.Robot`` work as with eager imports; a
submodule is reachable as an attribute (``closed_loop.sweep``) as it was when every submodule
was imported by the package.
"""

from __future__ import annotations

import importlib
import importlib.util
from typing import Any, Callable, Mapping, Sequence

__all__ = ["export_names", "lazy_exports"]


def export_names(exports: Mapping[str, Sequence[str]]) -> list[str]:
    """The package's ``__all__``: every name of ``exports`` (submodule -> names), sorted."""
    return sorted(name for names in exports.values() for name in names)


def lazy_exports(package: str, exports: Mapping[str, Sequence[str]]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package`` whose names come from submodules.

    Parameters
    ----------
    package
        The package's ``__name__``.
    exports
        Submodule (relative, e.g. ``"robot"`` or ``"dynamics.core"``) -> the names it exports.

    Raises
    ------
    ValueError
        A name is exported by two submodules.
    """
    where: dict[str, str] = {}
    for module, names in exports.items():
        for name in names:
            if name in where:
                raise ValueError(f"{package}: {name!r} is exported by both .{where[name]} and .{module}")
            where[name] = module
    namespace = importlib.import_module(package).__dict__

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is not None:
            value = getattr(importlib.import_module(f".{module}", package), name)
        elif not name.startswith("_") and importlib.util.find_spec(f"{package}.{name}") is not None:
            value = importlib.import_module(f".{name}", package)  # a submodule, as an attribute
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *where})

    return __getattr__, __dir__
