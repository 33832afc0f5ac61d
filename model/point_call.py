"""The single-call fast path: one generated function called at one point with its checks done in C.

:func:`point_call` wraps Function ``name`` of a :class:`~model.codegen.CompiledLibrary` in a
``PointCall`` of the small CPython extension ``model/c/point_call.c`` (compiled here on first use
and cached in the ``point-call`` folder of the libraries' cache, under the hash of its source, the Python ABI, NumPy and the
compiler). A ``PointCall`` takes the joint vectors (each a 1-D float64 array or a list/tuple of n
numbers), copies them into its buffers, evaluates with the fixed inputs it was made with (the
parameter vector) and returns a fresh array, or None whenever the checked path must decide (another
type or shape, a non-finite input or output). The caller then takes its checked path, which raises
the usual :class:`~model.errors.InputError` or returns the same numbers: the fast path changes no
result and no message, only the cost of a call.

Without a compiler, Python headers or NumPy headers, :func:`point_call` returns None and every call
takes the checked path.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import subprocess
import sysconfig
import tempfile
import threading
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .codegen import BASE_CFLAGS, CompiledLibrary, cache_dir, find_compiler
from .errors import ToolchainError

__all__ = ["PointCall", "extension", "point_call"]

SOURCE = Path(__file__).resolve().parent / "c" / "point_call.c"
#: A compiled call ``f(*joint_vectors) -> np.ndarray | None``.
PointCall = Callable[..., "np.ndarray | None"]

_lock = threading.Lock()
_state: dict[str, Any] = {}


def _build(folder: Path) -> Path:
    """Compile the extension into ``folder`` (cached by key); its path."""
    compiler = find_compiler()
    includes = [sysconfig.get_paths()["include"], np.get_include()]
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    flags = [*BASE_CFLAGS, "-O2", "-shared", *[f"-I{i}" for i in includes]]
    key = hashlib.sha256("\0".join([SOURCE.read_text(), suffix, np.__version__, compiler, *flags]).encode())
    target = folder / f"point-call-{key.hexdigest()[:20]}{suffix}"
    if not target.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".point-call-", suffix=suffix)
        os.close(fd)
        proc = subprocess.run([compiler, *flags, str(SOURCE), "-o", tmp], capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            os.unlink(tmp)
            raise ToolchainError(f"point_call.c does not compile: {proc.stderr[-2000:]}")
        os.replace(tmp, target)  # atomic: a concurrent build of the same key writes the same file
    return target


def extension() -> Any:
    """The loaded extension module, or None if it cannot be built here (the reason in ``_state``)."""
    with _lock:
        if "module" not in _state:
            try:
                path = _build(cache_dir() / "point-call")  # apart from the libraries
                loader = importlib.machinery.ExtensionFileLoader("_mw_point_call", str(path))
                spec = importlib.util.spec_from_file_location("_mw_point_call", str(path), loader=loader)
                assert spec is not None
                module = importlib.util.module_from_spec(spec)
                loader.exec_module(module)
                _state["module"] = module
            except (ToolchainError, OSError, ImportError) as exc:
                _state["module"], _state["reason"] = None, f"{type(exc).__name__}: {exc}"
        return _state["module"]


def point_call(library: CompiledLibrary | None, name: str, n_args: int, n: int,
               fixed: Sequence[np.ndarray] = (), matrix: bool = False) -> PointCall | None:
    """A compiled single-point call of Function ``name`` of ``library``, or None where there is none.

    Parameters
    ----------
    n_args, n
        The call takes ``n_args`` joint vectors of length ``n``: the Function's first inputs.
    fixed
        The Function's remaining inputs, read in place at every call (contiguous float64, kept referenced).
    matrix
        Return the first output as a Fortran-ordered (rows, cols) array (its column-major layout);
        else as a flat vector.
    """
    if library is None or name not in library:
        return None
    module = extension()
    if module is None:
        return None
    sig = library.signatures[name]
    if (len(sig.in_sizes) != n_args + len(fixed) or any(s != n for s in sig.in_sizes[:n_args])
            or any(f.shape != (s,) for f, s in zip(fixed, sig.in_sizes[n_args:]))):
        return None
    rows, cols = sig.out_shapes[0]
    if not matrix:
        rows, cols = rows * cols, 0
    eval_address, work_address = library.entry_points(name)
    return module.make(eval_address, work_address, n_args, n, tuple(fixed), rows, cols, library)
