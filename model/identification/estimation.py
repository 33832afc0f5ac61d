"""Estimating the base parameters from samples: ordinary and weighted least squares, and a physically
consistent fit.

The regression stacks, for every sample k and joint j, the equation ``tau_kj = Y_b(q_k, qd_k, qdd_k)_j beta``.

* **Equations at rest are left out**: where ``|qd_kj|`` is below :data:`REST_FRACTION` of joint j's
  99th-percentile speed (and at least :data:`REST_FLOOR`), the friction is static, not the model's
  ``fv qd + fc sign(qd)``; equation (k, j) is dropped.
* **Parameters the data do not excite** (a joint that barely moves, a log too short) are found by a QR
  decomposition with column pivoting of the unit-norm columns of ``W_b``: those past the rank (``|R_kk|``
  below :data:`DATA_RANK_TOL` of ``|R_00|``) keep the robot file's values and are reported as fixed.
* **OLS**: ``beta = argmin ||W_b beta - tau||``; per joint the noise variance
  ``sigma_j^2 = ||r_j||^2 / (m_j - nb m_j / m)`` from its ``m_j`` residuals (Gautier 1997).
* **WLS**: each joint's equations divided by ``sigma_j``, the deviations re-estimated from the WLS residuals
  until they settle (at most :data:`WLS_PASSES` times: OLS lets the joints with little torque keep large
  residuals); ``cov(beta) = s^2 (W^T W)^-1`` of the weighted
  system, ``s^2`` its residual variance; the standard deviations are the square roots of its diagonal.
* **Consistent**: the standard parameters themselves, each link's 4x4 pseudo-inertia ``J = L L^T``
  positive definite by construction (log-Cholesky: ``L`` lower triangular with diagonal ``exp(theta)``,
  Rucker & Wensing, "Smooth parameterization of rigid-body inertia", IEEE RA-L 7(2), 2022), rotor inertias,
  viscous and Coulomb friction >= 0, offsets free. IPOPT minimises the WLS cost
  ``||W_b K pi - tau||^2_w / ||tau||^2_w`` plus :data:`PRIOR_WEIGHT` times the scaled distance to the
  robot file's parameters (which fixes the standard parameters no torque determines), starting from the
  WLS solution projected onto the feasible set: the standard parameters nearest the file's with ``K pi =
  beta_wls``, each pseudo-inertia's eigenvalues raised to :data:`EIG_FLOOR` of its largest, negative
  friction and rotor inertias set to 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import casadi as ca
import numpy as np
import numpy.typing as npt
import scipy.linalg
from threadpoolctl import threadpool_limits

from ..errors import NumericalError
from .base import BaseParameters
from .parameters import PER_JOINT, inertial_from_pseudo, pseudo_inertia, standard_parameters
from .regressor import Regressor
from .signals import Samples

__all__ = [
    "DATA_RANK_TOL",
    "EIG_FLOOR",
    "FITS",
    "PRIOR_WEIGHT",
    "REST_FLOOR",
    "REST_FRACTION",
    "Fit",
    "Regression",
    "consistent_fit",
    "least_squares",
    "base_regressor",
    "regression",
]

Array = npt.NDArray[np.float64]

#: The fits, in the order they are computed.
FITS = ("ols", "wls", "consistent")
#: Equations with a joint speed below this fraction of the joint's 99th-percentile speed are dropped ...
REST_FRACTION = 0.02
#: ... and always those below this speed (rad/s or m/s).
REST_FLOOR = 1e-3
#: Relative ``|R_kk|`` of the unit-norm data columns below which a base parameter is not excited.
DATA_RANK_TOL = 1e-7
#: Most reweightings of WLS (the per-joint deviations re-estimated from the WLS residuals, until they move by
#: less than 1 %).
WLS_PASSES = 5
#: Smallest per-joint noise deviation, relative to the joint's RMS torque.
SIGMA_FLOOR = 1e-6
#: Weight of the distance to the robot file's parameters in the consistent fit (relative to the fit's cost,
#: which is a squared relative error: 1 % is 1e-4).
PRIOR_WEIGHT = 1e-6
#: Smallest eigenvalue of a projected pseudo-inertia, relative to its largest (log-Cholesky needs J > 0).
EIG_FLOOR = 1e-6


@dataclass(frozen=True, eq=False)
class Regression:
    """The stacked regression of a set of samples.

    Attributes
    ----------
    W
        (m, nb) base regressor rows kept (``m`` equations).
    tau
        (m,) torques of those rows.
    joint
        (m,) joint index of each row.
    sample
        (m,) sample index of each row.
    n
        Number of joints.
    W_all, moving
        (N n, nb) every sample's rows (sample-major), and which of them were kept.
    """

    W: Array
    tau: Array
    joint: Array
    sample: Array
    n: int
    W_all: Array
    moving: Array

    def rows_of(self, j: int) -> Array:
        return np.flatnonzero(self.joint == j)


def rest_speeds(qd: Array) -> Array:
    """(n,) the speed per joint below which an equation is left out (see the module docstring)."""
    return np.maximum(REST_FRACTION * np.percentile(np.abs(qd), 99, axis=0), REST_FLOOR)


#: Largest regressor array filtered at once, in values (the columns go through the filter in groups this size).
FILTER_BLOCK = 10_000_000


def base_regressor(regressor: Regressor, base: BaseParameters, samples: Samples) -> Array:
    """(K, n, nb) base regressor at the K kept samples; for filtered samples each column first goes through
    the samples' low-pass at the full rate (parallel filtering, :mod:`model.identification.signals`), in
    groups of columns that keep the array below :data:`FILTER_BLOCK` values."""
    if samples.lowpass is None:
        k = samples.kept()
        return base.columns(regressor.batch(k.q, k.qd, k.qdd))
    N, n = samples.q.shape
    cols = list(base.independent)
    group = max(1, FILTER_BLOCK // max(N * n, 1))
    chunk = max(1, FILTER_BLOCK // (n * regressor.size))
    out = np.empty((samples.keep.size, n, len(cols)))
    for g0 in range(0, len(cols), group):
        these = cols[g0:g0 + group]
        Y = np.empty((N, n, len(these)))
        for s0 in range(0, N, chunk):
            rows = slice(s0, s0 + chunk)
            Y[rows] = regressor.batch(samples.q[rows], samples.qd[rows], samples.qdd[rows])[:, :, these]
        out[:, :, g0:g0 + len(these)] = samples.lowpass(Y)[samples.keep]
    return out


def regression(Yb: Array, tau: Array, qd: Array, v_rest: Array) -> Regression:
    """The stacked regression of base regressors ``Yb`` (K, n, nb), torques ``tau`` and speeds ``qd`` (K, n),
    the equations with a speed below ``v_rest`` (n,) (at rest) left out."""
    K, n, nb = Yb.shape
    Wb = Yb.reshape(K * n, nb)
    moving = (np.abs(qd) >= v_rest[None, :]).ravel()
    joint = np.tile(np.arange(n), K)
    sample = np.repeat(np.arange(K), n)
    return Regression(W=Wb[moving], tau=tau.ravel()[moving], joint=joint[moving], sample=sample[moving], n=n,
                      W_all=Wb, moving=moving)


@dataclass(frozen=True, eq=False)
class Fit:
    """One estimate of the base parameters.

    Attributes
    ----------
    method
        ``"ols"``, ``"wls"`` or ``"consistent"``.
    beta
        (nb,) base parameters.
    std
        (nb,) standard deviations (least squares; NaN for a fixed parameter), or None (consistent fit).
    pi
        (p,) standard parameters (consistent fit), or None.
    info
        Solver details (IPOPT status, iterations, smallest pseudo-inertia eigenvalue per link, ...).
    """

    method: str
    beta: Array
    std: Array | None = None
    pi: Array | None = None
    info: Mapping[str, object] = field(default_factory=dict)

    def predict(self, W: Array) -> Array:
        return W @ self.beta


def _data_rank(W: Array) -> tuple[list[int], list[int]]:
    """Excited and not excited base columns of the data (pivoted QR of the unit-norm columns)."""
    norms = np.linalg.norm(W, axis=0)
    live = np.flatnonzero(norms > 0)
    R, piv = scipy.linalg.qr(W[:, live] / norms[live], mode="r", pivoting=True)
    d = np.abs(np.diag(R))
    r = int(np.count_nonzero(d > DATA_RANK_TOL * d[0])) if d.size else 0
    excited = sorted(int(live[k]) for k in piv[:r])
    return excited, [k for k in range(W.shape[1]) if k not in excited]


def least_squares(reg: Regression, beta_prior: Array) -> tuple[Fit, Fit, Array, list[int]]:
    """OLS and WLS fits of the regression, the per-joint noise deviations and the base parameters fixed
    at ``beta_prior`` (not excited by these data).

    Raises
    ------
    NumericalError
        No base parameter is excited, or a joint has fewer equations than its share of the parameters.
    """
    excited, fixed = _data_rank(reg.W)
    if not excited:
        raise NumericalError("identification: the data excite no base parameter (does the arm move?)")
    W, tau = reg.W[:, excited], reg.tau - reg.W[:, fixed] @ beta_prior[fixed]
    m, nb = W.shape
    b_ols = np.linalg.lstsq(W, tau, rcond=None)[0]
    r = tau - W @ b_ols
    std_ols = _std(W, r, m - nb)
    sigma = _joint_sigma(reg, r, nb)
    for _ in range(WLS_PASSES):  # OLS leaves the quiet joints' residuals too large: reweight from the WLS residuals
        w = 1.0 / sigma[reg.joint]
        Ww, tw = W * w[:, None], tau * w
        b_wls = np.linalg.lstsq(Ww, tw, rcond=None)[0]
        sigma_new = _joint_sigma(reg, tau - W @ b_wls, nb)
        done = np.allclose(sigma_new, sigma, rtol=0.01)
        sigma = sigma_new
        if done:
            break
    w = 1.0 / sigma[reg.joint]
    Ww, tw = W * w[:, None], tau * w
    b_wls = np.linalg.lstsq(Ww, tw, rcond=None)[0]
    std_wls = _std(Ww, tw - Ww @ b_wls, m - nb)

    def full(values: Array, fill: Array) -> Array:
        out = fill.astype(float).copy()
        out[excited] = values
        return out

    nan = np.full(beta_prior.size, math.nan)
    ols = Fit("ols", full(b_ols, beta_prior), full(std_ols, nan), info={"fixed": fixed})
    wls = Fit("wls", full(b_wls, beta_prior), full(std_wls, nan), info={"fixed": fixed})
    return ols, wls, sigma, fixed


def _joint_sigma(reg: Regression, r: Array, nb: int) -> Array:
    """(n,) per-joint residual deviations, each joint's degrees of freedom its share of ``m - nb``, at least
    :data:`SIGMA_FLOOR` of the joint's RMS torque (exact data leave residuals of rounding, whose ratios would
    weight the joints at random); a joint without equations gets 1."""
    m = r.size
    sigma = np.ones(reg.n)
    for j in range(reg.n):
        rows = reg.rows_of(j)
        dof = rows.size - nb * rows.size / m
        if dof > 0:
            floor = SIGMA_FLOOR * math.sqrt(reg.tau[rows] @ reg.tau[rows] / rows.size)
            sigma[j] = max(math.sqrt(r[rows] @ r[rows] / dof), floor, 1e-300)
    return sigma


def _std(W: Array, r: Array, dof: int) -> Array:
    s2 = (r @ r) / dof if dof > 0 else math.nan
    R = np.linalg.qr(W, mode="r")
    Rinv = scipy.linalg.solve_triangular(R, np.eye(R.shape[0]))
    return np.sqrt(s2 * np.sum(Rinv * Rinv, axis=1))  # diag((R^T R)^-1) = row sums of Rinv^2


def _scales(desc, pi_prior: Array, samples: Samples) -> Array:
    """(p,) the scale of each standard parameter for the prior term: a link mass M, a length l (the mean
    joint offset, at least 0.1 m), first moments M l, inertias M l^2; friction from the torques and speeds."""
    from ..chain import build_chain

    n = desc.n
    masses = pi_prior[0::PER_JOINT]
    M = max(float(np.mean(np.abs(masses))), 1e-3) if np.any(masses) else 1.0
    chain = build_chain(desc)
    ell = max(float(np.mean([np.linalg.norm(P[:3, 3]) for P in chain.placements[1:]] or [0.0])), 0.1)
    tau_scale = np.maximum(np.abs(samples.tau).max(axis=0), 1e-3)
    qd_scale = np.maximum(np.abs(samples.qd).max(axis=0), 1e-3)
    out = np.empty(PER_JOINT * n)
    for i in range(n):
        o = PER_JOINT * i
        out[o] = M
        out[o + 1:o + 4] = M * ell
        out[o + 4:o + 10] = M * ell * ell
        out[o + 10] = M * ell * ell
        out[o + 11] = tau_scale[i] / qd_scale[i]
        out[o + 12] = tau_scale[i]
        out[o + 13] = tau_scale[i]
    return out


def _projected_start(base: BaseParameters, beta: Array, pi_prior: Array, scale: Array) -> Array:
    """The standard parameters nearest the prior (in ``scale`` units) with ``K pi = beta``, then made feasible."""
    K = base.K * scale[None, :]
    delta = np.linalg.lstsq(K, beta - base.K @ pi_prior, rcond=None)[0]
    pi = pi_prior + scale * delta
    n = pi.size // PER_JOINT
    for i in range(n):
        o = PER_JOINT * i
        pi[o:o + 10] = inertial_from_pseudo(_pd(pseudo_inertia(pi[o:o + 10]), scale[o + 4]))
        pi[o + 10:o + 13] = np.maximum(pi[o + 10:o + 13], 0.0)
    return pi


def _pd(J: Array, inertia_scale: float) -> Array:
    """``J`` with its eigenvalues raised to at least :data:`EIG_FLOOR` of the largest (or of the link's scale)."""
    lam, V = np.linalg.eigh(0.5 * (J + J.T))
    floor = EIG_FLOOR * max(float(lam.max()), inertia_scale)
    return (V * np.maximum(lam, floor)) @ V.T


def _cholesky_params(J: Array) -> Array:
    """Log-Cholesky coordinates of a positive definite ``J`` (already divided by its link's scale)."""
    L = np.linalg.cholesky(J)
    return np.concatenate([np.log(np.diag(L)), L[np.tril_indices(4, -1)]])


def _pseudo_sx(theta: ca.SX) -> ca.SX:
    L = ca.SX.zeros(4, 4)
    for k in range(4):
        L[k, k] = ca.exp(theta[k])
    for k, (r, c) in enumerate(zip(*np.tril_indices(4, -1))):
        L[int(r), int(c)] = theta[4 + k]
    return L @ L.T


def _inertial_sx(J: ca.SX) -> ca.SX:
    """(10,) inertial parameters of a symbolic pseudo-inertia (as :func:`inertial_from_pseudo`)."""
    S = J[0:3, 0:3]
    tr = S[0, 0] + S[1, 1] + S[2, 2]
    I = tr * ca.SX.eye(3) - S
    return ca.vertcat(J[3, 3], J[0:3, 3], I[0, 0], I[0, 1], I[1, 1], I[0, 2], I[1, 2], I[2, 2])


def consistent_fit(regressor: Regressor, base: BaseParameters, reg: Regression, sigma: Array, beta_start: Array,
                   samples: Samples, *, max_iter: int = 500,
                   progress: Callable[[str], None] | None = None) -> Fit:
    """The physically consistent fit (see the module docstring), from the projected ``beta_start``.

    Raises
    ------
    NumericalError
        IPOPT fails to return a finite point.
    """
    desc = regressor.description
    n = desc.n
    pi_prior = standard_parameters(desc)
    scale = _scales(desc, pi_prior, samples)
    pi0 = _projected_start(base, beta_start, pi_prior, scale)
    w = 1.0 / sigma[reg.joint]
    A = reg.W * w[:, None]
    b = reg.tau * w
    # ||A beta - b||^2 = ||R beta - d||^2 + ||b||^2 - ||d||^2 (A = Q R): a sum of nb squares, no cancellation
    R = np.linalg.qr(A, mode="r")
    d = np.linalg.lstsq(R.T, A.T @ b, rcond=None)[0] if R.shape[0] == R.shape[1] else A.T @ b
    bb = float(b @ b) or 1.0
    floor = max(bb - float(d @ d), 0.0)
    theta = ca.SX.sym("theta", 10 * n)
    joint = ca.SX.sym("joint", 4 * n)
    # Each link's pseudo-inertia is s_i L L^T with s_i its start's largest eigenvalue, so that L is of order 1;
    # each joint parameter is scaled by its prior scale.
    J0 = [pseudo_inertia(pi0[PER_JOINT * i:PER_JOINT * i + 10]) for i in range(n)]
    s_link = [max(float(np.linalg.eigvalsh(J).max()), scale[PER_JOINT * i + 4]) for i, J in enumerate(J0)]
    s_joint = np.concatenate([scale[PER_JOINT * i + 10:PER_JOINT * i + 14] for i in range(n)])
    parts = []
    for i in range(n):
        parts.append(_inertial_sx(s_link[i] * _pseudo_sx(theta[10 * i:10 * i + 10])))
        parts.append(joint[4 * i:4 * i + 4] * ca.DM(s_joint[4 * i:4 * i + 4]))
    pi = ca.vertcat(*parts)
    beta = ca.DM(base.K) @ pi
    res = ca.DM(R) @ beta - ca.DM(d)
    cost = (ca.dot(res, res) + floor) / bb
    dev = (pi - ca.DM(pi_prior)) / ca.DM(scale)
    x = ca.vertcat(theta, joint)
    f = cost + PRIOR_WEIGHT * ca.dot(dev, dev)
    x0 = np.concatenate([_cholesky_params(J / s) for J, s in zip(J0, s_link)]
                        + [pi0[PER_JOINT * i + 10:PER_JOINT * i + 14] / s_joint[4 * i:4 * i + 4] for i in range(n)])
    lbx = np.concatenate([np.full(10 * n, -np.inf), np.tile([0.0, 0.0, 0.0, -np.inf], n)])
    opts = {"ipopt.max_iter": int(max_iter), "ipopt.tol": 1e-10, "ipopt.acceptable_tol": 1e-6, "ipopt.acceptable_obj_change_tol": 1e-9, "ipopt.acceptable_iter": 10, "ipopt.print_level": 0, "ipopt.sb": "yes",
            "print_time": False}
    solver = ca.nlpsol("consistent", "ipopt", {"x": x, "f": f}, opts)
    with threadpool_limits(1, user_api="blas"):
        sol = solver(x0=x0, lbx=lbx)
    stats = solver.stats()
    pi_fun = ca.Function("pi", [x], [pi])
    pi_hat = np.array(pi_fun(sol["x"])).ravel()
    if not np.all(np.isfinite(pi_hat)):
        raise NumericalError(f"consistent fit of {desc.name!r}: IPOPT ended ({stats['return_status']}) without a finite point")
    lams = [np.linalg.eigvalsh(pseudo_inertia(pi_hat[PER_JOINT * i:PER_JOINT * i + 10])) for i in range(n)]
    info = {"status": str(stats["return_status"]), "iterations": int(stats.get("iter_count", 0)),
            "min_pseudo_inertia_eigenvalue": [float(lam.min()) for lam in lams],
            "pseudo_inertia_eigenvalue_ratio": [float(lam.min() / lam.max()) if lam.max() > 0 else 0.0 for lam in lams],
            "cost": float(sol["f"])}
    if progress is not None:
        progress(f"consistent fit: IPOPT {info['status']} after {info['iterations']} iterations")
    return Fit("consistent", base.K @ pi_hat, pi=pi_hat, info=info)

