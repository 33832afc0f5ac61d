"""One rule for fixed-shape vector arguments: shape (size,), or (size, 1) / (1, size) reshaped, finite.

Every public numeric function of the workbench checks its vector arguments
through these two functions, so the accepted shapes and the error messages
are the same everywhere.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from .errors import InputError

__all__ = ["as_joint_vector", "shaped_vector", "finite_vector", "joint_batch"]


def shaped_vector(value: Any, size: int, name: str, what: str = "values") -> np.ndarray:
    """``value`` as a float array of shape (size,); a ValueError naming ``name`` otherwise (finiteness not checked)."""
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,):
        if arr.shape not in ((size, 1), (1, size)):
            raise InputError(f"expected {size} {what}, got an array of shape {np.shape(value)}", parameter=name)
        arr = arr.reshape(size)
    return arr


def finite_vector(value: Any, size: int, name: str, what: str = "values") -> np.ndarray:
    """:func:`shaped_vector`, also finite and C-contiguous."""
    arr = shaped_vector(value, size, name, what)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"expected finite values, got {arr.tolist()}", parameter=name)
    return np.ascontiguousarray(arr)


def as_joint_vector(value: Any, n: int, name: str = "q") -> np.ndarray:
    """``value`` as a finite float array of shape (n,); (n, 1) and (1, n) are accepted; a ValueError naming ``name`` otherwise."""
    return finite_vector(value, n, name, "joint values")


def joint_batch(value: Any, n: int, name: str = "Q") -> np.ndarray:
    """``value`` as a finite, C-contiguous float64 array of shape (N, n); a ValueError naming ``name`` and the bad rows otherwise."""
    arr = np.ascontiguousarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != n:
        raise InputError(f"expected an (N, {n}) array, got shape {np.shape(value)}", parameter=name)
    if not np.all(np.isfinite(arr)):
        rows = np.unique(np.nonzero(~np.isfinite(arr))[0])
        raise InputError(f"expected finite values; rows {rows[:5].tolist()} are not", parameter=name)
    return arr
