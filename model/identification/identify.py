"""The identification pipeline: samples in, the three fits, their errors on the fit and held-out data out.

:func:`identify` splits the samples chronologically (the last ``holdout`` share, 30 % by default, is
kept for validation), stacks the base regression of each part (:func:`~model.identification.estimation.regression`,
equations at rest left out by the speed threshold of the fit part), computes OLS, WLS and the
consistent fit, and for each the errors::

    relative_error          ||tau - W_b beta|| / ||tau||   on the fit part
    rms_holdout             per joint, sqrt(mean((tau_j - W_b,j beta)^2)) on the held-out part, N m or N
    relative_error_holdout  ||tau - W_b beta|| / ||tau||   on the held-out part

The consistent fit's standard parameters are the ones a robot file can hold
(:mod:`model.identification.robot_file`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np
import numpy.typing as npt
from threadpoolctl import threadpool_limits

from ..errors import InputError
from ..joint_table import JointTable
from .base import BaseParameters, base_parameters
from .estimation import FITS, Fit, Regression, base_regressor, consistent_fit, least_squares, regression, rest_speeds
from .parameters import PER_JOINT, standard_parameters
from .regressor import Regressor
from .signals import Preprocessing, Samples, prepare_samples

__all__ = ["DEFAULT_HOLDOUT", "FitErrors", "Identification", "identify", "identify_log"]

Array = npt.NDArray[np.float64]

#: Share of the samples, at the end of the log, held out for validation.
DEFAULT_HOLDOUT = 0.3


@dataclass(frozen=True)
class FitErrors:
    """A fit's torque errors (see the module docstring)."""

    relative_error: float
    rms_holdout: tuple[float, ...]
    relative_error_holdout: float
    rms_fit: tuple[float, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"relative_error": self.relative_error, "rms_holdout": list(self.rms_holdout),
                "relative_error_holdout": self.relative_error_holdout, "rms_fit": list(self.rms_fit)}


