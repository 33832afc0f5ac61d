"""Small symbolic linear algebra that keeps CasADi SX graphs compact."""

from __future__ import annotations

import casadi as ca

__all__ = ["ldl_solve_sx", "ldl_pivots_sx"]


def _ldl(B: ca.SX) -> tuple[list[list[ca.SX]], list[ca.SX]]:
    """Unpivoted ``B = L D L^T`` of the lower triangle of ``B``: ``(L, D)`` as nested lists of scalars."""
    n = B.shape[0]
    L = [[None] * n for _ in range(n)]
    D = [None] * n
    for j in range(n):
        d = B[j, j]
        for k in range(j):
            d = d - L[j][k] * L[j][k] * D[k]
        D[j] = d
        for i in range(j + 1, n):
            s = B[i, j]
            for k in range(j):
                s = s - L[i][k] * L[j][k] * D[k]
            L[i][j] = s / d
    return L, D


def ldl_solve_sx(B: ca.SX, rhs: ca.SX) -> ca.SX:
    """Solve ``B x = rhs`` for a symmetric positive-definite (n, n) ``B`` by an unpivoted LDL^T.

    Reads only the diagonal and the lower triangle of ``B``. Adds O(n^3) scalar operations to the graph (no cofactor expansion), so
    the result stays code-generatable and small for n <= 10. No pivoting is
    needed because the joint-space inertia matrix is positive definite; a
    pivot that is zero (a singular B) gives non-finite entries (see :func:`ldl_pivots_sx`).
    """
    n = B.shape[0]
    L, D = _ldl(B)
    y = [None] * n
    for i in range(n):
        s = rhs[i]
        for k in range(i):
            s = s - L[i][k] * y[k]
        y[i] = s
    x = [None] * n
    for i in reversed(range(n)):
        s = y[i] / D[i]
        for k in range(i + 1, n):
            s = s - L[k][i] * x[k]
        x[i] = s
    return ca.vertcat(*x)


def ldl_pivots_sx(B: ca.SX) -> ca.SX:
    """(n, 1) pivots ``D`` of the unpivoted LDL^T of :func:`ldl_solve_sx`: all positive for a positive-definite
    ``B``; the first that is not positive names the row (joint) at which ``B`` is singular."""
    return ca.vertcat(*_ldl(B)[1])
