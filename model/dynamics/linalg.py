"""Small symbolic linear algebra that keeps CasADi SX graphs compact."""

from __future__ import annotations

import casadi as ca

__all__ = ["ldl_solve_sx"]


def ldl_solve_sx(B: ca.SX, rhs: ca.SX) -> ca.SX:
    """Solve ``B x = rhs`` for a symmetric positive-definite (n, n) ``B`` by an unpivoted LDL^T.

    Reads only the diagonal and the lower triangle of ``B``. Adds O(n^3) scalar operations to the graph (no cofactor expansion), so
    the result stays code-generatable and small for n <= 10. No pivoting is
    needed because the joint-space inertia matrix is positive definite.
    """
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
