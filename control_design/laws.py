"""The control laws, each written once as a named CasADi Function.

Every law maps the measured joint state and the reference (joint side) to the
motor torque before saturation; the sampled Python controllers
(:mod:`control_design.controllers`) evaluate these Functions (compiled), and
the controller FMUs (:mod:`closed_loop.controller_fmu`) generate the same
Functions into their C, so both compute one law.

================  ===============================================================
kind              ``tau_m`` (motor side, N m), ``e_m = G (q_d - q)``, ``ed_m = G (qd_d - qd)``
'pd'              ``Kp e_m + Kd ed_m``
'pd-g'            ``Kp e_m + Kd ed_m + g(q; p_model) / G``
'pd-ff'           ``Kp e_m + Kd ed_m + J_ff_m G qdd_d + B_ff_m G qd_d``
'pid'             ``Kp e_m + Kd ed_m + Ki z``; next integrator state ``z + dt e_m``, frozen while
                  the saturated output clips in the direction of the error (conditional
                  integration, against wind-up)
'ct'              ``rne(q, qd, qdd_d + Kd (qd_d - qd) + Kp (q_d - q); p_model) / G``
================  ===============================================================

:func:`saturation` clips at ``+-tau_m_max``; :func:`controller_function` is a
law followed by the saturation, the function a controller runs. A controller
without limits uses :data:`NO_LIMIT` (clipping at it changes no finite torque).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from model.robot import Robot
from model.errors import InputError

__all__ = [
    "LAW_KINDS",
    "NO_LIMIT",
    "ControlLaw",
    "control_law",
    "controller_function",
    "law_fingerprint",
    "saturation",
]

#: The control laws, by controller kind.
LAW_KINDS: tuple[str, ...] = ("pd", "pd-g", "pd-ff", "pid", "ct")
#: Torque limit (N m) of a controller without saturation: clipping at it changes no finite torque.
NO_LIMIT = float(np.finfo(float).max)

#: Signals every law reads, in input order; 'pd-ff' and 'ct' also read ``qdd_d``.
_SIGNALS = ("q", "qd", "q_d", "qd_d")


@dataclass(frozen=True)
class ControlLaw:
    """One control law of one robot.

    Attributes
    ----------
    kind
        One of :data:`LAW_KINDS`.
    function
        ``Function(kind, [*signals, *parameters, *states], [tau_m, *next states])`` with named
        inputs and outputs; ``tau_m`` is before saturation.
    signals
        Names of the signal inputs (``q``, ``qd``, ``q_d``, ``qd_d`` and maybe ``qdd_d``), each (n,).
    parameters
        ``(name, size)`` of the parameter inputs, in input order (``Kp``, ``Kd``, ``Ki``,
        ``gear_ratio``, ``tau_m_max``, ``J_ff_m``, ``B_ff_m``, ``p_model``, ``dt``).
    states
        Names of the state inputs (``z`` for 'pid'); the Function returns their next values
        (``z_next``) after ``tau_m``.
    """

    kind: str
    function: ca.Function
    signals: tuple[str, ...]
    parameters: tuple[tuple[str, int], ...]
    states: tuple[str, ...]


def saturation(tau_m: ca.SX, tau_m_max: ca.SX) -> ca.SX:
    """``tau_m`` clipped to ``[-tau_m_max, tau_m_max]`` elementwise (the one saturation of every controller)."""
    return ca.fmin(ca.fmax(tau_m, -tau_m_max), tau_m_max)


def law_fingerprint() -> str:
    """SHA-256 of this module: editing a law invalidates its compiled code."""
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


def control_law(kind: str, n: int, model: Robot | None = None) -> ControlLaw:
    """The law of ``kind`` for ``n`` joints.

    Parameters
    ----------
    kind
        One of :data:`LAW_KINDS`.
    n
        Number of joints.
    model
        The controller's robot model, whose dynamics 'pd-g' (``gravload``) and 'ct' (``rne``)
        evaluate with the parameter input ``p_model``; not used by the other kinds.

    Raises
    ------
    model.errors.InputError
        ``kind`` not in :data:`LAW_KINDS`; no ``model`` (or one with another joint count) for 'pd-g' or 'ct'.
    """
    if kind not in LAW_KINDS:
        raise InputError(f"expected one of {', '.join(LAW_KINDS)}, got {kind!r}", parameter="kind")
    if kind in ("pd-g", "ct") and (model is None or model.n != n):
        raise InputError(f"a {kind!r} law needs the robot model of its {n} joints, got {model!r}", parameter="model")
    sym = {name: ca.SX.sym(name, n) for name in (*_SIGNALS, "qdd_d", "Kp", "Kd", "Ki", "gear_ratio", "tau_m_max",
                                                   "J_ff_m", "B_ff_m", "z")}
    q, qd, q_d, qd_d, qdd_d = (sym[k] for k in ("q", "qd", "q_d", "qd_d", "qdd_d"))
    Kp, Kd, Ki, G = (sym[k] for k in ("Kp", "Kd", "Ki", "gear_ratio"))
    signals: tuple[str, ...] = _SIGNALS
    states: tuple[str, ...] = ()
    extra: list[tuple[str, ca.SX]] = []
    outputs: list[tuple[str, ca.SX]] = []
    if kind == "ct":
        assert model is not None
        p_model = ca.SX.sym("p_model", model.dynamics.layout.size)
        signals += ("qdd_d",)
        params = [("Kp", Kp), ("Kd", Kd), ("gear_ratio", G), ("p_model", p_model)]
        v = qdd_d + Kd * (qd_d - qd) + Kp * (q_d - q)
        tau_m = model.dynamics.functions.rne(q, qd, v, p_model) / G
    else:
        e_m = G * (q_d - q)
        ed_m = G * (qd_d - qd)
        params = [("Kp", Kp), ("Kd", Kd), ("gear_ratio", G)]
        tau_m = Kp * e_m + Kd * ed_m
        if kind == "pd-ff":
            signals += ("qdd_d",)
            J, B = sym["J_ff_m"], sym["B_ff_m"]
            params += [("J_ff_m", J), ("B_ff_m", B)]
            tau_m = tau_m + J * G * qdd_d + B * G * qd_d
        elif kind == "pd-g":
            assert model is not None
            p_model = ca.SX.sym("p_model", model.dynamics.layout.size)
            params += [("p_model", p_model)]
            tau_m = tau_m + model.dynamics.functions.gravload(q, p_model) / G
        elif kind == "pid":
            z, tmax, dt = sym["z"], sym["tau_m_max"], ca.SX.sym("dt")
            params = [("Kp", Kp), ("Kd", Kd), ("Ki", Ki), ("gear_ratio", G), ("tau_m_max", tmax), ("dt", dt)]
            states = ("z",)
            extra = [("z", z)]
            tau_m = tau_m + Ki * z
            clipped = saturation(tau_m, tmax)
            winding = ca.logic_and(clipped != tau_m, ca.sign(e_m) == ca.sign(tau_m))
            outputs = [("z_next", z + ca.if_else(winding, 0.0, dt * e_m))]
    inputs = [(name, sym[name]) for name in signals] + params + extra
    function = ca.Function(kind.replace("-", "_"), [s for _, s in inputs], [tau_m] + [e for _, e in outputs],
                           [name for name, _ in inputs], ["tau_m"] + [name for name, _ in outputs])
    return ControlLaw(kind, function, signals, tuple((name, int(s.numel())) for name, s in params), states)


def controller_function(law: ControlLaw) -> ca.Function:
    """The law followed by :func:`saturation`: inputs the law's plus ``tau_m_max`` (unless it has it), output
    ``tau_m`` saturated (and the law's next states).

    Named ``<kind>_controller``; the Python controller and the controller FMU both run it.
    """
    f = law.function
    args = [ca.SX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
    names = [f.name_in(i) for i in range(f.n_in())]
    if "tau_m_max" in names:
        tmax = args[names.index("tau_m_max")]
    else:
        tmax = ca.SX.sym("tau_m_max", f.size1_out(0))
        args.append(tmax)
        names.append("tau_m_max")
    out = f(*args[:f.n_in()])
    out = list(out) if isinstance(out, (list, tuple)) else [out]
    return ca.Function(f"{f.name()}_controller", args, [saturation(out[0], tmax), *out[1:]], names,
                       [f.name_out(i) for i in range(f.n_out())])
