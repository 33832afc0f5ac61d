"""Atomic output files: every file the workbench writes appears complete or not at all.

A writer produces its output under a temporary name in the destination's
folder (``.NAME.<random>.tmp.SUFFIX``) and renames it over the destination with
:func:`os.replace`, which is atomic on one file system. An interrupted or
failed write leaves the destination untouched and removes the temporary file.
The file gets the permissions a plain ``open(path, "w")`` would give it: those
of the file it replaces, or ``0o666`` less the process's umask for a new one
(:func:`tempfile.mkstemp` alone would leave it readable by its owner only).
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
import threading
from pathlib import Path
from typing import Iterator

__all__ = ["TEMP_SUFFIX", "atomic_path", "write_atomic"]

#: Mark in the names of the temporary files (``.NAME.<random>.tmp.SUFFIX``): none is left behind after a write.
TEMP_SUFFIX = ".tmp"

_UMASK_LOCK = threading.Lock()


def _plain_mode(path: Path) -> int:
    """Permission bits ``open(path, "w")`` would leave: the existing file's, else 0o666 less the umask."""
    try:
        return stat.S_IMODE(path.stat().st_mode)
    except OSError:
        with _UMASK_LOCK:  # os.umask can only be read by setting it
            umask = os.umask(0o022)
            os.umask(umask)
        return 0o666 & ~umask


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
        os.chmod(tmp, _plain_mode(path))
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
