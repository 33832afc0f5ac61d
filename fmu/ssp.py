"""SSP 1.0 files (System Structure and Parameterization): FMUs, their connections and parameter sets in one archive.

An SSP written by :func:`write_ssp` holds

* ``SystemStructure.ssd``: one system of Co-Simulation FMU components (``resources/<name>.fmu``), their
  connectors (every connected variable, ``ssc:Real``), the connections, the default experiment
  (start, stop, and libcosim's ``osp:FixedStepAlgorithm`` annotation with the communication step) and,
  per component, a parameter binding to the nominal parameter set ``resources/<component>.nominal.ssv``;
* for every other parameter set (a *variant*) ``<variant>.ssd``, the same system bound to
  ``resources/<component>.<variant>.ssv`` (SSP 1.0 keeps variants as further ``.ssd`` files at the root);
  each ``.ssv`` holds every parameter of the component it sets, so a set is complete on its own.

Importers read them differently, and :func:`run_fmpy` and :func:`run_libcosim` say how:
libcosim (``CosimExecution.from_ssp_file``) reads the ``.ssd`` it is given, applies the first
parameter binding of each component (to parameters and inputs only) and steps Jacobi; FMPy
(``fmpy.ssp.simulation.simulate_ssp``) reads only ``SystemStructure.ssd``, ignores its bindings (the
set is passed as an object, read here from the ``.ssv``), starts every connector at 0.0, steps every FMU
and then moves the values along the connections (Jacobi too), and counts time as a running sum.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import zipfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence
from xml.sax.saxutils import quoteattr

import numpy as np

from model.errors import InputError

__all__ = ["check_set_name", "read_resource", "SspComponent", "SspConnection", "write_ssp", "ssp_variants", "read_parameter_set", "run_fmpy",
           "run_libcosim", "NOMINAL"]

#: Name of the parameter set bound in ``SystemStructure.ssd``.
NOMINAL = "nominal"

_NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
       "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
       "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues"}
_NAME = re.compile(r"^[A-Za-z0-9_.=+-]+$")


@dataclass(frozen=True)
class SspComponent:
    """One FMU of the system: its name, file, input and output connectors (FMI variable names) and its parameter
    sets (set name -> variable name -> value; every set of a component has the same names)."""

    name: str
    fmu: Path
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    parameter_sets: Mapping[str, Mapping[str, float]]


@dataclass(frozen=True)
class SspConnection:
    """``start`` component's output ``start_connector`` drives ``end`` component's input ``end_connector``."""

    start: str
    start_connector: str
    end: str
    end_connector: str


def check_set_name(*names: str) -> None:
    """Refuse a parameter set name that is not letters, digits and ``_.=+-`` (it names the set's files)."""
    for v in names:
        if not _NAME.match(v):
            raise InputError(f"expected a name of letters, digits and _.=+-, got {v!r}", parameter="variant")


def _ssv(name: str, values: Mapping[str, float]) -> str:
    rows = "".join(f'    <ssv:Parameter name={quoteattr(k)}><ssv:Real value="{float(v)!r}"/></ssv:Parameter>\n'
                   for k, v in values.items())
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<ssv:ParameterSet xmlns:ssv="{_NS["ssv"]}" xmlns:ssc="{_NS["ssc"]}" version="1.0" '
            f'name={quoteattr(name)}>\n  <ssv:Parameters>\n{rows}  </ssv:Parameters>\n</ssv:ParameterSet>\n')


