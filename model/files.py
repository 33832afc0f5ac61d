"""Atomic output files: every file the workbench writes appears complete or not at all.

A writer produces its output under a temporary name in the destination's
folder (``.NAME.<random>.tmp.SUFFIX``) and renames it over the destination with
:func:`os.replace`, which is atomic on one file system. An interrupted or
failed write leaves the destination untouched and removes the temporary file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator

__all__ = ["TEMP_SUFFIX", "atomic_path", "write_atomic"]

#: Mark in the names of the temporary files (``.NAME.<random>.tmp.SUFFIX``): none is left behind after a write.
TEMP_SUFFIX = ".tmp"


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it to ``path``, else delete it.

    The temporary name ends with the destination's suffix, so writers that choose
    their format by the suffix (``Figure.savefig``, Pillow) write the right one.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=TEMP_SUFFIX + path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_atomic(path: str | os.PathLike[str], data: str | bytes) -> Path:
    """Write ``data`` (text as UTF-8, or bytes) to ``path`` through a temporary file and a rename."""
    path = Path(path)
    with atomic_path(path) as tmp:
        if isinstance(data, bytes):
            tmp.write_bytes(data)
        else:
            tmp.write_text(data, encoding="utf-8")
    return path