@dataclass(frozen=True, eq=False)
class Identification:
    """The result of :func:`identify`.

    Attributes
    ----------
    base
        The robot's base parameters.
    fits
        ``"ols"``, ``"wls"``, ``"consistent"`` -> :class:`~model.identification.estimation.Fit`.
    errors
        The same keys -> :class:`FitErrors`.
    chosen
        The fit the robot file is written from (``"consistent"``).
    sigma
        (n,) per-joint torque noise deviation from the OLS residuals, N m or N.
    fixed
        Indices of base parameters the data do not excite (kept at the robot file's values).
    condition_number
        ``cond(W_b)`` of the fit equations.
    fit, holdout
        The two parts of the samples; ``holdout`` may be empty (``holdout=0``).
    v_rest
        (n,) speeds below which equations were left out.
    equations
        Equations used in the fit and held-out parts, and left out at rest (per joint).
    preprocessing
        What was done to the log, when it came from one (:func:`identify_log`).
    seconds
        Wall time.
    """

    base: BaseParameters
    fits: Mapping[str, Fit]
    errors: Mapping[str, FitErrors]
    chosen: str
    sigma: Array
    fixed: tuple[int, ...]
    condition_number: float
    fit: Samples
    holdout: Samples
    v_rest: Array
    equations: Mapping[str, Any]
    preprocessing: Preprocessing | None = None
    seconds: float = 0.0
    regressions: Mapping[str, Regression] = field(default_factory=dict, repr=False)

    @property
    def pi(self) -> Array:
        """(p,) standard parameters of the chosen fit."""
        pi = self.fits[self.chosen].pi
        assert pi is not None
        return pi

    def to_dict(self) -> dict[str, Any]:
        """The JSON view (``identification.json``): ``n_base``, ``condition_number``, ``relative_error``,
        ``rms_holdout``, ``relative_error_holdout`` (the chosen fit's), ``base_parameters`` (name, expression,
        each fit's value, the WLS standard deviation, fixed or not), ``fit`` (the chosen one), then the
        details: every fit's errors and solver information, the noise deviations, the equations used, the
        consistent fit's standard parameters and torque offsets, and the preprocessing."""
        chosen = self.errors[self.chosen]
        wls = self.fits["wls"]
        names, exprs = self.base.base_names, self.base.expressions()
        params = []
        for k in range(self.base.n_base):
            std = float(wls.std[k]) if wls.std is not None and math.isfinite(wls.std[k]) else None
            value = float(self.fits[self.chosen].beta[k])
            entry = {"name": names[k], "expression": exprs[k], "value": value, "std": std,
                     "std_percent": None if std is None or value == 0 else 100.0 * std / abs(value),
                     "fixed": k in self.fixed}
            entry.update({m: float(f.beta[k]) for m, f in self.fits.items()})
            params.append(entry)
        fits = {}
        for m, f in self.fits.items():
            fits[m] = {**self.errors[m].to_dict(), **{k: _jsonable(v) for k, v in f.info.items()}}
        out: dict[str, Any] = {
            "n_base": self.base.n_base,
            "condition_number": self.condition_number,
            "relative_error": chosen.relative_error,
            "rms_holdout": list(chosen.rms_holdout),
            "relative_error_holdout": chosen.relative_error_holdout,
            "base_parameters": params,
            "fit": self.chosen,
            "fits": fits,
            "sigma": self.sigma.tolist(),
            "samples": {"fit": len(self.fit), "holdout": len(self.holdout)},
            "equations": dict(self.equations),
            "rest_speed": self.v_rest.tolist(),
            "seconds": self.seconds,
        }
        pi = self.fits[self.chosen].pi
        if pi is not None:
            out["standard_parameters"] = dict(zip(self.base.names, (float(v) for v in pi)))
            out["torque_offset"] = [float(v) for v in pi[PER_JOINT - 1::PER_JOINT]]
        if self.preprocessing is not None:
            out["preprocessing"] = self.preprocessing.to_dict()
        return _jsonable(out)

    def predicted(self, part: str, method: str | None = None) -> Array:
        """(N, n) torques predicted by a fit (default the chosen one) on the ``"fit"`` or ``"holdout"`` samples,
        every sample (those at rest included)."""
        reg = self.regressions[part]
        beta = self.fits[method or self.chosen].beta
        return (reg.W_all @ beta).reshape(-1, reg.n)


