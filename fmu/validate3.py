"""The FMI 3.0 twins of :func:`fmu.validate.state_roundtrip` and :func:`fmu.validate.directional_derivative_error`.

``validate-fmu`` runs the same checks on an FMI 2.0 and an FMI 3.0 FMU of a robot; the
FMI 3.0 calls differ (array variables, one value reference per array, ``fmi3FMUState``,
``fmi3GetAdjointDerivative``), so they live here, over FMPy's ``FMU3Slave`` and
``FMU3Model``, and return the same results:

* :func:`state_roundtrip3`: a Co-Simulation run saved with ``fmi3GetFMUState``, continued,
  restored and continued again, and deserialised in a second instance; Model Exchange
  derivatives after restoring; every continuation bit for bit (a :class:`RoundTrip`);
* :func:`directional_derivative_error3`: forward-mode directional derivatives of the state
  derivatives and outputs with respect to every state, input and tunable parameter element,
  against the same Richardson-combined central differences as FMI 2.0's, and the reverse mode
  (``fmi3GetAdjointDerivative``) against the forward mode (they must be one Jacobian: its
  transpose, to rounding).

Scalar names (``q[1]``) are mapped to an array and an element by :func:`_elements`.
"""

from __future__ import annotations

import ctypes
import os
import shutil
from typing import Any, Callable, Sequence

import numpy as np

from model.errors import InputError

from .archive import check_fmu_archive
from .roundtrip import StateCalls, cs_roundtrip, me_roundtrip
from .check_results import RoundTrip, fd_mismatch

__all__ = ["state_roundtrip3", "directional_derivative_error3"]


def _arrays(md: Any) -> dict[str, tuple[int, int]]:
    """name -> (value reference, number of elements) of every Float64 variable."""
    return {v.name: (v.valueReference, int(np.prod([d.start for d in v.dimensions])) if v.dimensions else 1)
            for v in md.modelVariables}


def _elements(md: Any, names: Sequence[str]) -> tuple[list[int], list[int], list[int]]:
    """For scalar names: the distinct array value references (in order), their sizes, and the position of
    each name in the concatenation of those arrays."""
    arrays = _arrays(md)
    vrs: list[int] = []
    sizes: list[int] = []
    offsets: dict[int, int] = {}
    where: list[int] = []
    for name in names:
        base, index = (name.split("[", 1)[0], int(name.split("[", 1)[1][:-1]) - 1) if "[" in name else (name, 0)
        vr, size = arrays[base] if base in arrays else arrays[name]
        if vr not in offsets:
            offsets[vr] = sum(sizes)
            vrs.append(vr)
            sizes.append(size)
        where.append(offsets[vr] + index)
    return vrs, sizes, where


def _new(fmu_path: str | os.PathLike[str], unzip: str, name: str, kind: str) -> tuple[Any, Any]:
    from fmpy import read_model_description
    from fmpy.fmi3 import FMU3Model, FMU3Slave

    md = read_model_description(str(fmu_path))
    cls, ident = ((FMU3Slave, md.coSimulation.modelIdentifier) if kind == "cs"
                  else (FMU3Model, md.modelExchange.modelIdentifier))
    inst = cls(guid=md.guid, unzipDirectory=unzip, modelIdentifier=ident, instanceName=name)
    inst.instantiate()
    inst.enterInitializationMode(startTime=0.0)
    inst.exitInitializationMode()
    if kind == "me":
        inst.updateDiscreteStates()
        inst.enterContinuousTimeMode()
    return md, inst


def state_roundtrip3(fmu_path: str | os.PathLike[str], inputs: Callable[[float], Sequence[float]],
                     input_names: Sequence[str], output_names: Sequence[str], step: float = 1e-3,
                     steps_before: int = 500, steps_after: int = 500) -> RoundTrip:
    """:func:`fmu.validate.state_roundtrip` for an FMI 3.0 FMU (scalar names, ``step`` in s)."""
    from fmpy import extract, read_model_description

    check_fmu_archive(fmu_path)
    md = read_model_description(str(fmu_path))
    vin, in_sizes, in_where = _elements(md, input_names)
    vout, out_sizes, out_where = _elements(md, output_names)
    if in_where != list(range(sum(in_sizes))):
        raise InputError(f"expected whole input arrays in order, got {list(input_names)}", parameter="input_names")
    unzip = extract(str(fmu_path))
    try:
        def run(s: Any, k0: int, n: int) -> np.ndarray:
            out = np.zeros((n, len(output_names)))
            for k in range(k0, k0 + n):
                t = k * step                           # t0 + k h from the step counter
                s.setFloat64(vin, [float(v) for v in inputs(t)])
                s.doStep(t, step)
                out[k - k0] = np.array(s.getFloat64(vout, sum(out_sizes)))[out_where]
            return out

        get_set, deserialized, size = cs_roundtrip(
            lambda name: (s := _new(fmu_path, unzip, name + "3", "cs")[1], _calls3(s)), run, steps_before, steps_after)
        me_same = _me_roundtrip3(fmu_path, unzip)
    finally:
        shutil.rmtree(unzip, ignore_errors=True)
    return RoundTrip(steps_before, steps_after, size, get_set, deserialized, me_same)


def _nx(md: Any) -> int:
    sizes = _arrays(md)
    by_vr = {vr: size for vr, size in sizes.values()}
    return sum(by_vr[d.variable.valueReference] for d in md.derivatives)


def _get_x(m: Any, nx: int) -> np.ndarray:
    buf = (ctypes.c_double * nx)()
    m.getContinuousStates(buf, nx)
    return np.array(buf[:])


def _set_x(m: Any, x: np.ndarray) -> None:
    m.setContinuousStates((ctypes.c_double * x.size)(*x), x.size)


