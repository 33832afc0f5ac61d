"""The workbench's version, written once: ``pyproject.toml`` reads it at build time (``attr``), and
``manip --version``, the FMU's ``generationTool`` and the benchmarks' headers print it."""

__all__ = ["__version__"]

__version__ = "0.1.0"
