"""Time-optimal path parameterisation by reachability analysis (TOPP-RA) under the full inverse dynamics.

Along a path ``q(s)`` with the time law ``s(t)``, ``qd = q' sd`` and ``qdd = q' sdd + q'' sd^2``. The inverse
dynamics with motors and friction (:meth:`model.Robot.rne`) then reads, per joint and at each path point,

    tau(s) = a(s) sdd + b(s) sd^2 + v(s) sd + c(s)

with ``a = B(q) q'`` (reflected rotors included), ``b = B(q) q'' + C(q, q') q'``, ``c = g(q) + |G| Tc(sign q')``
(Coulomb friction in the direction the path moves the joint) and the viscous term ``v = G^2 B_m q'``. Each
coefficient is taken from the compiled inverse dynamics itself (``rne`` with friction off at
``(q, 0, q')``, ``(q, q', q'')`` and ``(q, 0, 0)``), never re-derived. Joint accelerations give rows
``q' sdd + q'' sd^2``; joint velocities bound ``sd`` directly.

The method, on a grid ``s_0 .. s_N`` with ``x = sd^2`` and ``u = sdd`` constant on each stage
(``x_{i+1} = x_i + 2 (s_{i+1} - s_i) u_i``):

* Every stage keeps the rows of its start point at ``(x_i, u_i)`` *and* those of its end point at
  ``(x_{i+1}, u_i)`` (toppra's "interpolation" discretisation): each grid point's limits hold for the
  acceleration before it and after it, so a bang-bang switch cannot overshoot between grid points.
* The viscous term ``v sd = v sqrt(x)`` is not linear in ``x``, so TOPP-RA's linear form does not cover it.
  It is bounded soundly by lines: above by a tangent of ``sqrt`` (valid for every x), below by chords (valid
  on ``[0, X]``, the stage's x kept within X). The first pass without viscous friction is exact and sizes
  ``X`` (twice its controllable top, within the maximal velocity curve) and the first tangent point; the
  pass with the lines gives a feasible motion; each further pass, with lines exact at the previous motion's own
  x (tangent and chord node there), keeps it feasible and can only shorten it, until one gains less than
  :data:`REFINE_RTOL`. Measured against a direct IPOPT transcription with the viscous term exact (planar2r,
  whose joints have 100 N m s/rad): 2.7e-2 longer after the first pass, 3.7e-5 after one refinement, 2e-10
  after two; on the SCARA's pick-and-place the refinements gain 3e-3, then 4e-7.
* The backward pass computes the controllable sets ``K_i`` (eliminating u pairwise between the rows:
  Fourier-Motzkin on each stage's 2-D polygon), the forward pass takes the largest u that keeps ``K_{i+1}``
  reachable. Without viscous friction this is the discretised problem toppra solves with
  ``JointTorqueConstraint`` and the interpolation scheme, and the durations agree to 1e-7.
* The maximal velocity curve (each point's admissible speeds on its own, exact with the viscous term: the
  bounds on sdd are quadratic in sd and the set is found from the roots of their pairwise differences) is
  kept for the figure and as the range of x.

Units: s in the path's unit (rad, m, or both as one joint-space length), ``sd`` per second, ``sdd`` per s^2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from ..errors import InputError, NumericalError
from ..trajectory import JointPath

if TYPE_CHECKING:  # pragma: no cover
    from ..robot import Robot
    from .limits import RetimeLimits

__all__ = ["PathConstraints", "SegmentSolution", "RetimeInfeasibleError", "path_constraints", "solve_segment",
           "REFINE_RTOL", "Y_CAP"]

Array = npt.NDArray[np.float64]

#: The refinement passes stop once one shortens the motion by less than this share.
REFINE_RTOL = 1e-7
#: Largest path speed considered, per second: the top of the search range where nothing else bounds sd.
Y_CAP = 1e8
#: A row whose ``a`` is below this fraction of its largest ``|a|`` along the segment is a pure sd-constraint there.
_PURE_RTOL = 1e-12
#: Relative tolerance of a test point's feasibility (rounding of the roots that bound a set).
_FEAS_RTOL = 1e-11
#: Points whose u-interval is empty by more than this share of its bounds are not checked for rounding.
_NEAR = 1e-6


class RetimeInfeasibleError(NumericalError):
    """No time law along the path keeps within the limits (e.g. a joint cannot hold the arm still at some s)."""


@dataclass(frozen=True, eq=False)
class PathConstraints:
    """The constraints of one segment on its grid, as rows ``lo <= alpha sdd + beta sd^2 + gamma sd + delta <= hi``.

    Attributes
    ----------
    s
        (N+1,) grid in the path coordinate.
    q, dq, ddq
        (N+1, n) ``q(s)``, ``q'(s)``, ``q''(s)`` on the grid.
    alpha, beta, gamma, delta, lo, hi
        (N+1, R) the rows' coefficients and bounds: first the n torque rows (N m or N, joint side), then one
        acceleration row per joint with a finite acceleration limit.
    rows
        R labels ``("torque", j)`` or ``("acceleration", j)`` (0-based joints).
    y_max
        (N+1,) the largest sd the velocity limits allow (:data:`Y_CAP` where none binds).
    """

    s: Array
    q: Array
    dq: Array
    ddq: Array
    alpha: Array
    beta: Array
    gamma: Array
    delta: Array
    lo: Array
    hi: Array
    rows: tuple[tuple[str, int], ...]
    y_max: Array

    def values(self, y: Array, u: Array) -> Array:
        """(N+1, R) each row's value ``alpha u + beta y^2 + gamma y + delta`` at the grid's (y, u)."""
        return self.alpha * u[:, None] + self.beta * (y * y)[:, None] + self.gamma * y[:, None] + self.delta


def path_constraints(robot: "Robot", segment: JointPath, s: npt.ArrayLike, limits: "RetimeLimits") -> PathConstraints:
    """The torque, acceleration and velocity constraints of ``robot`` along ``segment`` at the grid ``s``.

    ``limits`` holds the joint-side torque bounds (torque margin and gear ratios applied) and the joint
    velocity and acceleration limits (see :func:`model.retime.retime_limits`).
    """
    grid = np.asarray(s, dtype=float)
    Q, dQ, ddQ = segment.batch(grid)
    N1, n = Q.shape
    p = robot.parameters
    frictionless = p.with_friction(viscous=np.zeros(n), coulomb_pos=np.zeros(n), coulomb_neg=np.zeros(n))
    zero = np.zeros_like(Q)
    c = robot.rne_batch(Q, zero, zero, frictionless)
    a = robot.rne_batch(Q, zero, dQ, frictionless) - c
    b = robot.rne_batch(Q, dQ, ddQ, frictionless) - c
    G = robot.gear_ratio
    tc_pos, tc_neg = p.field("coulomb_friction_pos"), p.field("coulomb_friction_neg")
    coulomb = np.abs(G) * np.where(dQ > 0.0, tc_pos, np.where(dQ < 0.0, tc_neg, 0.0))
    viscous = (G * G * p.viscous_friction) * dQ
    tau = np.broadcast_to(limits.tau_max, (N1, n))
    alpha, beta, gamma, delta, lo, hi = [a], [b], [viscous], [c + coulomb], [-tau], [tau]
    rows: list[tuple[str, int]] = [("torque", j) for j in range(n)]
    acc = [j for j in range(n) if np.isfinite(limits.acceleration[j])]
    if acc:
        amax = np.broadcast_to(limits.acceleration[acc], (N1, len(acc)))
        alpha.append(dQ[:, acc])
        beta.append(ddQ[:, acc])
        gamma.append(np.zeros((N1, len(acc))))
        delta.append(np.zeros((N1, len(acc))))
        lo.append(-amax)
        hi.append(amax)
        rows += [("acceleration", j) for j in acc]
    with np.errstate(divide="ignore"):
        bound = np.where(np.abs(dQ) > 0.0, limits.velocity / np.abs(dQ), np.inf)
    y_max = np.minimum(np.min(bound, axis=1), Y_CAP)
    return PathConstraints(s=grid, q=Q, dq=dQ, ddq=ddQ, alpha=np.hstack(alpha), beta=np.hstack(beta),
                           gamma=np.hstack(gamma), delta=np.hstack(delta), lo=np.hstack(lo), hi=np.hstack(hi),
                           rows=tuple(rows), y_max=y_max)


@dataclass(frozen=True, eq=False)
class SegmentSolution:
    """The time-optimal law of one segment on its grid.

    Attributes
    ----------
    s
        (N+1,) grid.
    sd
        (N+1,) path speed at the grid points (0 at both ends), per s.
    sdd
        (N,) path acceleration on each stage (constant over it), per s^2.
    K
        (N+1, 2) the controllable sets ``[x_lo, x_hi]`` of ``x = sd^2``.
    y_limit
        (N+1,) the maximal velocity curve: the largest sd at which each grid point is admissible on its own.
    """

    s: Array
    sd: Array
    sdd: Array
    K: Array
    y_limit: Array

    @property
    def stage_times(self) -> Array:
        """(N,) duration of each stage at constant sdd: ``2 (s_{i+1} - s_i) / (sd_i + sd_{i+1})``, s."""
        return 2.0 * np.diff(self.s) / (self.sd[:-1] + self.sd[1:])

    @property
    def duration(self) -> float:
        """Total time of the segment, s."""
        return float(np.sum(self.stage_times))


def _bounds(pc: PathConstraints) -> tuple[Array, Array, Array, Array]:
    """Every grid point's rows as u-bounds quadratic in y, batched over the grid.

    Returns ``L``, ``U`` (N+1, R, 3): ``u >= L(y)`` and ``u <= U(y)`` (coefficients c2, c1, c0 of
    ``c2 y^2 + c1 y + c0``; ``c0 = -inf`` / ``+inf`` where a row does not bound u); ``P`` (N+1, 2R, 3):
    conditions ``P(y) <= 0`` of the rows that do not depend on u there (``c0 = -inf`` elsewhere); and
    ``pure`` (N+1, R).
    """
    scale = np.max(np.abs(pc.alpha), axis=0)
    pure = np.abs(pc.alpha) <= _PURE_RTOL * scale
    a = np.where(pure, 1.0, pc.alpha)
    pos = a > 0.0
    c2, c1 = -pc.beta / a, -pc.gamma / a
    c0L = np.where(pure, -np.inf, (np.where(pos, pc.lo, pc.hi) - pc.delta) / a)
    c0U = np.where(pure, np.inf, (np.where(pos, pc.hi, pc.lo) - pc.delta) / a)
    L = np.stack([c2, c1, c0L], axis=-1)
    U = np.stack([c2, c1, c0U], axis=-1)
    keep = lambda v: np.where(pure, v, 0.0)  # noqa: E731
    P = np.concatenate([np.stack([keep(pc.beta), keep(pc.gamma), np.where(pure, pc.delta - pc.hi, -np.inf)], axis=-1),
                        np.stack([keep(-pc.beta), keep(-pc.gamma), np.where(pure, pc.lo - pc.delta, -np.inf)], axis=-1)],
                       axis=1)
    return L, U, P, pure


def _quad(C: Array, y: Array) -> Array:
    """(..., m, T) values of the quadratics ``C`` (..., m, 3) at the points y (..., T)."""
    y = y[..., None, :]
    return (C[..., 0:1] * y + C[..., 1:2]) * y + C[..., 2:3]


def _size(C: Array, y: Array) -> Array:
    """(..., T) the largest finite term magnitude ``|c2| y^2 + |c1| y + |c0|`` of the quadratics (rounding scale)."""
    c0 = np.abs(C[..., 2:3])
    y = y[..., None, :]
    return ((np.abs(C[..., 0:1]) * y + np.abs(C[..., 1:2])) * y + np.where(np.isfinite(c0), c0, 0.0)).max(axis=-2)


def _feasible(L: Array, U: Array, P: Array, y: Array) -> Array:
    """(B, T) whether each y (B, T) admits a u with every ``L(y) <= u <= U(y)`` and every ``P(y) <= 0`` (to rounding).

    Rounding is forgiven up to :data:`_FEAS_RTOL` times the largest term of the quadratics at y (computed
    only where the plain test fails).
    """
    hi_l, lo_u = _quad(L, y).max(axis=-2), _quad(U, y).min(axis=-2)
    gap = hi_l - lo_u
    ok = gap <= 0.0
    if P.shape[-2]:
        ok &= _quad(P, y).max(axis=-2) <= 0.0
    # only points within a hair of feasible can be feasible to rounding: the rest are not looked at again
    close = np.argwhere(~ok & (gap <= _NEAR * np.maximum(np.abs(hi_l), np.abs(lo_u))))
    if close.size:
        b, t = close[:, 0], close[:, 1]
        yy = y[b, t][:, None]
        size = np.maximum(_size(L[b], yy), _size(U[b], yy))[:, 0]
        good = gap[b, t] <= _FEAS_RTOL * size
        if P.shape[-2]:
            good &= np.all(_quad(P[b], yy)[..., 0] <= _FEAS_RTOL * _size(P[b], yy), axis=-1)
        ok[b, t] = good
    return ok


def _pieces(L: Array, U: Array, P: Array, top: Array) -> tuple[Array, Array]:
    """The lowest connected piece ``[y_lo, y_hi]`` of the feasible y in ``[0, top]``, batched: L (B, l, 3), U (B, u, 3),
    P (B, p, 3), top (B,); NaN where there is none.

    The boundaries of the feasible set are roots of the pairwise differences ``L_a - U_b`` and of ``P``; the
    set is tested at every such root in range and midway between neighbouring ones.
    """
    B = L.shape[0]
    C = np.concatenate([(L[:, :, None, :] - U[:, None, :, :]).reshape(B, -1, 3), P], axis=1)
    a, b, c = C[..., 0], C[..., 1], C[..., 2]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        disc = b * b - 4.0 * a * c
        sq = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        qq = -0.5 * (b + np.copysign(sq, b))
        r = np.concatenate([qq / a, c / qq], axis=1)
    t = top[:, None]
    r = np.where(np.isfinite(r) & (r > 0.0) & (r < t), r, t)
    pts = np.sort(np.concatenate([np.zeros((B, 1)), r, t], axis=1), axis=1)
    test = np.empty((B, 2 * pts.shape[1] - 1))
    test[:, 0::2] = pts
    test[:, 1::2] = 0.5 * (pts[:, :-1] + pts[:, 1:])
    with np.errstate(invalid="ignore", over="ignore"):
        ok = _feasible(L, U, P, test)
    T = test.shape[1]
    first = np.argmax(ok, axis=1)
    after = ~ok & (np.arange(T)[None, :] > first[:, None])
    last = np.where(after.any(axis=1), np.argmax(after, axis=1) - 1, T - 1)
    rows = np.arange(B)
    none = ~ok.any(axis=1)
    y_lo = np.where(none, np.nan, test[rows, first])
    y_hi = np.where(none, np.nan, test[rows, last])
    return y_lo, y_hi


def _lines(gamma: Array, x0: Array, X: Array) -> tuple[Array, Array, Array, Array]:
    """Lines bounding ``sqrt(x)`` on ``[0, X]``, chosen per row by the sign of its viscous coefficient.

    Above: the tangent at ``x0`` (valid for every x >= 0). Below: the chords of the nodes ``0, x0, X``
    (valid on ``[0, X]``; ``sqrt`` is concave, so it lies above each chord's line between the nodes, and
    the lower envelope of the two lines is below it on the whole range). Both are exact at ``x0``.

    Parameters
    ----------
    gamma
        (M, R) viscous coefficients of the rows.
    x0, X
        (M,) tangent point and top of the range, ``0 <= x0 <= X``.

    Returns
    -------
    ``m_hi, c_hi, m_lo, c_lo`` (M, R, 2): for the upper side of each row (value <= hi) the lines ``m x + c``
    bounding ``gamma sqrt(x)`` from above, for its lower side those bounding it from below; two lines each
    (the tangent repeated), every one of which must be kept.
    """
    sX, s0 = np.sqrt(X)[:, None], np.sqrt(x0)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_m = np.where(s0 > 0.0, 0.5 / s0, 0.0)
        t_c = 0.5 * s0
        m1 = np.where(s0 > 0.0, 1.0 / s0, np.where(sX > 0.0, 1.0 / sX, 0.0))  # chord 0 -> x0 (0 -> X if x0 = 0)
        m2 = np.where(s0 + sX > 0.0, 1.0 / (s0 + sX), 0.0)                     # chord x0 -> X
        c2 = np.where(s0 + sX > 0.0, s0 * sX / (s0 + sX), 0.0)
    tan_m, tan_c = np.repeat(t_m[..., None], 2, -1), np.repeat(t_c[..., None], 2, -1)
    ch_m = np.stack([m1, m2], -1)
    ch_c = np.stack([np.zeros_like(c2), c2], -1)
    up = (gamma > 0.0)[..., None]
    g = gamma[..., None]
    m_hi = g * np.where(up, tan_m, ch_m)
    c_hi = g * np.where(up, tan_c, ch_c)
    m_lo = g * np.where(up, ch_m, tan_m)
    c_lo = g * np.where(up, ch_c, tan_c)
    return m_hi, c_hi, m_lo, c_lo


def _one_sided(alpha: Array, beta: Array, gamma: Array, delta: Array, lo: Array, hi: Array, x0: Array, X: Array,
               shift: Array | None = None) -> tuple[Array, Array, Array]:
    """Rows ``lo <= alpha u + beta x + gamma sqrt(x) + delta <= hi`` (M, R) as one-sided linear rows ``a u + b x <= c``.

    ``sqrt`` is replaced by :func:`_lines` (sound on ``[0, X]``) in the rows with a viscous term somewhere (four
    one-sided rows each: two sides, two lines); the others are exact (two one-sided rows each). With ``shift``
    (M,) the rows hold at the end of a stage, ``x' = x + 2 delta u`` (``shift = 2 delta``), and are written in
    the stage's own (u, x). Each row is scaled by ``1 / hi`` (its bounds are ``+-hi``). Returns ``a, b, c``.
    """
    M = alpha.shape[0]
    wet = np.any(gamma != 0.0, axis=0)
    parts = []
    for rows, lines in ((~wet, False), (wet, True)):
        if not rows.any():
            continue
        g = gamma[:, rows]
        if lines:
            m_hi, c_hi, m_lo, c_lo = _lines(g, x0, X)
        else:
            m_hi = c_hi = m_lo = c_lo = np.zeros(g.shape + (1,))
        scale = (1.0 / hi[:, rows])[..., None]
        a, b, d = alpha[:, rows, None], beta[:, rows, None], delta[:, rows, None]
        bh, bl = b + m_hi, b + m_lo
        ah, al = np.broadcast_to(a, bh.shape), np.broadcast_to(a, bl.shape)
        if shift is not None:
            ah = a + shift[:, None, None] * bh
            al = a + shift[:, None, None] * bl
        parts.append((np.concatenate([ah * scale, -al * scale], axis=-1).reshape(M, -1),
                      np.concatenate([bh * scale, -bl * scale], axis=-1).reshape(M, -1),
                      np.concatenate([np.broadcast_to((hi[:, rows, None] - d - c_hi) * scale, bh.shape),
                                      np.broadcast_to((d + c_lo - lo[:, rows, None]) * scale, bl.shape)],
                                     axis=-1).reshape(M, -1)))
    return tuple(np.hstack([p[k] for p in parts]) for k in range(3))  # type: ignore[return-value]


def _static(A: Array, B: Array, C: Array, top: Array) -> tuple[Array, Array]:
    """Per stage, the x for which some u meets every row ``a u + b x <= c``, as ``[x_lo, x_hi]`` (NaN: none).

    u is eliminated pairwise (Fourier-Motzkin): a row with ``a > 0`` and one with ``a < 0`` give
    ``(a_k b_l - a_l b_k) x <= a_k c_l - a_l c_k``; a row with ``a = 0`` bounds x itself; ``0 <= x <= top``.
    """
    M = A.shape[0]
    x_lo, x_hi = np.zeros(M), np.array(top, dtype=float)
    zero = A == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        zb = np.where(zero, C / B, np.nan)
    x_hi = np.minimum(x_hi, np.where(zero & (B > 0.0), zb, np.inf).min(axis=1))
    x_lo = np.maximum(x_lo, np.where(zero & (B < 0.0), zb, -np.inf).max(axis=1))
    empty = (zero & (B == 0.0) & (C < 0.0)).any(axis=1)
    order = np.argsort(A, axis=1)  # rows with a < 0 first, a > 0 last
    A, B, C = (np.take_along_axis(v, order, axis=1) for v in (A, B, C))
    n_neg, n_pos = int((A < 0.0).sum(axis=1).max()), int((A > 0.0).sum(axis=1).max())
    if n_neg and n_pos:
        chunk = max(1, 400_000 // (n_neg * n_pos))
        for s0 in range(0, M, chunk):
            sl = slice(s0, min(M, s0 + chunk))
            an, bn, cn = A[sl, :n_neg, None], B[sl, :n_neg, None], C[sl, :n_neg, None]   # (c, neg, 1): rows l
            ap, bp, cp = A[sl, None, -n_pos:], B[sl, None, -n_pos:], C[sl, None, -n_pos:]  # (c, 1, pos): rows k
            pair = (an < 0.0) & (ap > 0.0)
            p = ap * bn - an * bp
            r = ap * cn - an * cp
            with np.errstate(divide="ignore", invalid="ignore"):
                bound = r / p
            x_hi[sl] = np.minimum(x_hi[sl], np.where(pair & (p > 0.0), bound, np.inf).min(axis=(1, 2)))
            x_lo[sl] = np.maximum(x_lo[sl], np.where(pair & (p < 0.0), bound, -np.inf).max(axis=(1, 2)))
            empty[sl] |= (pair & (p == 0.0) & (r < 0.0)).any(axis=(1, 2))
    bad = empty | (x_lo > x_hi + 1e-12 * np.maximum(1.0, np.abs(x_hi)))
    x_hi = np.maximum(x_hi, x_lo)
    return np.where(bad, np.nan, x_lo), np.where(bad, np.nan, x_hi)


def _pass(pc: PathConstraints, gamma: Array, X: Array, x0: Array) -> tuple[Array, Array]:
    """One TOPP-RA pass with the viscous terms ``gamma sd`` bounded on ``[0, X]`` by lines exact at ``x0``: ``(x, K)``.

    Stage i holds the rows of point i at its state ``(x_i, u_i)`` and those of point i+1 at the stage's end
    state ``(x_i + 2 delta_i u_i, u_i)``, so every grid point's limits hold for both one-sided accelerations.
    """
    s = pc.s
    N = s.size - 1
    deltas = np.diff(s)
    sl, sr = slice(0, N), slice(1, N + 1)
    a1, b1, c1 = _one_sided(pc.alpha[sl], pc.beta[sl], gamma[sl], pc.delta[sl], pc.lo[sl], pc.hi[sl], x0[sl], X[sl])
    a2, b2, c2 = _one_sided(pc.alpha[sr], pc.beta[sr], gamma[sr], pc.delta[sr], pc.lo[sr], pc.hi[sr], x0[sr], X[sr],
                            shift=2.0 * deltas)
    A, B, C = np.hstack([a1, a2]), np.hstack([b1, b2]), np.hstack([c1, c2])
    x_lo, x_hi = _static(A, B, C, X[:N])
    bad = np.flatnonzero(np.isnan(x_lo))
    if bad.size:
        i = int(bad[0])
        raise RetimeInfeasibleError(f"retime: no state at s = {s[i]:.6g} (q = {np.round(pc.q[i], 6).tolist()}) "
                                    f"is within the limits: {_describe(pc, i)}")
    # The step into K_{i+1}, paired with every row: u <= (kh - x) / 2delta against a row with a < 0 bounds x by
    # (2delta c - a kh) / (2delta b - a), u >= (kl - x) / 2delta against one with a > 0 by (2delta c - a kl) / (...).
    two_d = (2.0 * deltas)[:, None]
    P = two_d * B - A
    base = two_d * C
    with np.errstate(divide="ignore", invalid="ignore"):
        beta, eta = base / P, -A / P
    neg, pos = A < 0.0, A > 0.0
    inf = np.inf
    bh_kh, eh_kh = np.where(neg & (P > 0.0), beta, inf), np.where(neg & (P > 0.0), eta, 0.0)
    bl_kh, el_kh = np.where(neg & (P < 0.0), beta, -inf), np.where(neg & (P < 0.0), eta, 0.0)
    bh_kl, eh_kl = np.where(pos & (P > 0.0), beta, inf), np.where(pos & (P > 0.0), eta, 0.0)
    bl_kl, el_kl = np.where(pos & (P < 0.0), beta, -inf), np.where(pos & (P < 0.0), eta, 0.0)
    flat_neg = neg & (P == 0.0)  # r = base - a kh must be >= 0
    flat_pos = pos & (P == 0.0)
    some_lo_kh = (neg & (P < 0.0)).any(axis=1).tolist()
    some_flat = (flat_neg | flat_pos).any(axis=1).tolist()
    # with kl = 0 the kl-terms are constants: fold them into the static interval
    hi0 = np.minimum(x_hi, bh_kl.min(axis=1))
    lo0 = np.maximum(x_lo, bl_kl.max(axis=1))
    K = np.zeros((N + 1, 2))
    kl = kh = 0.0
    hi0l, lo0l = hi0.tolist(), lo0.tolist()
    for i in range(N - 1, -1, -1):
        if kl == 0.0:
            lo_i, hi_i = lo0l[i], hi0l[i]
        else:
            hi_i = min(float(x_hi[i]), float((bh_kl[i] + eh_kl[i] * kl).min()))
            lo_i = max(float(x_lo[i]), float((bl_kl[i] + el_kl[i] * kl).max()))
        hi_i = min(hi_i, float((bh_kh[i] + eh_kh[i] * kh).min()))
        if some_lo_kh[i]:
            lo_i = max(lo_i, float((bl_kh[i] + el_kh[i] * kh).max()))
        if some_flat[i]:
            r = np.concatenate([base[i][flat_neg[i]] - A[i][flat_neg[i]] * kh, base[i][flat_pos[i]] - A[i][flat_pos[i]] * kl])
            if np.any(r < 0.0):
                hi_i = -1.0
        if lo_i > hi_i:
            if lo_i - hi_i > 1e-12 * max(1.0, abs(hi_i)):
                raise RetimeInfeasibleError(f"retime: no motion through s = {s[i]:.6g} (q = "
                                            f"{np.round(pc.q[i], 6).tolist()}) reaches the end within the limits: "
                                            f"{_describe(pc, i)}")
            hi_i = lo_i
        kl, kh = lo_i, hi_i
        K[i] = (kl, kh)
    if K[0, 0] > 1e-12 * max(1.0, K[0, 1]):
        raise RetimeInfeasibleError(f"retime: the path cannot start from rest within the limits "
                                    f"(q = {np.round(pc.q[0], 6).tolist()}): {_describe(pc, 0)}")
    # Forward: the largest u the rows and the step into K_{i+1} allow.
    with np.errstate(divide="ignore", invalid="ignore"):
        ca, ba = np.where(pos, C / A, inf), np.where(pos, B / A, 0.0)
        cn, bn = np.where(neg, C / A, -inf), np.where(neg, B / A, 0.0)
    xs = np.zeros(N + 1)
    dl = deltas.tolist()
    Kl, Kh = K[:, 0].tolist(), K[:, 1].tolist()
    x = 0.0
    for i in range(N):
        d2 = 2.0 * dl[i]
        u_hi = min((Kh[i + 1] - x) / d2, float((ca[i] - ba[i] * x).min()))
        u_lo = max((Kl[i + 1] - x) / d2, float((cn[i] - bn[i] * x).max()))
        if u_hi < u_lo - 1e-9 * max(1.0, abs(u_lo), abs(u_hi), x / d2):
            raise NumericalError(f"retime: forward pass lost feasibility at s = {s[i]:.6g} (sdd in [{u_lo:.6g}, "
                                 f"{u_hi:.6g}]): a bug, please report it")
        x = min(max(x + d2 * u_hi, Kl[i + 1], 0.0), Kh[i + 1])
        xs[i + 1] = x
    xs[N] = 0.0
    return xs, K


def _describe(pc: PathConstraints, i: int) -> str:
    """The torque row most over its bound at rest at grid point i, in words (for an infeasible path's message)."""
    worst, text = -np.inf, "no joint is over its torque limit at rest there (the limits on speed and acceleration leave no way through)"
    for r, (kind, j) in enumerate(pc.rows):
        need = abs(float(pc.delta[i, r]))
        if kind == "torque" and need > pc.hi[i, r] and need / pc.hi[i, r] > worst:
            worst = need / pc.hi[i, r]
            text = f"joint {j + 1} needs {need:.4g} to hold the arm still there, above its limit {pc.hi[i, r]:.4g}"
    return text


def solve_segment(pc: PathConstraints, refine: int = 4) -> SegmentSolution:
    """The time-optimal law on one segment from rest to rest (TOPP-RA; see the module docstring).

    Parameters
    ----------
    pc
        The segment's constraints on its grid.
    refine
        Most passes after the first that bound the viscous terms again, by lines exact at the previous pass's
        solution (each pass keeps the previous solution feasible, so the duration never grows); they stop
        once a pass shortens the motion by less than :data:`REFINE_RTOL`. None without viscous friction,
        where one pass is exact.

    Raises
    ------
    RetimeInfeasibleError
        Some grid point admits no state within the limits, or none from which the end can still be reached at
        rest (naming s and the joint most over its limit at rest), or the start at rest is not controllable.
    """
    s = pc.s
    N = s.size - 1
    if N < 1:
        raise InputError(f"grid: expected at least 2 points, got {s.size}")
    viscous = bool(np.any(pc.gamma != 0.0))
    zero = np.zeros_like(pc.gamma)
    ones = np.ones(N + 1)
    # The admissible set of each point on its own (its top is the maximal velocity curve): without viscous
    # friction the rows are linear in x and the pairwise elimination is exact; with it, the roots of the
    # quadratics in sd (exact too, costlier).
    a, b, c = _one_sided(pc.alpha, pc.beta, zero, pc.delta, pc.lo, pc.hi, ones, ones)
    x_lo, x_hi = _static(a, b, c, pc.y_max ** 2)
    if viscous:
        L, U, P, _pure = _bounds(pc)
        P = P[:, np.isfinite(P[..., 2]).any(axis=0)]  # only the rows that are u-free somewhere
        y_lo, y_hi = np.empty(N + 1), np.empty(N + 1)
        chunk = max(1, 200_000 // max(1, L.shape[1] * U.shape[1] * L.shape[1]))
        for a0 in range(0, N + 1, chunk):
            b0 = min(N + 1, a0 + chunk)
            y_lo[a0:b0], y_hi[a0:b0] = _pieces(L[a0:b0], U[a0:b0], P[a0:b0], pc.y_max[a0:b0])
    else:
        y_lo, y_hi = np.sqrt(x_lo), np.sqrt(x_hi)
    bad = np.flatnonzero(np.isnan(y_lo))
    if bad.size:
        i = int(bad[0])
        raise RetimeInfeasibleError(f"retime: no state at s = {s[i]:.6g} (q = {np.round(pc.q[i], 6).tolist()}) is "
                                    f"within the limits: {_describe(pc, i)}")
    mvc = np.where(np.isnan(x_hi), 0.0, x_hi)
    x, K = _pass(pc, zero, mvc, mvc)  # exact without viscous friction
    if viscous:
        # With it: the lines bound sqrt(x) on [0, X], X twice the frictionless controllable top (a speed 41 %
        # above it) within the maximal velocity curve; tangent at that top, then at each pass's solution.
        X = np.minimum(y_hi ** 2, 2.0 * K[:, 1])
        x, K = _pass(pc, pc.gamma, X, K[:, 1].copy())
        T = _duration(s, x)
        for _ in range(refine):
            x_new, K_new = _pass(pc, pc.gamma, X, np.minimum(x, X))
            T_new = _duration(s, x_new)
            if T_new <= T:
                x, K = x_new, K_new
            if T - T_new <= REFINE_RTOL * T:
                break
            T = min(T, T_new)
    sd = np.sqrt(x)
    sdd = np.diff(x) / (2.0 * np.diff(s))
    if np.any(sd[:-1] + sd[1:] <= 0.0):
        i = int(np.argmax(sd[:-1] + sd[1:] <= 0.0))
        raise RetimeInfeasibleError(f"retime: the arm comes to a standstill inside the path at s = {s[i]:.6g}: "
                                    "no motion past it stays within the limits")
    return SegmentSolution(s=s.copy(), sd=sd, sdd=sdd, K=K, y_limit=y_hi)


def _duration(s: Array, x: Array) -> float:
    with np.errstate(divide="ignore"):
        return float(np.sum(2.0 * np.diff(s) / (np.sqrt(x[:-1]) + np.sqrt(x[1:]))))