def _dx(m: Any, nx: int) -> np.ndarray:
    buf = (ctypes.c_double * nx)()
    m.getContinuousStateDerivatives(buf, nx)
    return np.array(buf[:])


def _calls3(m: Any, nx: int = 0) -> StateCalls:
    """The FMI 3.0 spellings of the round trip's calls on instance ``m`` (``nx`` states for Model Exchange)."""
    def end() -> None:
        m.terminate()
        m.freeInstance()

    return StateCalls(m.getFMUState, m.setFMUState, m.serializeFMUState, m.deserializeFMUState, m.freeFMUState, end,
                      lambda: _get_x(m, nx), lambda x: _set_x(m, x), lambda: _dx(m, nx))


def _me_roundtrip3(fmu_path: str | os.PathLike[str], unzip: str) -> bool:
    md, m = _new(fmu_path, unzip, "roundtrip3_me", "me")
    return me_roundtrip(_calls3(m, _nx(md)))


def directional_derivative_error3(fmu_path: str | os.PathLike[str], seed: int = 7,
                                  rel_step: float = 1e-4) -> tuple[float, int, float]:
    """:func:`fmu.validate.directional_derivative_error` for an FMI 3.0 FMU, plus the adjoint.

    Returns the largest ``|AD - FD| / (1 + |FD|)``, the number of Jacobian entries compared, and
    ``max |J_adjoint^T - J_forward| / max |J_forward|`` (reverse mode against forward mode).
    """
    from fmpy import extract

    check_fmu_archive(fmu_path)
    unzip = extract(str(fmu_path))
    try:
        md, m = _new(fmu_path, unzip, "directional3", "me")
        variables = sorted(md.modelVariables, key=lambda v: v.valueReference)
        size = {v.valueReference: s for v, s in ((v, _arrays(md)[v.name][1]) for v in variables)}
        derivs = [d.variable for d in md.derivatives]
        states = [d.derivative for d in derivs]
        state_vrs = {s.valueReference for s in states}
        outputs = [v for v in variables if v.causality == "output" and v.valueReference not in state_vrs]
        inputs = [v for v in variables if v.causality == "input"]
        params = [v for v in variables if v.causality == "parameter" and v.variability == "tunable"]
        unknowns = [v.valueReference for v in derivs + outputs]
        ny = sum(size[vr] for vr in unknowns)
        nx = sum(size[s.valueReference] for s in states)
        rng = np.random.default_rng(seed)

        x = _get_x(m, nx) + 0.2 * rng.standard_normal(nx)
        _set_x(m, x)
        for v in inputs:
            m.setFloat64([v.valueReference], list(0.05 * rng.standard_normal(size[v.valueReference])))

        def set_param(vr: int, values: np.ndarray) -> None:
            # as the FMI 2.0 check: no fmi3UpdateDiscreteStates, so the friction modes stay those of the point
            # (an update at this random state may switch a mode and project a speed, which moves the point
            # under the differences: the panda's payload column then missed by 1.5e-3)
            m.enterEventMode()
            m.setFloat64([vr], [float(a) for a in values])
            m.enterContinuousTimeMode()

        for v in params:  # move parameters that sit on a bound (no payload, no Coulomb friction) inside their range
            values = np.array(m.getFloat64([v.valueReference], size[v.valueReference]))
            lo = float(v.min) if v.min is not None else -np.inf
            hi = float(v.max) if v.max is not None else np.inf
            moved = np.where(values - lo < 1e-3, lo + 0.5, np.where(hi - values < 1e-3, hi - 0.5, values))
            if np.any(moved != values):
                set_param(v.valueReference, moved)

        def evaluate() -> np.ndarray:
            out = [np.array(m.getFloat64([v.valueReference], size[v.valueReference])) for v in outputs]
            return np.concatenate([_dx(m, nx), *out])

        worst, count = 0.0, 0
        J_columns: list[np.ndarray] = []
        knowns: list[int] = []
        for known in states + inputs + params:
            vr = known.valueReference
            k_size = size[vr]
            knowns.append(vr)
            base_all = (x[sum(size[s.valueReference] for s in states[:states.index(known)]):][:k_size].copy()
                        if known in states else np.array(m.getFloat64([vr], k_size)))
            offset = sum(size[s.valueReference] for s in states[:states.index(known)]) if known in states else 0

            def put(values: np.ndarray) -> None:
                if known in states:
                    xp = x.copy()
                    xp[offset:offset + k_size] = values
                    _set_x(m, xp)
                elif known in inputs:
                    m.setFloat64([vr], [float(a) for a in values])
                else:
                    set_param(vr, values)

            for e in range(k_size):
                seed_vec = np.zeros(k_size)
                seed_vec[e] = 1.0
                ad = np.array(m.getDirectionalDerivative(unknowns, [vr], list(seed_vec), ny))
                J_columns.append(ad)
                scale = max(1.0, abs(base_all[e]))

                def at(h: float) -> np.ndarray:
                    values = base_all.copy()
                    values[e] += h
                    put(values)
                    return evaluate()

                best = fd_mismatch(ad, at, scale, rel_step)
                put(base_all)
                worst = max(worst, float(np.max(best)))
                count += ad.size
        J = np.column_stack(J_columns)                       # (ny, n_knowns)
        JT = np.vstack([m.getAdjointDerivative(unknowns, knowns, list(np.eye(ny)[i]), J.shape[1])
                        for i in range(ny)])
        adjoint = float(np.max(np.abs(JT - J))) / max(float(np.max(np.abs(J))), 1e-300)
        m.terminate()
        m.freeInstance()
    finally:
        shutil.rmtree(unzip, ignore_errors=True)
    return worst, count, adjoint
