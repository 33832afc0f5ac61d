"""Where the commands write: output paths checked before any work, files written atomically.

:func:`check_out_dir` and :func:`out_file` run first in every command that writes,
so that a read-only or misspelt ``--out`` / ``-o`` is refused in one line before
minutes of work; :func:`write_json` and :func:`save_figure` go through
:func:`model.files.atomic_path`, so an interrupted command leaves no half file.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from model.files import atomic_path, write_atomic

from .args import UsageError

__all__ = ["check_out_dir", "out_dir", "out_file", "save_figure", "write_json"]


def _check_writable(folder: Path, flag: str, shown: Path) -> None:
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".manip-probe-")
    except OSError as exc:
        raise UsageError(f"{flag}: cannot write to {str(shown)!r}: {exc.strerror or exc}") from None
    os.close(fd)
    os.unlink(probe)


def _named(path: str | os.PathLike[str], flag: str, what: str) -> Path:
    """``path`` as a Path, unless it is empty or holds a NUL byte (no file system has such a name)."""
    text = os.fspath(path)
    if not str(text).strip() or "\0" in str(text):
        raise UsageError(f"{flag}: expected {what}, got {str(text)!r}")
    return Path(text)


def check_out_dir(path: str | os.PathLike[str], flag: str = "--out") -> Path:
    """Check, creating nothing, that the folder ``path`` exists and is writable or can be created.

    Commands call this before their work, so that a refused request leaves no
    empty output folder behind, and :func:`out_dir` when they write.

    Raises
    ------
    UsageError
        Naming ``flag`` and the path: it is empty or holds a NUL byte, is a file, lies under
        a file, or the nearest existing folder cannot be written.
    """
    out = _named(path, flag, "a directory name")
    if out.exists() and not out.is_dir():
        raise UsageError(f"{flag}: expected a directory, got the file {str(out)!r}")
    existing = out.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise UsageError(f"{flag}: cannot create the directory {str(out)!r}: {str(existing)!r} is a file")
    if existing == out.absolute():
        _check_writable(out, flag, out)
    else:
        try:
            _check_writable(existing, flag, out)
        except UsageError:
            raise UsageError(f"{flag}: cannot create the directory {str(out)!r}: {str(existing)!r} is not writable") from None
    return out


def out_dir(path: str | os.PathLike[str], flag: str = "--out") -> Path:
    """Create the output folder ``path`` if missing and check that files can be written in it.

    Raises
    ------
    UsageError
        Naming ``flag`` and the path: it is a file, cannot be created, or is not writable.
    """
    out = check_out_dir(path, flag)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{flag}: cannot create the directory {str(out)!r}: {exc.strerror or exc}") from None
    _check_writable(out, flag, out)
    return out


def out_file(path: str | os.PathLike[str], flag: str = "--output", create: bool = True) -> Path:
    """Check that the file ``path`` can be written, its folder created if missing (``create=False``: only checked)."""
    target = _named(path, flag, "a file name")
    if target.is_dir():
        raise UsageError(f"{flag}: expected a file name, got the directory {str(target)!r}")
    (out_dir if create else check_out_dir)(target.parent, flag)
    return target


def write_json(path: Path, data: dict[str, Any]) -> Path:
    """Write ``data`` as indented JSON, atomically; NaN or infinity is refused (not valid JSON)."""
    return write_atomic(path, json.dumps(data, indent=2, allow_nan=False) + "\n")


def save_figure(fig: Any, path: Path, dpi: int = 110) -> Path:
    """Save a :class:`matplotlib.figure.Figure` as PNG at ``path``, atomically (no pyplot involved)."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return path
