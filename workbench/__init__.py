"""The workbench front end: the ``manip`` command line, the end-to-end demo and its report."""

__all__: list[str] = []