def _ssd(name: str, variant: str, components: Sequence[SspComponent], connections: Sequence[SspConnection],
         start: float, stop: float, step: float) -> str:
    parts = [f'<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription xmlns:ssd="{_NS["ssd"]}" '
             f'xmlns:ssc="{_NS["ssc"]}" xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations" '
             f'version="1.0" name={quoteattr(f"{name} ({variant})")}>\n'
             f'  <ssd:System name={quoteattr(name)}>\n    <ssd:Elements>\n']
    for c in components:
        parts.append(f'      <ssd:Component name={quoteattr(c.name)} source="resources/{c.name}.fmu" '
                     f'type="application/x-fmu-sharedlibrary">\n        <ssd:Connectors>\n')
        parts += [f'          <ssd:Connector name={quoteattr(v)} kind="{kind}"><ssc:Real/></ssd:Connector>\n'
                  for kind, names in (("input", c.inputs), ("output", c.outputs)) for v in names]
        parts.append("        </ssd:Connectors>\n")
        if c.parameter_sets:
            parts.append(f'        <ssd:ParameterBindings>\n          <ssd:ParameterBinding '
                         f'source="resources/{c.name}.{variant}.ssv"/>\n        </ssd:ParameterBindings>\n')
        parts.append("      </ssd:Component>\n")
    parts.append("    </ssd:Elements>\n    <ssd:Connections>\n")
    parts += [f'      <ssd:Connection startElement={quoteattr(k.start)} startConnector={quoteattr(k.start_connector)} '
              f'endElement={quoteattr(k.end)} endConnector={quoteattr(k.end_connector)}/>\n' for k in connections]
    parts.append(f'    </ssd:Connections>\n  </ssd:System>\n'
                 f'  <ssd:DefaultExperiment startTime="{start!r}" stopTime="{stop!r}">\n    <ssd:Annotations>\n'
                 f'      <ssc:Annotation type="com.opensimulationplatform"><osp:Algorithm>'
                 f'<osp:FixedStepAlgorithm baseStepSize="{step!r}"/></osp:Algorithm></ssc:Annotation>\n'
                 f'    </ssd:Annotations>\n  </ssd:DefaultExperiment>\n</ssd:SystemStructureDescription>\n')
    return "".join(parts)


def write_ssp(path: str | os.PathLike[str], name: str, components: Sequence[SspComponent],
              connections: Sequence[SspConnection], *, start: float, stop: float, step: float,
              extra: Mapping[str, str | bytes] | None = None) -> Path:
    """Write the SSP 1.0 archive ``path`` (``.ssp``) of ``components`` and ``connections``.

    ``start``, ``stop`` and ``step`` (s) are the default experiment and the fixed communication step;
    ``extra`` maps archive paths under ``resources/`` to files (text or bytes) added as they are (the exporter's
    notes, a copy of its reference file).
    Every component with parameter sets has the same set names, :data:`NOMINAL` among them.

    Raises
    ------
    model.errors.InputError
        A path not ending in ``.ssp``, a connection naming an unknown component or connector, set names that
        differ between components, a set name that is not a plain file name, a bad time.
    """
    out = Path(path)
    if out.suffix != ".ssp":
        raise InputError(f"expected a file name ending in .ssp, got {str(out)!r}", parameter="path")
    if not (math.isfinite(start) and math.isfinite(stop) and math.isfinite(step) and step > 0 and stop > start):
        raise InputError(f"expected start < stop and step > 0, got {start!r}, {stop!r}, {step!r}", parameter="step")
    by_name = {c.name: c for c in components}
    for k in connections:
        if k.start not in by_name or k.start_connector not in by_name[k.start].outputs or k.end not in by_name \
                or k.end_connector not in by_name[k.end].inputs:
            raise InputError(f"{k.start}.{k.start_connector} -> {k.end}.{k.end_connector}: no such output or input",
                             parameter="connections")
    sets = [sorted(c.parameter_sets) for c in components if c.parameter_sets]
    variants = sets[0] if sets else [NOMINAL]
    if any(s != variants for s in sets) or NOMINAL not in variants:
        raise InputError(f"expected the same parameter sets, {NOMINAL!r} among them, in every component, got {sets}",
                         parameter="parameter_sets")
    check_set_name(*variants)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for v in variants:
            zf.writestr("SystemStructure.ssd" if v == NOMINAL else f"{v}.ssd",
                        _ssd(name, v, components, connections, start, stop, step))
        for c in components:
            zf.write(c.fmu, f"resources/{c.name}.fmu")
            for v, values in c.parameter_sets.items():
                zf.writestr(f"resources/{c.name}.{v}.ssv", _ssv(f"{c.name} {v}", values))
        for name, text in (extra or {}).items():
            if not name.startswith("resources/") or ".." in name:
                raise InputError(f"expected a path under resources/, got {name!r}", parameter="extra")
            zf.writestr(name, text)
    tmp.replace(out)
    return out


def ssp_variants(path: str | os.PathLike[str]) -> list[str]:
    """The parameter sets of the SSP ``path``: :data:`NOMINAL` (``SystemStructure.ssd``), then the other ``.ssd``."""
    with zipfile.ZipFile(path) as zf:
        names = zf.namelist()
    if "SystemStructure.ssd" not in names:
        raise InputError(f"{Path(path).name} has no SystemStructure.ssd: not an SSP", parameter="ssp")
    return [NOMINAL] + sorted(n[:-4] for n in names if n.endswith(".ssd") and "/" not in n
                              and n != "SystemStructure.ssd")


