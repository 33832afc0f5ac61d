"""The numeric checks of ``validate-fmu``, written once for FMI 2.0 and 3.0 over :class:`fmu.instance.Instance`.

* :func:`tracking_error` and :func:`tracking_checks`: an FMU run (Co-Simulation or Model Exchange) against
  the reference response (:mod:`fmu.reference`), relative to the motion's scales;
* :func:`state_roundtrip`: a Co-Simulation run saved (get FMU state), continued, restored and continued
  again, and deserialised in a second instance; Model Exchange derivatives after restoring; every
  continuation bit for bit (a :class:`RoundTrip`);
* :func:`directional_derivative_error`: directional derivatives of the state derivatives and outputs with
  respect to every state, input and tunable parameter (scalar or array element) against Richardson-combined
  central differences (:func:`fd_mismatch`), and, where the FMU provides them (FMI 3.0), the adjoint
  derivatives against the forward ones (one Jacobian: its transpose, to rounding).

Variables are scalar names (``q[2]``: an FMI 2.0 variable or an FMI 3.0 array element,
:meth:`fmu.opened.OpenedFmu.select`); every FMI call goes through the adapter's choke point, so a refused
call raises :class:`fmu.instance.FmuCallError`.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, Callable, NamedTuple, Sequence

import numpy as np

from model.errors import InputError

from .opened import OpenedFmu, open_fmu
from .reference import DIVERGENCE_GAIN
from .report import Check, RoundTrip, TrackingError

if TYPE_CHECKING:
    from .instance import Instance

__all__ = ["FD_LADDER", "ME_RTOL", "TOLERANCES", "DerivativeErrors", "RoundTrip", "TrackingError",
           "directional_derivative_error", "fd_mismatch", "state_roundtrip", "tracking_checks", "tracking_error"]

ME_RTOL = 1e-10
#: Acceptance limits, all relative: tracking errors are divided by the motion scale of the reference
#: (largest joint excursion, largest joint speed, largest tool excursion over the horizon).
TOLERANCES = {
    # CVode's local error control at ME_RTOL: global errors of rtol x (up to ~1e3 steps and restarts at the
    # input switches) x amplification (at most DIVERGENCE_GAIN over the horizon); seen 8e-6 on the Puma 560
    "me": 1e3 * ME_RTOL * DIVERGENCE_GAIN,
    # RK4 against the reference: at most this many times RK4's own error, estimated by a second run at
    # half the internal step (Richardson: err(h) ~ 16/15 |x_h - x_h/2|) ...
    "cs_richardson": 10.0,
    # ... plus this floor: the reference's rtol 1e-11 amplified DIVERGENCE_GAIN times, x 10 (seen 7e-12, Puma)
    "cs_floor": 10 * 1e-11 * DIVERGENCE_GAIN,
    "cosim": 1e-12,      # libcosim against FMPy, relative to the state scale: the same binary, the same arithmetic
    # the FMU's Co-Simulation against the plant's rule at the FMU's internal step, relative: the same C rule on the
    # same generated expressions (built twice), so rounding only, amplified at most DIVERGENCE_GAIN times: 1e-16 x 1e3
    # x 10 (seen 0 on the SCARA and the Puma 560: the two builds compute bit for bit the same)
    "plant": 1e-12,
    "directional": 1e-6, # |AD - FD| / (1 + |FD|), best of Richardson-combined central differences, steps 1e-4..1e-7
}
#: Rungs of the finite-difference ladder of the directional-derivative checks: steps rel_step x 10^-k.
FD_LADDER = 4


# ---------------------------------------------------------------- tracking

def _scale(x: float) -> float:
    """A motion scale, kept off zero for an arm that does not move (1e-9 of the unit)."""
    return max(float(x), 1e-9)


def tracking_error(label: str, t: np.ndarray, X: np.ndarray, P: np.ndarray, t_ref: np.ndarray,
                   X_ref: np.ndarray, P_ref: np.ndarray) -> TrackingError:
    """Compare states ``X`` and tool positions ``P`` sampled at ``t`` with the reference at ``t_ref``."""
    # the last sample at each time: Model Exchange results repeat the time of an event (before, after)
    idx = [t.size - 1 - int(np.argmin(np.abs(t[::-1] - tr))) for tr in t_ref]
    if np.max(np.abs(t[idx] - t_ref)) > 1e-9:
        raise InputError("the run does not sample every reference time", parameter="tracking_error")
    n = X.shape[1] // 2
    dX = np.abs(X[idx] - X_ref)
    dP = np.linalg.norm(P[idx] - P_ref, axis=1)
    q_scale = _scale(np.max(np.abs(X_ref[:, :n] - X_ref[0, :n])))
    qd_scale = _scale(np.max(np.abs(X_ref[:, n:])))
    p_scale = _scale(np.max(np.linalg.norm(P_ref - P_ref[0], axis=1)))
    return TrackingError(label, float(t_ref[-1] - t_ref[0]), dX[:, :n].max(axis=0), dX[:, n:].max(axis=0),
                         float(dP.max()), q_scale, qd_scale, p_scale)


#: The figures of one tracking comparison, in the order :func:`tracking_checks` gives them.
TRACKED = ("q", "qd", "tool")


def tracking_checks(e: TrackingError, kind: str, bound: float, basis: str) -> list[Check]:
    """The checks ``{kind} q``, ``{kind} qd`` and ``{kind} tool`` of tracking error ``e`` against ``bound``."""
    rel = e.relative
    return [
        Check(f"{kind} q", rel["q"], bound, f"max|q - q_ref| / {e.q_scale:.3g} (largest joint excursion), {basis}"),
        Check(f"{kind} qd", rel["qd"], bound, f"max|qd - qd_ref| / {e.qd_scale:.3g} (largest joint speed), {basis}"),
        Check(f"{kind} tool", rel["tool"], bound,
              f"max|p_tool - p_ref| / {e.p_scale:.3g} m (largest tool excursion), {basis}"),
    ]


# ------------------------------------------------------------- FMU states

def state_roundtrip(fmu_path: str | os.PathLike[str], inputs: Callable[[float], Sequence[float]],
                    input_names: Sequence[str], output_names: Sequence[str], step: float = 1e-3,
                    steps_before: int = 500, steps_after: int = 500) -> RoundTrip:
    """Run, save the FMU state, run on; restore (and deserialise in a second instance) and run again.

    ``inputs(t)``: the values of the scalar ``input_names`` from ``t`` (s) over one ``step``; the outputs
    compared are the scalar ``output_names``. All three continuations must agree bit for bit. Model
    Exchange: the derivatives after restoring a state must equal those when it was taken.
    """
    with open_fmu(fmu_path) as fmu:
        sel_in, sel_out = fmu.select(input_names), fmu.select(output_names)

        def run(s: "Instance", k0: int, n: int) -> np.ndarray:
            out = np.zeros((n, len(output_names)))
            for k in range(k0, k0 + n):
                t = k * step                           # t0 + k h from the step counter
                s.set(sel_in, inputs(t))
                s.do_step(t, step)
                out[k - k0] = s.get(sel_out)
            return out

        with fmu.instance("cs", "roundtrip_a") as a, fmu.instance("cs", "roundtrip_b") as b:
            a.start(0.0)
            run(a, 0, steps_before)
            state = a.get_state()
            data = a.serialize(state)
            first = run(a, steps_before, steps_after)
            a.set_state(state)
            again = run(a, steps_before, steps_after)
            a.free_state(state)
            b.start(0.0)
            state_b = b.deserialize(data)
            b.set_state(state_b)
            restored = run(b, steps_before, steps_after)
            b.free_state(state_b)
        me_same = _me_roundtrip(fmu)
    return RoundTrip(steps_before, steps_after, len(data), first.tobytes() == again.tobytes(),
                     first.tobytes() == restored.tobytes(), me_same)


def _me_roundtrip(fmu: OpenedFmu, seed: int = 1) -> bool:
    """Model Exchange: the derivatives at a perturbed state, again after setting other states and restoring the
    saved FMU state, and again after restoring its deserialised copy; True when all three are bit for bit equal."""
    with fmu.instance("me", "roundtrip_me") as m:
        m.start(0.0)
        rng = np.random.default_rng(seed)
        x0 = m.get_x()
        x1 = x0 + 0.1 * rng.standard_normal(x0.size)
        m.set_x(x1)
        d1 = m.get_dx()
        state = m.get_state()
        data = m.serialize(state)
        m.set_x(x1 + 1.0)
        m.set_state(state)
        d2 = m.get_dx()
        m.set_x(x1 - 1.0)
        state2 = m.deserialize(data)
        m.set_state(state2)
        d3 = m.get_dx()
        m.free_state(state)
        m.free_state(state2)
    return d1.tobytes() == d2.tobytes() == d3.tobytes()


# ------------------------------------------------------------ derivatives

class DerivativeErrors(NamedTuple):
    """What :func:`directional_derivative_error` found."""

    worst: float              # max |AD - FD| / (1 + |FD|)
    count: int                # Jacobian entries compared
    adjoint: float | None     # max |J_adjoint^T - J_forward| / max |J_forward|; None without adjoint derivatives


def fd_mismatch(ad: np.ndarray, at: Callable[[float], np.ndarray], scale: float, rel_step: float) -> np.ndarray:
    """Per entry, ``min over the ladder of |ad - fd| / (1 + |fd|)``: ``fd`` the Richardson-combined central
    differences (error O(h^4)) of ``at`` (the unknowns with the known moved by h) at h = scale rel_step 10^-k.
    AD is exact, so the best rung (truncation against rounding) is the differences' own accuracy."""
    best = np.full(ad.shape, np.inf)
    for k in range(FD_LADDER):
        h = scale * rel_step * 10.0 ** -k
        fd_h = (at(h) - at(-h)) / (2.0 * h)
        fd_2h = (at(2.0 * h) - at(-2.0 * h)) / (4.0 * h)
        fd = (4.0 * fd_h - fd_2h) / 3.0
        best = np.minimum(best, np.abs(ad - fd) / (1.0 + np.abs(fd)))
    return best