def _jsonable(value: Any) -> Any:
    """``value`` with numpy numbers as Python ones and NaN or infinities as None (valid JSON)."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def _errors(reg_fit: Regression, reg_hold: Regression, beta: Array, n: int) -> FitErrors:
    def rel(reg: Regression) -> float:
        if reg.tau.size == 0:
            return math.nan
        return float(np.linalg.norm(reg.tau - reg.W @ beta) / max(np.linalg.norm(reg.tau), 1e-300))

    def rms(reg: Regression) -> tuple[float, ...]:
        r = reg.tau - reg.W @ beta
        return tuple(float(np.sqrt(np.mean(r[reg.joint == j] ** 2))) if np.any(reg.joint == j) else math.nan
                     for j in range(n))

    return FitErrors(relative_error=rel(reg_fit), rms_holdout=rms(reg_hold), relative_error_holdout=rel(reg_hold),
                     rms_fit=rms(reg_fit))


def identify(robot: Any, samples: Samples, *, holdout: float = DEFAULT_HOLDOUT, regressor: Regressor | None = None,
             base: BaseParameters | None = None, consistent: bool = True,
             progress: Callable[[str], None] | None = None) -> Identification:
    """Identify the base parameters of ``robot`` (a :class:`model.Robot` or a description) from ``samples``.

    Parameters
    ----------
    robot
        The robot: its geometry (the regressor) and its file's parameters (the prior of the consistent fit,
        the values of parameters the data do not excite).
    samples
        Joint positions, velocities, accelerations and torques (:func:`~model.identification.signals.prepare_samples`
        makes them from a log).
    holdout
        Share of the samples, at the end, kept for validation (0 <= holdout < 0.9).
    regressor, base
        The robot's compiled regressor and base parameters, when the caller has them.
    consistent
        Also compute the physically consistent fit (the chosen one); False: WLS only is chosen.
    progress
        Called with a line per step.

    Raises
    ------
    InputError
        A holdout share out of range, or samples of another number of joints.
    model.errors.NumericalError
        The data excite no base parameter, or a fit fails.
    """
    t0 = time.perf_counter()
    desc = getattr(robot, "description", robot)
    n = desc.n
    if not (0 <= holdout < 0.9):
        raise InputError(f"holdout: expected a share from 0 to 0.9 of the samples, got {holdout!r}")
    if samples.q.shape[1] != n:
        raise InputError(f"samples: {samples.q.shape[1]} joints, the robot {desc.name!r} has {n}")
    say = progress or (lambda line: None)
    reg = regressor if regressor is not None else Regressor(desc)
    base = base if base is not None else base_parameters(reg)
    with threadpool_limits(1, user_api="blas"):
        Yb = base_regressor(reg, base, samples)
    kept = samples.kept()
    N = len(kept)
    split = N - int(round(holdout * N))
    part_fit, part_hold = kept.select(slice(0, split)), kept.select(slice(split, N))
    v_rest = rest_speeds(part_fit.qd)
    reg_fit = regression(Yb[:split], part_fit.tau, part_fit.qd, v_rest)
    reg_hold = regression(Yb[split:], part_hold.tau, part_hold.qd, v_rest)
    beta_prior = base.beta(standard_parameters(desc))
    say(f"{reg_fit.tau.size} equations in the fit part ({split} samples), {reg_hold.tau.size} held out "
        f"({N - split} samples); {base.n_base} base parameters")
    ols, wls, sigma, fixed = least_squares(reg_fit, beta_prior)
    fits = {"ols": ols, "wls": wls}
    chosen = "wls"
    if consistent:
        fits["consistent"] = consistent_fit(reg, base, reg_fit, sigma, wls.beta, part_fit, progress=progress)
        chosen = "consistent"
    errors = {m: _errors(reg_fit, reg_hold, fits[m].beta, n) for m in FITS if m in fits}
    s = np.linalg.svd(reg_fit.W, compute_uv=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    moving = lambda reg_: [int(np.count_nonzero(reg_.joint == j)) for j in range(n)]  # noqa: E731
    equations = {"fit": moving(reg_fit), "holdout": moving(reg_hold),
                 "at_rest_fit": [split - k for k in moving(reg_fit)],
                 "at_rest_holdout": [N - split - k for k in moving(reg_hold)]}
    return Identification(base=base, fits=fits, errors=errors, chosen=chosen, sigma=sigma, fixed=tuple(fixed),
                          condition_number=cond, fit=part_fit, holdout=part_hold, v_rest=v_rest, equations=equations,
                          seconds=time.perf_counter() - t0, regressions={"fit": reg_fit, "holdout": reg_hold})


def identify_log(robot: Any, table: JointTable, *, cutoff_hz: float | None = None, decimation: int | None = None,
                 holdout: float = DEFAULT_HOLDOUT, regressor: Regressor | None = None,
                 base: BaseParameters | None = None,
                 progress: Callable[[str], None] | None = None) -> Identification:
    """:func:`identify` on a measured log (a :class:`~model.joint_table.JointTable` with groups ``q``, ``tau`` and
    optionally ``qd``), prepared by :func:`~model.identification.signals.prepare_samples`."""
    samples, info = prepare_samples(table.t, table["q"], table["tau"], table["qd"] if "qd" in table else None,
                                    cutoff_hz=cutoff_hz, decimation=decimation)
    result = identify(robot, samples, holdout=holdout, regressor=regressor, base=base, progress=progress)
    return dataclasses.replace(result, preprocessing=info)

