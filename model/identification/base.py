"""Base parameters: the combinations of the standard parameters that the joint torques determine.

Many standard parameters never change a torque (the mass of a link on a vertical first joint), or change
it only in fixed combinations with others (a link's mass and the first moments of the link before it).
The base parameters ``beta = K pi`` are a maximal set of independent combinations:
``Y(q, qd, qdd) pi = Y_b(q, qd, qdd) beta`` for every state, with ``Y_b`` the columns ``independent``
of ``Y``.

They are found numerically (Gautier 1990), for any robot:

1. ``Y`` is stacked at random states (joint values uniform within the limits, :func:`model.tasks.finite_limits`;
   velocities and accelerations uniform in [-1, 1]): ``W``, ``N n`` rows, seeded;
2. each column is scaled to unit norm; columns below :data:`ZERO_COLUMN` of the largest never act;
3. the rank ``r`` is that of a QR decomposition with column pivoting, counting ``|R_kk| > RANK_TOL |R_00|``;
4. the ``r`` independent columns are chosen by a QR without pivoting in a fixed preference order (link by
   link, base to tip; in each link ``I_zz, I_xx, I_xy, I_xz, I_yz, I_yy, mc_x, mc_y, mc_z, m``, then
   ``Ia, fv, fc, off``): a column is dependent when it adds less than ``RANK_TOL`` to the span of those
   before it, so masses and ``I_yy`` are regrouped into earlier parameters, as in the classical tables;
   the count must equal the pivoted rank;
5. each dependent column is the least-squares combination of the independent ones, which gives ``K``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import numpy.typing as npt
import scipy.linalg

from ..errors import NumericalError
from ..tasks import finite_limits
from .parameters import INERTIAL_FIELDS, JOINT_FIELDS, PER_JOINT, ParameterKind, parameter_kinds, parameter_names
from .regressor import Regressor

__all__ = ["BaseParameters", "RANK_TOL", "ZERO_COLUMN", "base_parameters", "random_states"]

Array = npt.NDArray[np.float64]

#: Relative size of ``|R_kk|`` (unit-norm columns) below which a column adds nothing new. Random states give
#: independent columns ``|R_kk|`` above 1e-5 on the built-ins and dependent ones below 1e-12.
RANK_TOL = 1e-8
#: A column whose norm is below this fraction of the largest never acts on a torque.
ZERO_COLUMN = 1e-12
#: Entries of ``K`` below this (relative to the unit-norm columns) are rounding of an exact 0.
_K_TOL = 1e-9
_PREFERENCE = ("I_zz", "I_xx", "I_xy", "I_xz", "I_yz", "I_yy", "mc_x", "mc_y", "mc_z", "m") + JOINT_FIELDS


@dataclass(frozen=True, eq=False)
class BaseParameters:
    """The base parameters ``beta = K pi`` of one robot.

    Attributes
    ----------
    names
        (p,) names of the standard parameters (:func:`~model.identification.parameters.parameter_names`).
    independent
        (nb,) indices into ``pi`` of the columns of ``Y`` that form ``Y_b``; base parameter k is
        ``pi[independent[k]]`` plus the dependent parameters regrouped into it.
    K
        (nb, p) ``beta = K pi``; ``K[:, independent]`` is the identity.
    """

    names: tuple[str, ...]
    independent: tuple[int, ...]
    K: Array

    @property
    def n_base(self) -> int:
        """Number of base parameters."""
        return len(self.independent)

    @property
    def base_names(self) -> tuple[str, ...]:
        """A name per base parameter: its independent standard parameter, with ``R`` when others are regrouped
        into it (``I_zz1R``)."""
        out = []
        for k, j in enumerate(self.independent):
            regrouped = np.count_nonzero(self.K[k]) > 1
            out.append(self.names[j] + ("R" if regrouped else ""))
        return tuple(out)

    def beta(self, pi: npt.ArrayLike) -> Array:
        """(nb,) base parameters of the standard parameters ``pi`` (p,)."""
        return self.K @ np.asarray(pi, dtype=float)

    def columns(self, Y: npt.ArrayLike) -> Array:
        """The base regressor: the ``independent`` columns of ``Y`` (any leading shape, last axis p)."""
        return np.asarray(Y)[..., list(self.independent)]

    def expressions(self, digits: int = 6) -> tuple[str, ...]:
        """Each base parameter as a sum of standard ones, e.g. ``"I_zz1 + Ia_1 + 0.18645 m_2 - I_xx2"`` (that of ``I_zz1R``): the
        independent parameter first, then those regrouped into it."""
        return tuple(_expression(row, self.names, digits, j) for row, j in zip(self.K, self.independent))


def _expression(row: Array, names: Sequence[str], digits: int, first: int) -> str:
    """The sum ``row . pi`` in words, the independent parameter ``first`` first, the others in vector order."""
    terms = []
    for j in [first, *(k for k in np.flatnonzero(row) if k != first)]:
        c = float(row[j])
        mag = abs(c)
        coef = "" if abs(mag - 1.0) < 1e-12 else f"{mag:.{digits}g} "
        sign = "-" if c < 0 else "+"
        terms.append((sign, f"{coef}{names[j]}"))
    if not terms:
        return "0"
    text = ("-" if terms[0][0] == "-" else "") + terms[0][1]
    for sign, term in terms[1:]:
        text += f" {sign} {term}"
    return text


def random_states(desc, N: int, seed: int = 0) -> tuple[Array, Array, Array]:
    """``N`` random states (each (N, n)): q uniform in the finite joint limits, qd and qdd uniform in [-1, 1]."""
    rng = np.random.default_rng(seed)
    lim = finite_limits(desc)
    Q = rng.uniform(lim[0], lim[1], (N, desc.n))
    return Q, rng.uniform(-1.0, 1.0, (N, desc.n)), rng.uniform(-1.0, 1.0, (N, desc.n))


def base_parameters(regressor: Regressor, *, kinds: Sequence[str] = ParameterKind.ALL, samples: int | None = None,
                    seed: int = 0) -> BaseParameters:
    """The base parameters of the robot of ``regressor`` (see the module docstring for the method).

    Parameters
    ----------
    regressor
        The compiled regressor of the robot.
    kinds
        Which groups of standard parameters to consider (:class:`~model.identification.parameters.ParameterKind`);
        the others are left out (e.g. ``("inertial",)`` for the inertial base parameters of the literature).
    samples
        Random states stacked (default ``max(40, 3 p / n)``, at least three equations per parameter).
    seed
        Seed of the random states.

    Raises
    ------
    NumericalError
        The pivoted and the ordered QR disagree on the rank (the tolerance met a nearly dependent column).
    """
    desc = regressor.description
    n, p = desc.n, regressor.size
    names = parameter_names(n)
    considered = [j for j, kind in enumerate(parameter_kinds(n)) if kind in kinds]
    N = samples if samples is not None else max(40, -(-3 * p // n))
    W = regressor.batch(*random_states(desc, N, seed)).reshape(N * n, p)
    norms = np.linalg.norm(W, axis=0)
    active = [j for j in considered if norms[j] > ZERO_COLUMN * norms.max()]
    Ws = W[:, active] / norms[active]
    R_piv = scipy.linalg.qr(Ws, mode="r", pivoting=True)[0]
    d_piv = np.abs(np.diag(R_piv))
    rank = int(np.count_nonzero(d_piv > RANK_TOL * d_piv[0]))
    rank_in = {f: r for r, f in enumerate(_PREFERENCE)}
    order = sorted(range(len(active)), key=lambda k: (active[k] // PER_JOINT, rank_in[_field(active[k])]))
    R = scipy.linalg.qr(Ws[:, order], mode="r")[0]
    d = np.abs(np.diag(R))
    chosen = sorted(active[order[k]] for k in range(len(order)) if d[k] > RANK_TOL)
    if len(chosen) != rank:
        raise NumericalError(f"base parameters of {desc.name!r}: the pivoted QR finds rank {rank}, the ordered QR "
                             f"{len(chosen)} independent columns (tolerance {RANK_TOL:g})")
    dependent = [j for j in active if j not in chosen]
    K = np.zeros((rank, p))
    K[np.arange(rank), chosen] = 1.0
    if dependent:
        Xs = np.linalg.lstsq(Ws[:, [active.index(j) for j in chosen]], Ws[:, [active.index(j) for j in dependent]],
                             rcond=None)[0]
        Xs[np.abs(Xs) < _K_TOL] = 0.0
        # back from unit-norm columns: W_d = W_b X with X = diag(1/|W_b|) Xs diag(|W_d|)
        X = Xs * norms[dependent][None, :] / norms[chosen][:, None]
        K[:, dependent] = X
    return BaseParameters(names=names, independent=tuple(chosen), K=K)


def _field(j: int) -> str:
    return (*INERTIAL_FIELDS, *JOINT_FIELDS)[j % PER_JOINT]