def _scalars(fmu: OpenedFmu, variables: Sequence[Any]) -> list[str]:
    """The scalar names of FMPy model ``variables`` (``q[1]`` .. for an FMI 3.0 array ``q``)."""
    out: list[str] = []
    for v in variables:
        if fmu.fmi_version >= 3 and getattr(v, "dimensions", None):
            out += [f"{v.name}[{k}]" for k in range(1, fmu.select([v.name]).total + 1)]
        else:
            out.append(v.name)
    return out


def directional_derivative_error(fmu_path: str | os.PathLike[str], seed: int = 7,
                                 rel_step: float = 1e-4) -> DerivativeErrors:
    """Directional (and adjoint) derivatives of the derivatives and outputs against finite differences (Model
    Exchange).

    Knowns: every state, every input and every tunable parameter, element by element; the point is a seeded
    random perturbation of the start state with random inputs (parameters on a bound moved 0.5 inside); the
    finite differences are central at ``h`` and ``2 h``, Richardson-combined (error O(h^4)), for
    ``h = rel_step * max(1, |value|) * 10^-k``, k < :data:`FD_LADDER`; each entry keeps its best rung. An FMU
    that provides adjoint derivatives (FMI 3.0) has its reverse mode compared with the forward one.
    """
    with open_fmu(fmu_path) as fmu, fmu.instance("me", "directional") as m:
        m.start(0.0)
        variables = sorted(fmu.md.modelVariables, key=lambda v: v.valueReference)
        derivs = [d.variable for d in fmu.md.derivatives]
        states = [d.derivative for d in derivs]
        state_vrs = {s.valueReference for s in states}
        outputs = _scalars(fmu, [v for v in variables if v.causality == "output" and v.valueReference not in state_vrs])
        inputs = _scalars(fmu, [v for v in variables if v.causality == "input"])
        params = [v for v in variables if v.causality == "parameter" and v.variability == "tunable"]
        state_names = _scalars(fmu, states)
        unknowns = _scalars(fmu, derivs) + outputs
        nx = len(state_names)
        rng = np.random.default_rng(seed)

        x = m.get_x() + 0.2 * rng.standard_normal(nx)
        m.set_x(x)
        if inputs:
            m.set(inputs, 0.05 * rng.standard_normal(len(inputs)))

        def set_param(names: Sequence[str], values: np.ndarray) -> None:
            # no event iteration, so the friction modes stay those of the point (an update at this random state
            # may switch a mode and project a speed, which moves the point under the differences: the panda's
            # payload column then missed by 1.5e-3)
            m.enter_event_mode()
            m.set(names, values)
            m.enter_continuous_time_mode()

        param_names: list[str] = []
        for v in params:  # move parameters that sit on a bound (no payload, no Coulomb friction) inside their range
            names = _scalars(fmu, [v])
            param_names += names
            values = m.get(names)
            lo = float(v.min) if v.min is not None else -np.inf
            hi = float(v.max) if v.max is not None else np.inf
            moved = np.where(values - lo < 1e-3, lo + 0.5, np.where(hi - values < 1e-3, hi - 0.5, values))
            if np.any(moved != values):
                set_param(names, moved)

        def evaluate() -> np.ndarray:
            return np.concatenate([m.get_dx(), m.get(outputs)]) if outputs else m.get_dx()

        worst, count = 0.0, 0
        columns: list[np.ndarray] = []
        knowns = state_names + inputs + param_names
        for j, known in enumerate(knowns):
            ad = m.directional(unknowns, [known], [1.0])
            columns.append(ad)
            base = float(x[j]) if j < nx else float(m.get([known])[0])

            def put(value: float) -> None:
                if j < nx:
                    xp = x.copy()
                    xp[j] = value
                    m.set_x(xp)
                elif j < nx + len(inputs):
                    m.set([known], [value])
                else:
                    set_param([known], np.array([value]))

            best = fd_mismatch(ad, lambda h: (put(base + h), evaluate())[1], max(1.0, abs(base)), rel_step)
            put(base)
            worst = max(worst, float(np.max(best)))
            count += ad.size
        adjoint = None
        if m.fmi3 and fmu.md.modelExchange.providesAdjointDerivatives:
            J = np.column_stack(columns)                       # (ny, n_knowns)
            JT = np.vstack([m.adjoint(unknowns, knowns, np.eye(len(unknowns))[i]) for i in range(len(unknowns))])
            adjoint = float(np.max(np.abs(JT - J))) / max(float(np.max(np.abs(J))), 1e-300)
    return DerivativeErrors(worst, count, adjoint)
