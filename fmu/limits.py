"""The C limits of the FMI wrapper, rendered from the Python constants that the export checks use.

``fmu/c/instance.c`` counts the RK4 sub-steps of one ``DoStep`` with
``MW_MAX_SUBSTEPS`` and ``MW_SUBSTEP_RTOL``; :func:`fmu.variables.substeps` counts
them in Python with :data:`fmu.variables.MAX_SUBSTEPS` and
:data:`fmu.variables.SUBSTEP_RTOL`. The C macros are not written by hand: every
FMU's ``sources/mw_limits.h`` is rendered here from those two constants, so the
two sides cannot drift apart.
"""

from __future__ import annotations

import string
from pathlib import Path

from model.errors import InputError

from .variables import MAX_SUBSTEPS, SUBSTEP_RTOL, TEMPLATE_DIR

__all__ = ["LIMITS_HEADER", "limits_h", "write_limits_h"]

#: The generated header's file name (included by ``fmu/c/instance.h``).
LIMITS_HEADER = "mw_limits.h"


def limits_h() -> str:
    """The text of ``mw_limits.h``: ``MW_MAX_SUBSTEPS`` (sub-steps, an integer) and ``MW_SUBSTEP_RTOL`` (relative)."""
    if not (isinstance(MAX_SUBSTEPS, int) and MAX_SUBSTEPS > 0):
        raise InputError(f"MAX_SUBSTEPS: expected a positive integer, got {MAX_SUBSTEPS!r}", parameter="MAX_SUBSTEPS")
    if not 0.0 < SUBSTEP_RTOL < 1.0:
        raise InputError(f"SUBSTEP_RTOL: expected a number in (0, 1), got {SUBSTEP_RTOL!r}", parameter="SUBSTEP_RTOL")
    template = string.Template((TEMPLATE_DIR / LIMITS_HEADER).read_text())
    return template.substitute(max_substeps=str(MAX_SUBSTEPS), substep_rtol=repr(float(SUBSTEP_RTOL)))


def write_limits_h(folder: Path) -> Path:
    """Write ``mw_limits.h`` into ``folder`` (an FMU's ``sources/``); returns its path."""
    path = Path(folder) / LIMITS_HEADER
    path.write_text(limits_h())
    return path