def _ssd_name(variant: str) -> str:
    return "SystemStructure.ssd" if variant == NOMINAL else f"{variant}.ssd"


def read_parameter_set(path: str | os.PathLike[str], variant: str = NOMINAL) -> dict[str, float]:
    """The real parameters ``component.variable -> value`` bound in the ``.ssd`` of ``variant`` of the SSP ``path``."""
    with zipfile.ZipFile(path) as zf:
        if _ssd_name(variant) not in zf.namelist():
            raise InputError(f"{Path(path).name} has no parameter set {variant!r} (has {ssp_variants(path)})",
                             parameter="variant")
        ssd = ET.fromstring(zf.read(_ssd_name(variant)))
        values: dict[str, float] = {}
        for comp in ssd.iterfind("ssd:System/ssd:Elements/ssd:Component", _NS):
            for binding in comp.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", _NS):
                ssv = ET.fromstring(zf.read(binding.get("source", "")))
                for p in ssv.iterfind("ssv:Parameters/ssv:Parameter", _NS):
                    real = p.find("ssv:Real", _NS)
                    if real is not None:
                        values[f"{comp.get('name')}.{p.get('name')}"] = float(real.get("value", "nan"))
    return values


@dataclass
class _Parameter:
    name: str
    value: float


@dataclass
class _ParameterSet:
    parameters: list[_Parameter]


def run_fmpy(path: str | os.PathLike[str], variant: str, outputs: Sequence[str], *, start: float, stop: float,
             step: float) -> np.ndarray:
    """Run the SSP in FMPy's ``simulate_ssp`` with the parameter set ``variant``; the ``outputs``
    (``component.variable``) after each of its N = round((stop - start) / step) steps, shape (N, m): row k - 1 holds
    the values at ``start + k step``. FMPy steps while its running-sum time is below its stop time, which is put
    half a step before ``stop`` so that it takes exactly N steps.
    """
    from fmpy.ssp.simulation import simulate_ssp

    pset = _ParameterSet([_Parameter(k, v) for k, v in read_parameter_set(path, variant).items()])
    steps = int(round((stop - start) / step))
    rows = simulate_ssp(str(path), start_time=start, stop_time=start + (steps - 0.5) * step, step_size=step,
                        parameter_set=pset)
    if rows.size != steps:
        raise InputError(f"FMPy took {rows.size} steps, expected {steps}", parameter="ssp")
    return np.column_stack([rows[name] for name in outputs])


def run_libcosim(path: str | os.PathLike[str], variant: str, outputs: Sequence[str], *, steps: int) -> np.ndarray:
    """Run the ``.ssd`` of ``variant`` of the SSP in libcosim (``CosimExecution.from_ssp_file``, the file's own
    algorithm and bindings); the ``outputs`` (``component.variable``) after each of ``steps`` steps, shape
    (steps, m): row k - 1 holds the values at ``start + k step``."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    from .cosim import CosimError, last_error

    log_output_level(CosimLogLevel.WARNING)
    with tempfile.TemporaryDirectory(prefix="mw_ssp_") as work:
        with zipfile.ZipFile(path) as zf:
            zf.extractall(work)
        ssd = Path(work) / _ssd_name(variant)
        if not ssd.is_file():
            raise InputError(f"{Path(path).name} has no parameter set {variant!r}", parameter="variant")
        execution = CosimExecution.from_ssp_file(str(ssd))
        if execution is None:
            raise CosimError(f"libcosim refused {Path(path).name} ({variant}): {last_error()}")
        observer = CosimObserver.create_last_value()
        try:
            if not execution.add_observer(observer):
                raise CosimError(f"libcosim refused the observer: {last_error()}")
            index = {s.name.decode(): s.index for s in execution.slave_infos()}
            refs: list[tuple[int, int]] = []
            for name in outputs:
                comp, var = name.split(".", 1)
                vr = {v.name.decode(): int(v.reference) for v in execution.slave_variables(index[comp])}
                refs.append((index[comp], vr[var]))
            out = np.empty((steps, len(outputs)))
            for k in range(steps):
                if not execution.step(1):
                    raise CosimError(f"libcosim step {k + 1} failed: {last_error()}")
                out[k] = [observer.last_real_values(i, [vr])[0] for i, vr in refs]
        finally:
            del execution
            del observer
    return out


def read_resource(path: str | os.PathLike[str], name: str) -> bytes | None:
    """The file ``name`` (an archive path) of the SSP ``path``, or None when it has none."""
    with zipfile.ZipFile(path) as zf:
        return zf.read(name) if name in zf.namelist() else None
