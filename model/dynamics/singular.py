"""A singular joint-space inertia matrix B(q): which joint, and the one error every engine raises for it.

``accel`` solves ``B(q) qdd = tau - h`` by an LDL^T; a joint that moves no mass
and has no motor inertia at ``q`` (a massless link, a prismatic joint whose only
load is the payload, a revolute joint whose mass sits on its own axis) makes
``B(q)`` singular and the solve returns non-finite numbers. The numeric API
(``accel``, ``accel_batch``) and every closed loop (the Python loop, the
compiled kernel, the FMU) turn that into a :class:`SingularDynamicsError`
naming the joint and ``q`` instead of returning NaN.
(:class:`~model.errors.SingularDynamicsError` lives in :mod:`model.errors`, importable without CasADi.)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import SingularDynamicsError

__all__ = ["INERTIA_RTOL", "singular_joint", "singular_dynamics_error"]

#: An eigenvalue of B(q) at most this fraction of the largest counts as zero (double rounding of a
#: sum of products is ~1e-16 relative; 1e-12 leaves 4 decades and still flags a truly massless joint).
INERTIA_RTOL = 1e-12


def singular_joint(B: Any) -> tuple[int, float, float] | None:
    """``(joint, smallest eigenvalue, largest |eigenvalue|)`` of a singular (n, n) ``B``, else None.

    ``joint`` is 0-based: the joint the null direction moves most. Singular means an eigenvalue
    at most :data:`INERTIA_RTOL` times the largest, or one that is not finite.
    """
    B = np.asarray(B, dtype=float)
    if not np.all(np.isfinite(B)):
        return int(np.flatnonzero(~np.isfinite(B).all(axis=1))[0]), float("nan"), float("nan")
    eigval, eigvec = np.linalg.eigh(0.5 * (B + B.T))
    scale = max(float(np.max(np.abs(eigval))), np.finfo(float).tiny)
    if eigval[0] > INERTIA_RTOL * scale:
        return None
    return int(np.argmax(np.abs(eigvec[:, 0]))), float(eigval[0]), scale


def singular_dynamics_error(description: Any, joint: int, q: Any, where: str = "") -> SingularDynamicsError:
    """The :class:`SingularDynamicsError` of ``description`` (a :class:`~model.RobotDescription`) at the
    0-based ``joint`` and configuration ``q``; ``where`` says what was computed (e.g. ``"accel_batch row 3"``)."""
    link = description.links[joint]
    name = f" ({link.name})" if link.name else ""
    q = np.asarray(q, dtype=float)
    at = f", {where}" if where else ""
    return SingularDynamicsError(
        f"{description.name}: the inertia matrix B(q) is singular at joint {joint + 1}{name}, "
        f"q = [{', '.join(f'{v:.6g}' for v in q)}]{at}: joint {joint + 1} "
        "moves no mass and has no motor inertia there, so its acceleration is undefined",
        joint + 1, q)
