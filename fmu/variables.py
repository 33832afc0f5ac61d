"""The FMU's variable table: the one list both the C side and the XML come from.

A :class:`ModelSpec` says what an FMU is built from (the CasADi ``ode`` and
``out`` Functions and, for every entry of x, u, p and y, a name, a unit and a
description). :func:`build_table` turns it into a :class:`VariableTable`: the
value reference, causality, variability, start value and range of every FMI
variable, and the dependencies of the ModelStructure taken from the exact
sparsity of the CasADi Jacobians. The table then renders, through the
templates in ``fmu/templates/``:

* ``modelDescription.xml`` (:meth:`VariableTable.model_description`),
* ``model_data.h``, the value references as C macros (:meth:`VariableTable.model_data_h`),
* ``model_data.c``, the model contract of ``fmu/c/model.h`` (:meth:`VariableTable.model_data_c`).

Value references are the row numbers of the table, so the wrapper finds a
variable in O(1) and nothing is kept by hand in two places. FMI 2.0 exposes
every row as a ScalarVariable; FMI 3.0 groups consecutive rows ``name[1]`` ..
``name[k]`` of the same attributes into one array variable ``name`` with
``<Dimension start="k"/>`` (:meth:`VariableTable.arrays`), value reference
``1 + its position`` (0 is ``time``); both are rendered from the same rows,
and the C side gets both (``MwVariable`` rows and ``MwArray`` groups).
"""

from __future__ import annotations

import math
import re
import string
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence
from xml.sax.saxutils import quoteattr

import casadi as ca
import numpy as np
from model.errors import InputError

__all__ = [
    "TEMPLATE_DIR",
    "MIN_STEP",
    "MAX_SUBSTEPS",
    "SUBSTEP_RTOL",
    "substeps",
    "fmu_identifier",
    "Quantity",
    "ModelSpec",
    "DiscreteStates",
    "Variable",
    "Unknown",
    "VariableTable",
    "ArrayVariable",
    "FMI3_TIME_VR",
    "build_table",
    "spec_from_plant",
    "trivial_spec",
    "parse_unit",
    "derivative_unit",
    "is_structured_name",
]

TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"
STEP_NAME = "internal_step"
#: Smallest internal step, s: the check of :class:`ModelSpec` and the ``min`` of ``internal_step`` in the XML.
#: With at most :data:`MAX_SUBSTEPS` sub-steps per ``fmi2DoStep`` or ``fmi3DoStep`` it bounds the work of one call.
MIN_STEP = 1e-6
#: Most RK4 sub-steps of one ``fmi2DoStep`` or ``fmi3DoStep`` (rendered as ``MW_MAX_SUBSTEPS`` by :mod:`fmu.limits`); more is an error status.
MAX_SUBSTEPS = 1_000_000
#: Relative noise of ``h / internal_step`` forgiven when counting sub-steps (rendered as ``MW_SUBSTEP_RTOL``).
SUBSTEP_RTOL = 1e-8

#: Value reference of the independent variable ``time`` in FMI 3.0 (the arrays follow from 1).
FMI3_TIME_VR = 0

# Names of the FMI variables that the table itself chooses.
_STRUCTURED = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\[\d+(,\d+)*\])?(\.[A-Za-z_][A-Za-z0-9_]*(\[\d+(,\d+)*\])?)*")


def substeps(h: float, internal_step: float) -> int:
    """RK4 sub-steps of a communication step ``h`` (s), as ``mw_substeps`` of ``fmu/c/instance.c`` counts them.

    ``ceil(h / internal_step)``, except that a ratio within a relative
    :data:`SUBSTEP_RTOL` of an integer k gives k; 0 above :data:`MAX_SUBSTEPS`.
    """
    ratio = h / internal_step
    if not (ratio > 0 and math.isfinite(ratio)):
        return 0
    nearest = math.floor(ratio + 0.5)
    n = nearest if abs(ratio - nearest) <= SUBSTEP_RTOL * ratio else math.ceil(ratio)
    n = max(n, 1)
    return n if n <= MAX_SUBSTEPS else 0


def is_structured_name(name: str) -> bool:
    """Whether ``name`` is a plain identifier path of the FMI "structured" naming convention."""
    return _STRUCTURED.fullmatch(name) is not None


@dataclass(frozen=True)
class Quantity:
    """One scalar of a model vector: FMI name, unit (``""`` for none) and description."""

    name: str
    unit: str
    description: str


@dataclass(frozen=True)
class DiscreteStates:
    """Sampled discrete states ``d`` of a model: ``d <- tick(x, u, p, d)`` once per ``period`` s.

    The tick runs at the start of every period with the inputs held over it (zero-order hold), as a
    digital controller updates its integrator after computing its output; ``d`` is never iterated
    at events (unlike the friction modes). A model with sampled states is Co-Simulation only.
    """

    states: tuple[Quantity, ...]
    start: np.ndarray
    period: float
    tick: ca.Function  # (x, u, p, d) -> d_next

    def __post_init__(self) -> None:
        nd = len(self.states)
        if np.shape(self.start) != (nd,) or not np.all(np.isfinite(self.start)):
            raise InputError(f"expected {nd} finite values, got {np.asarray(self.start).tolist()}",
                             parameter="discrete.start")
        if not (math.isfinite(self.period) and self.period > 0):
            raise InputError(f"expected a positive sample period in s, got {self.period!r}",
                             parameter="discrete.period")
        if self.tick.n_in() != 4 or self.tick.numel_in(3) != nd or self.tick.numel_out(0) != nd:
            raise InputError(f"expected (x, u, p, d) -> d_next with {nd} sampled states", parameter="discrete.tick")


@dataclass(frozen=True)
class ModelSpec:
    """What an FMU is built from.

    ``ode(x, u, p) -> xdot`` and ``out(x, u, p) -> y`` are CasADi Functions (with ``modes``, the
    plant's friction modes, ``ode`` takes ``m`` as a fourth input);
    ``states``, ``inputs``, ``params`` and ``outputs`` name every entry of x,
    u, p and y. ``output_state[k]`` is the index of the state that output k
    equals (such outputs are exposed as the state variable itself), or -1.
    ``step`` is the default internal step of the co-simulation integrator.
    With ``discrete`` (:class:`DiscreteStates`), ``ode`` and ``out`` take a fourth input ``d``.
    """

    model_identifier: str
    model_name: str
    description: str
    ode: ca.Function
    out: ca.Function
    states: tuple[Quantity, ...]
    x_start: np.ndarray
    inputs: tuple[Quantity, ...]
    params: tuple[Quantity, ...]
    p_start: np.ndarray
    p_tunable: tuple[bool, ...]
    p_min: tuple[float | None, ...]
    p_max: tuple[float | None, ...]
    outputs: tuple[Quantity, ...]
    output_state: tuple[int, ...]
    step: float
    stop_time: float = 3.0
    robot: str = ""        # the robot's name, recorded in VendorAnnotations
    motor_model: str = ""
    robot_digest: str = ""  # RobotDescription.digest() of the robot built, recorded to check a reload
    robot_json: str = ""    # the whole description (fmu.robot_resource), shipped as resources/robot.json
    modes: Any = None       # model.plant.Plant (its friction modes: events, update, start, active, pivots), or None
    discrete: DiscreteStates | None = None  # sampled discrete states (a digital controller's integrator), or None

    def __post_init__(self) -> None:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", self.model_identifier):
            raise InputError(f"expected a C identifier, got {self.model_identifier!r}", parameter="model_identifier")
        nx, nu, np_, ny = len(self.states), len(self.inputs), len(self.params), len(self.outputs)
        expected = {"ode inputs": [nx, nu, np_], "out inputs": [nx, nu, np_]}
        got = {"ode inputs": [self.ode.numel_in(i) for i in range(3)],
               "out inputs": [self.out.numel_in(i) for i in range(3)]}
        for key in expected:
            if got[key] != expected[key]:
                raise InputError(f"expected sizes (x, u, p) = {expected[key]}, got {got[key]}", parameter=key)
        if self.discrete is not None and self.modes is not None:
            raise InputError("a model with sampled states has no friction modes", parameter="discrete")
        extra = ", d" if self.discrete is not None else ", m" if self.modes is not None else ""
        ode_in = 3 + bool(extra)
        out_in = 4 if self.discrete is not None else 3
        if self.ode.n_in() != ode_in or self.out.n_in() != out_in:
            raise InputError(f"ode, out: expected {ode_in} and {out_in} inputs (x, u, p{extra}), got "
                             f"{self.ode.n_in()} and {self.out.n_in()}")
        if self.ode.numel_out(0) != nx:
            raise InputError(f"ode output: expected {nx} entries, got {self.ode.numel_out(0)}")
        if self.out.numel_out(0) != ny:
            raise InputError(f"out output: expected {ny} entries, got {self.out.numel_out(0)}")
        for name, arr, n in (("x_start", self.x_start, nx), ("p_start", self.p_start, np_)):
            if np.shape(arr) != (n,) or not np.all(np.isfinite(arr)):
                raise InputError(f"expected {n} finite values, got {np.asarray(arr).tolist()}", parameter=name)
        if len(self.p_tunable) != np_ or len(self.p_min) != np_ or len(self.p_max) != np_:
            raise InputError(f"p_tunable, p_min, p_max: expected {np_} entries each")
        for i, q in enumerate(self.params):
            lo, hi, v = self.p_min[i], self.p_max[i], float(self.p_start[i])
            if (lo is not None and v < lo) or (hi is not None and v > hi):
                raise InputError(f"parameter {q.name} = {v} is outside its range [{lo}, {hi}]", parameter="p_start")
        if len(self.output_state) != ny or any(not -1 <= k < nx for k in self.output_state):
            raise InputError(f"expected {ny} state indices in [-1, {nx - 1}], got {self.output_state}",
                             parameter="output_state")
        if not (math.isfinite(self.step) and self.step > 0):
            raise InputError(f"expected a positive internal step in s, got {self.step!r}", parameter="step")
        if self.step < MIN_STEP:
            raise InputError(f"expected an internal step of at least {MIN_STEP:g} s (the min of {STEP_NAME}), "
                             f"got {self.step!r}", parameter="step")


@dataclass(frozen=True)
class Variable:
    """One FMI ScalarVariable; ``vr`` is also its row in the table (XML index vr + 1)."""

    name: str
    vr: int
    kind: str            # state, derivative, input, parameter, output, step, indicator
    index: int           # position in x, xdot, u, p or y
    causality: str
    variability: str
    initial: str | None
    start: float | None
    unit: str
    description: str
    settable: str        # never, initial, tunable, input, state (see fmu/c/model.h)
    min: float | None = None
    max: float | None = None
    derivative_of: int | None = None  # vr of the state this is the derivative of

    @property
    def xml_index(self) -> int:
        return self.vr + 1


@dataclass(frozen=True)
class ArrayVariable:
    """One FMI 3.0 variable: rows ``first .. first + count - 1`` of the table; ``scalar``: no ``<Dimension>``."""

    name: str
    vr: int
    first: int
    count: int
    scalar: bool

    def rows(self) -> range:
        return range(self.first, self.first + self.count)


_ELEMENT = re.compile(r"(der\()?([A-Za-z_][A-Za-z0-9_.]*)\[(\d+)\](\))?")


def _element(name: str) -> tuple[str, int] | None:
    """``("q", 2)`` for ``q[2]``, ``("der(q)", 1)`` for ``der(q[1])``; None for a name that is no element."""
    m = _ELEMENT.fullmatch(name)
    if m is None or bool(m.group(1)) != bool(m.group(4)):
        return None
    base = f"der({m.group(2)})" if m.group(1) else m.group(2)
    return base, int(m.group(3))


def _group_key(v: "Variable") -> tuple[Any, ...]:
    """What the elements of one FMI 3.0 array must share (not the unit: a joint vector mixes rad and m)."""
    return (v.kind, v.causality, v.variability, v.initial, v.settable, v.min, v.max, v.derivative_of is not None)


@dataclass(frozen=True)
class Unknown:
    """A ModelStructure entry: the variable and the XML indices it depends on."""

    vr: int
    dependencies: tuple[int, ...]


@dataclass(frozen=True)
class VariableTable:
    """Every FMI variable of one model and its ModelStructure."""

    spec: ModelSpec
    variables: tuple[Variable, ...]
    outputs: tuple[Unknown, ...]
    derivatives: tuple[Unknown, ...]
    initial_unknowns: tuple[Unknown, ...]
    units: dict[str, dict[str, int] | None] = field(compare=False)

    def vr(self, name: str) -> int:
        """Value reference of the variable called ``name``; KeyError names the unknown variable."""
        for v in self.variables:
            if v.name == name:
                return v.vr
        raise KeyError(f"no FMU variable named {name!r}")

    def arrays(self) -> tuple[ArrayVariable, ...]:
        """The FMI 3.0 variables: runs of rows ``base[1] .. base[k]`` of equal attributes, else single rows."""
        groups: list[ArrayVariable] = []
        rows = self.variables
        i = 0
        while i < len(rows):
            el = _element(rows[i].name)
            j = i + 1
            if el is not None and el[1] == 1:
                while (j < len(rows) and _element(rows[j].name) == (el[0], j - i + 1)
                       and _group_key(rows[j]) == _group_key(rows[i])):
                    j += 1
            name = el[0] if el is not None and el[1] == 1 else rows[i].name
            groups.append(ArrayVariable(name, FMI3_TIME_VR + 1 + len(groups), i, j - i,
                                        scalar=el is None or el[1] != 1))
            i = j
        names = [g.name for g in groups]
        if len(set(names)) != len(names) or "time" in names:
            raise InputError(f"FMI 3.0 variables: expected unique array names besides 'time', got {names}")
        return tuple(groups)

    # ------------------------------------------------------------ rendering
    def model_description_fmi3(self, guid: str, source_files: Sequence[str], version: str) -> str:
        """The text of the FMI 3.0 ``modelDescription.xml`` (array variables, one value reference each)."""
        spec = self.spec
        arrays = self.arrays()
        of_row = {r: a for a in arrays for r in a.rows()}

        def unknowns(tag: str, items: Sequence[Unknown]) -> list[str]:
            merged: dict[int, set[int]] = {}
            for u in items:
                a = of_row[u.vr]
                merged.setdefault(a.vr, set()).update(of_row[d - 1].vr for d in u.dependencies)
            return [f'    <{tag} valueReference="{vr}" dependencies="{" ".join(map(str, sorted(deps)))}"/>'
                    for vr, deps in merged.items()]

        indicators = [a for a in arrays if self.variables[a.first].kind == "indicator"]
        structure = (unknowns("Output", self.outputs) + unknowns("ContinuousStateDerivative", self.derivatives)
                     + unknowns("InitialUnknown", self.initial_unknowns)
                     + [f'    <EventIndicator valueReference="{a.vr}"/>' for a in indicators])
        values = {
            **self._header_values(guid, version),
            "model_exchange": "" if spec.discrete is not None else (
                f"  <ModelExchange\n    modelIdentifier={quoteattr(spec.model_identifier)}\n"
                '    canGetAndSetFMUState="true"\n    canSerializeFMUState="true"\n'
                '    providesDirectionalDerivatives="true"\n    providesAdjointDerivatives="true"/>\n'),
            "annotations": self._annotations_fmi3(),
            "time_vr": str(FMI3_TIME_VR),
            "model_variables": "\n".join(self._array_variable(a, of_row) for a in arrays),
            "model_structure": "\n".join(structure),
        }
        return _template("modelDescription3.xml").substitute(values)

    def _header_values(self, guid: str, version: str) -> dict[str, str]:
        """The template values both FMI versions' descriptions share: names, GUID, tool, units, experiment."""
        spec = self.spec
        return {
            "model_name": quoteattr(spec.model_name),
            "model_identifier": quoteattr(spec.model_identifier),
            "guid": quoteattr(guid),
            "description": quoteattr(spec.description),
            "generation_tool": quoteattr(f"manipulator-workbench {version}"),
            "unit_definitions": self._unit_definitions(),
            "stop_time": _xml_number(spec.stop_time),
            "step_size": _xml_number(spec.step),
        }

    def _array_variable(self, a: ArrayVariable, of_row: dict[int, ArrayVariable]) -> str:
        rows = [self.variables[r] for r in a.rows()]
        v = rows[0]
        units = [r.unit for r in rows]
        one_unit = len(set(units)) == 1
        # elements of different units (revolute and prismatic joints): no unit attribute, each element's in the text
        descriptions = [r.description + ("" if one_unit or not r.unit else f" ({r.unit})") for r in rows]
        if len(set(descriptions)) == 1:
            text = descriptions[0]
        else:
            text = "; ".join(f"[{k + 1}] {d}" for k, d in enumerate(descriptions))
        attrs = [f"name={quoteattr(a.name)}", f'valueReference="{a.vr}"']
        if text:
            attrs.append(f"description={quoteattr(text)}")
        attrs += [f'causality="{v.causality}"', f'variability="{v.variability}"']
        if v.initial is not None:
            attrs.append(f'initial="{v.initial}"')
        attrs += _value_attrs(v.unit if one_unit else "",
                              None if v.derivative_of is None else of_row[v.derivative_of].vr,
                              None if v.start is None else " ".join(_xml_number(r.start) for r in rows), v.min, v.max)
        head = f"    <!-- vr {a.vr}: rows {a.first}..{a.first + a.count - 1} of the table -->\n"
        if a.scalar:
            return head + f"    <Float64 {' '.join(attrs)}/>"
        return head + f"    <Float64 {' '.join(attrs)}>\n      <Dimension start=\"{a.count}\"/>\n    </Float64>"

    def model_description(self, guid: str, source_files: Sequence[str], version: str) -> str:
        """The text of ``modelDescription.xml``."""
        spec = self.spec
        files = "\n".join(f'      <File name={quoteattr(f)}/>' for f in source_files)
        values = {
            **self._header_values(guid, version),
            "source_files": files,
            "event_indicators": str(spec.modes.nz if spec.modes is not None else 0),
            "model_exchange": "" if spec.discrete is not None else (
                f"  <ModelExchange\n    modelIdentifier={quoteattr(spec.model_identifier)}\n"
                '    canGetAndSetFMUstate="true"\n    canSerializeFMUstate="true"\n'
                f'    providesDirectionalDerivative="true">\n    <SourceFiles>\n{files}\n    </SourceFiles>\n'
                "  </ModelExchange>\n"),
            "vendor_annotations": self._vendor_annotations(),
            "model_variables": "\n".join(self._scalar_variable(v) for v in self.variables),
            "outputs": _unknowns_xml("Outputs", self.outputs),
            "derivatives": _unknowns_xml("Derivatives", self.derivatives),
            "initial_unknowns": _unknowns_xml("InitialUnknowns", self.initial_unknowns),
        }
        return _template("modelDescription.xml").substitute(values)

    def model_data_h(self, guid: str) -> str:
        """The text of ``model_data.h``: sizes, GUID and one value-reference macro per variable."""
        spec = self.spec
        macros = "\n".join(f"#define MW_VR_{_c_identifier(v.name)} {v.vr}u /* {v.name} */" for v in self.variables)
        return _template("model_data.h").substitute(
            model_identifier=spec.model_identifier,
            guid=_c_string(guid),
            model_identifier_string=_c_string(spec.model_identifier),
            nx=len(spec.states), nu=len(spec.inputs), np=len(spec.params), ny=len(spec.outputs),
            nz=spec.modes.nz if spec.modes is not None else 0,
            npiv=spec.modes.pivots.numel_out(0) if spec.modes is not None else 0,
            nd=len(spec.discrete.states) if spec.discrete is not None else 0,
            nvars=len(self.variables),
            narrays=len(self.arrays()),
            value_references=macros,
        )

    def model_data_c(self, casadi_header: str) -> str:
        """The text of ``model_data.c``: the variable table and start values behind ``mw_model()``."""
        spec = self.spec
        kinds = {"state": "MW_KIND_STATE", "derivative": "MW_KIND_DERIVATIVE", "input": "MW_KIND_INPUT",
                 "parameter": "MW_KIND_PARAMETER", "output": "MW_KIND_OUTPUT", "step": "MW_KIND_STEP",
                 "indicator": "MW_KIND_INDICATOR", "discrete": "MW_KIND_DISCRETE"}
        settable = {"never": "MW_SET_NEVER", "initial": "MW_SET_INITIAL", "tunable": "MW_SET_TUNABLE",
                    "input": "MW_SET_INPUT", "state": "MW_SET_STATE"}
        rows = []
        for v in self.variables:
            lo = "-HUGE_VAL" if v.min is None else _c_number(v.min)
            hi = "HUGE_VAL" if v.max is None else _c_number(v.max)
            rows.append(f"    {{{_c_string(v.name)}, {kinds[v.kind]}, {settable[v.settable]}, {v.index}u, {lo}, {hi}}},")
        fid = spec.model_identifier
        array_rows = [f"    {{{_c_string(a.name)}, {a.first}u, {a.count}u, {int(a.scalar)}u}}," for a in self.arrays()]
        return _template("model_data.c").substitute(
            casadi_header=casadi_header,
            variable_rows="\n".join(rows),
            array_rows="\n".join(array_rows),
            x_start=_c_array(spec.x_start),
            x_nominal=_c_array(np.ones(len(spec.states))),
            u_start=_c_array(np.zeros(len(spec.inputs))),
            p_start=_c_array(spec.p_start),
            step_start=_c_number(spec.step),
            ode=f"{fid}_ode", ode_sliding=f"{fid}_ode_sliding", out=f"{fid}_out", ode_dir=f"{fid}_ode_dir", out_dir=f"{fid}_out_dir",
            ode_adj=f"{fid}_ode_adj", out_adj=f"{fid}_out_adj", tick=f"{fid}_tick",
            d_start=_c_array(spec.discrete.start if spec.discrete is not None else np.zeros(0)),
            sample_period=_c_number(spec.discrete.period if spec.discrete is not None else 0.0),
            events=f"{fid}_events", events_sliding=f"{fid}_events_sliding", update=f"{fid}_update", start=f"{fid}_start", active=f"{fid}_active",
            pivots=f"{fid}_pivots",
        )

    def _robot_annotation_attrs(self) -> str:
        spec = self.spec
        attrs = f"name={quoteattr(spec.robot)} motorModel={quoteattr(spec.motor_model)}"
        if spec.robot_digest:
            attrs += f" digest={quoteattr(spec.robot_digest)}"
        if spec.robot_json:
            from .robot_resource import ROBOT_RESOURCE

            attrs += f" description={quoteattr(ROBOT_RESOURCE)}"
        return attrs

    def _vendor_annotations(self) -> str:
        if not self.spec.robot:
            return ""
        return ("  <VendorAnnotations>\n"
                "    <Tool name=\"manipulator-workbench\">\n"
                f"      <Robot {self._robot_annotation_attrs()}/>\n"
                "    </Tool>\n"
                "  </VendorAnnotations>\n")

    def _annotations_fmi3(self) -> str:
        if not self.spec.robot:
            return ""
        return ("  <Annotations>\n"
                "    <Annotation type=\"manipulator-workbench\">\n"
                f"      <Robot {self._robot_annotation_attrs()}/>\n"
                "    </Annotation>\n"
                "  </Annotations>\n")

    def _scalar_variable(self, v: Variable) -> str:
        attrs = [f"name={quoteattr(v.name)}", f'valueReference="{v.vr}"']
        if v.description:
            attrs.append(f"description={quoteattr(v.description)}")
        attrs += [f'causality="{v.causality}"', f'variability="{v.variability}"']
        if v.initial is not None:
            attrs.append(f'initial="{v.initial}"')
        real = _value_attrs(v.unit, None if v.derivative_of is None else v.derivative_of + 1,
                            None if v.start is None else _xml_number(v.start), v.min, v.max)
        return (f"    <!-- vr {v.vr}, index {v.xml_index} -->\n"
                f"    <ScalarVariable {' '.join(attrs)}>\n"
                f"      <Real {' '.join(real)}/>\n"
                f"    </ScalarVariable>")

    def _unit_definitions(self) -> str:
        lines = []
        for name in sorted(self.units):
            exps = self.units[name]
            if exps is None:
                lines.append(f"    <Unit name={quoteattr(name)}/>")
            else:
                base = " ".join(f'{k}="{e}"' for k, e in sorted(exps.items()) if e != 0)
                lines.append(f"    <Unit name={quoteattr(name)}>\n      <BaseUnit {base}/>\n    </Unit>".replace("<BaseUnit />", "<BaseUnit/>"))
        return "\n".join(lines)


# ---------------------------------------------------------------------- units

_BASE_UNITS: dict[str, dict[str, int]] = {
    "kg": {"kg": 1}, "m": {"m": 1}, "s": {"s": 1}, "A": {"A": 1}, "K": {"K": 1},
    "mol": {"mol": 1}, "cd": {"cd": 1}, "rad": {"rad": 1},
    "N": {"kg": 1, "m": 1, "s": -2}, "J": {"kg": 1, "m": 2, "s": -2}, "W": {"kg": 1, "m": 2, "s": -3},
}


def parse_unit(text: str) -> dict[str, int] | None:
    """SI base-unit exponents of a unit such as ``"N m s/rad"``, ``"kg.m2"`` or ``"m/s^2"``; None if unknown.

    Factors are separated by spaces, ``.`` or ``*``; an exponent follows its
    symbol with or without ``^``; one ``/`` divides by every factor after it.
    """
    text = text.strip().replace("^", "").replace("*", ".")
    if text in ("", "1", "-"):
        return {}
    num, _, den = text.partition("/")
    if "/" in den:
        return None
    exps: dict[str, int] = {}
    for part, sign in ((num, 1), (den, -1)):
        for token in re.split(r"[.\s]+", part.strip()):
            if token in ("", "1"):
                continue
            m = re.fullmatch(r"([A-Za-z]+)(-?\d+)?", token)
            if m is None or m.group(1) not in _BASE_UNITS:
                return None
            power = sign * int(m.group(2) or 1)
            for base, e in _BASE_UNITS[m.group(1)].items():
                exps[base] = exps.get(base, 0) + power * e
    return exps


def derivative_unit(unit: str) -> str:
    """The unit of the time derivative: ``rad -> rad/s``, ``m/s -> m/s2``, ``m/s2 -> m/s3``."""
    if not unit:
        return "1/s"
    m = re.fullmatch(r"(.*)/s(\d*)", unit)
    if m is not None:
        return f"{m.group(1)}/s{int(m.group(2) or 1) + 1}"
    if "/" in unit:
        return f"{unit}.s-1"
    return f"{unit}/s"


# ---------------------------------------------------------------------- table

def build_table(spec: ModelSpec) -> VariableTable:
    """Value references, attributes and the ModelStructure of ``spec``."""
    state_is_output = {k for k in spec.output_state if k >= 0}
    variables: list[Variable] = []

    def add(**kw: Any) -> Variable:
        v = Variable(vr=len(variables), **kw)
        variables.append(v)
        return v

    states = [add(name=q.name, kind="state", index=i, causality="output" if i in state_is_output else "local",
                  variability="continuous", initial="exact", start=float(spec.x_start[i]), unit=q.unit,
                  description=q.description, settable="state")
              for i, q in enumerate(spec.states)]
    derivs = [add(name=f"der({q.name})", kind="derivative", index=i, causality="local", variability="continuous",
                  initial="calculated", start=None, unit=derivative_unit(q.unit),
                  description=f"time derivative of {q.name}", settable="never", derivative_of=states[i].vr)
              for i, q in enumerate(spec.states)]
    inputs = [add(name=q.name, kind="input", index=i, causality="input", variability="continuous", initial=None,
                  start=0.0, unit=q.unit, description=q.description, settable="input")
              for i, q in enumerate(spec.inputs)]
    outputs = [add(name=q.name, kind="output", index=k, causality="output", variability="continuous",
                   initial="calculated", start=None, unit=q.unit, description=q.description, settable="never")
               for k, q in enumerate(spec.outputs) if spec.output_state[k] < 0]
    params = [add(name=q.name, kind="parameter", index=i, causality="parameter",
                  variability="tunable" if spec.p_tunable[i] else "fixed", initial="exact",
                  start=float(spec.p_start[i]), unit=q.unit, description=q.description,
                  settable="tunable" if spec.p_tunable[i] else "initial", min=spec.p_min[i], max=spec.p_max[i])
              for i, q in enumerate(spec.params)]
    add(name=STEP_NAME, kind="step", index=0, causality="parameter", variability="fixed", initial="exact",
        start=float(spec.step), unit="s", min=MIN_STEP, settable="initial",
        description="step of the co-simulation integrator (classical RK4): a communication step h "
                    "takes ceil(h / internal_step) equal sub-steps (k if h / internal_step is within a "
                    f"relative {SUBSTEP_RTOL:g} of an integer k), at most {MAX_SUBSTEPS} per DoStep call")

    nz = spec.modes.nz if spec.modes is not None else 0
    for i in range(nz):
        add(name=f"friction_indicator[{i + 1}]", kind="indicator", index=i, causality="local",
            variability="continuous", initial="calculated", start=None, unit="",
            description=f"event indicator of joint {i + 1}'s friction mode: positive while the mode holds",
            settable="never")

    if spec.discrete is not None:
        for i, q in enumerate(spec.discrete.states):
            add(name=q.name, kind="discrete", index=i, causality="local", variability="discrete", initial="exact",
                start=float(spec.discrete.start[i]), unit=q.unit, description=q.description, settable="initial")

    names = [v.name for v in variables]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise InputError(f"variable names: expected unique names, got duplicates {duplicates}")
    bad = [n for n in names if not is_structured_name(n.removeprefix("der(").removesuffix(")"))]
    if bad:
        raise InputError(f"variable names: expected structured FMI names such as 'q[1]', got {bad}")
    c_names = [_c_identifier(n) for n in names]
    if len(set(c_names)) != len(c_names):
        raise InputError("variable names: two names map to the same C identifier")

    # Exact structural dependencies from the CasADi Jacobian sparsity.
    def deps(f: ca.Function, row: int, with_params: bool) -> tuple[int, ...]:
        groups = [(0, states), (1, inputs)] + ([(2, params)] if with_params else [])
        found: list[int] = []
        for iind, known in groups:
            sp = f.jac_sparsity(0, iind)
            cols = [c for c in range(sp.size2()) if sp.has_nz(row, c)]
            found += [known[c].xml_index for c in cols]
        return tuple(sorted(found))

    out_unknowns = []
    for v in sorted([*states, *outputs], key=lambda v: v.vr):
        if v.causality != "output":
            continue
        if v.kind == "state":
            out_unknowns.append(Unknown(v.vr, (v.xml_index,)))
        else:
            out_unknowns.append(Unknown(v.vr, deps(spec.out, v.index, with_params=False)))
    der_unknowns = [Unknown(d.vr, deps(spec.ode, d.index, with_params=False)) for d in derivs]
    initial = [Unknown(v.vr, deps(spec.ode if v.kind == "derivative" else spec.out, v.index, with_params=True))
               for v in sorted([*derivs, *outputs], key=lambda v: v.vr)]

    units: dict[str, dict[str, int] | None] = {}
    for v in variables:
        if v.unit:
            units[v.unit] = parse_unit(v.unit)
    return VariableTable(spec, tuple(variables), tuple(out_unknowns), tuple(der_unknowns), tuple(initial), units)


# ------------------------------------------------------------ specifications

def spec_from_plant(plant: Any, step: float, model_identifier: str | None = None) -> ModelSpec:
    """The :class:`ModelSpec` of a robot's plant (:func:`model.plant.build_plant`): everything from the plant.

    States ``q[i]`` and ``qd[i]`` (also outputs), inputs the motor torques ``tau_m[i]``, outputs the
    motor positions and the tool pose in the world frame, parameters the payload and friction
    (tunable) and gravity (fixed), their start values the plant robot's parameters, and the friction
    modes of the plant. The robot the plant was built from is recorded whole (its description, motor
    model and parameters as ``resources/robot.json``, :func:`fmu.robot_resource.robot_to_json`, and the
    description's digest), so the FMU alone gives back the same robot.
    """
    from .robot_resource import robot_to_json

    robot = plant.robot
    n = int(plant.n)
    if getattr(plant, "link_mass_scale", False):
        raise InputError("expected the plant of a robot (build_plant(robot)), got a kernel plant with a "
                         "link-mass scale", parameter="plant")
    out_names = list(plant.output_names)
    if len(out_names) != 3 * n + 6:
        raise InputError(f"expected 3n + 6 = {3 * n + 6} outputs [q, qd, G q, tool position, "
                         f"tool orientation], got {len(out_names)}", parameter="plant.output_names")
    units, texts = list(plant.output_units), list(plant.output_descriptions)
    states = tuple(Quantity(out_names[k], units[k], texts[k]) for k in range(2 * n))
    drive = _drive_train_states(plant)  # an elastic gear's rotor, a current loop: local states after [q; qd]
    names = [lk.name or f"joint {i + 1}" for i, lk in enumerate(robot.description.links)]
    inputs = tuple(Quantity(f"tau_m[{i + 1}]", "N.m", f"motor torque of joint {i + 1} ({names[i]}), motor side")
                   for i in range(n))
    outputs = states + tuple(Quantity(out_names[k], units[k], texts[k]) for k in range(2 * n, 3 * n + 6))
    states = states + drive
    params = tuple(Quantity(nm, u, d) for nm, u, d in
                   zip(plant.param_names, plant.param_units, plant.param_descriptions))
    tunable = tuple(not nm.startswith("gravity") for nm in plant.param_names)
    # physical signs (model.dynamics.parameters): masses and dissipation >= 0, Tc- <= 0
    nonneg = ("payload_mass", "viscous_friction", "coulomb_friction_pos")
    p_min = tuple(0.0 if nm.split("[")[0] in nonneg else None for nm in plant.param_names)
    p_max = tuple(0.0 if nm.split("[")[0] == "coulomb_friction_neg" else None for nm in plant.param_names)
    # the first 2n outputs are exposed as the states themselves: check they are [q; qd]
    x_probe = np.random.default_rng(0).standard_normal(int(plant.nx))
    y_probe = np.asarray(plant.out(x_probe, np.zeros(n), plant.param_defaults), dtype=float).reshape(-1)
    if not np.array_equal(y_probe[:2 * n], x_probe[:2 * n]):
        raise InputError("expected the first 2n outputs to be the state [q; qd] itself", parameter="plant.out")
    identifier = fmu_identifier(model_identifier or robot.description.identifier, robot.name)
    return ModelSpec(
        model_identifier=identifier,
        model_name=robot.name,
        description=(f"{robot.description.description or robot.name}: rigid-body dynamics with motors "
                     f"({robot.motor_model} motor model) and stick-slip friction; inputs motor torques"),
        ode=plant.ode, out=plant.out,
        states=states, x_start=np.asarray(plant.x0, dtype=float),
        inputs=inputs,
        params=params, p_start=np.asarray(plant.param_defaults, dtype=float), p_tunable=tunable, p_min=p_min,
        p_max=p_max, outputs=outputs, output_state=tuple(list(range(2 * n)) + [-1] * (n + 6)),
        step=float(step),
        robot=robot.name,
        motor_model=robot.motor_model,
        robot_digest=robot.description.digest(),
        robot_json=robot_to_json(robot),
        modes=plant,
    )


def _drive_train_states(plant: Any) -> tuple[Quantity, ...]:
    """The plant's states after ``[q; qd]`` (:mod:`model.drive_train`): rotor angles and speeds of the elastic
    gears, motor torques and loop integrators of the current loops; none for a rigid arm."""
    out = []
    for name in plant.state_names[2 * int(plant.n):]:
        kind, joint = name.rstrip("]").split("[")
        unit, text = {"q_m": ("rad", "rotor angle behind the elastic gear, motor side"),
                      "qd_m": ("rad/s", "rotor speed behind the elastic gear, motor side"),
                      "tau_m": ("N.m", "motor torque of the current loop (follows the demand tau_m input)"),
                      "xi": ("N.m.s", "current-loop integrator, scaled to torque")}[kind]
        out.append(Quantity(name if kind != "tau_m" else f"tau_motor[{joint}]", unit, f"joint {joint}: {text}"))
    return tuple(out)


def trivial_spec(step: float = 1e-3, n_inputs: int = 1) -> ModelSpec:
    """A one-state lag ``xdot = rate (u_1 + ... + u_m - x), y = x``: the yardstick of an importer's own cost.

    ``n_inputs`` lets a benchmark give it as many inputs as the model it is
    compared with, so that setting the inputs costs the importer the same.
    """
    if n_inputs < 1:
        raise InputError(f"expected at least 1 input, got {n_inputs}", parameter="n_inputs")
    x, u, p = ca.SX.sym("x", 1), ca.SX.sym("u", n_inputs), ca.SX.sym("p", 1)
    ode = ca.Function("ode", [x, u, p], [p * (ca.sum1(u) - x)], ["x", "u", "p"], ["xdot"])
    out = ca.Function("out", [x, u, p], [x], ["x", "u", "p"], ["y"])
    names = ["u"] if n_inputs == 1 else [f"u[{i}]" for i in range(1, n_inputs + 1)]
    state = Quantity("x", "", "state, also the output")
    return ModelSpec(
        model_identifier="trivial",
        model_name="trivial",
        description="first-order lag xdot = rate (sum of the inputs - x): the trivial FMU of the benchmarks",
        ode=ode, out=out,
        states=(state,), x_start=np.zeros(1),
        inputs=tuple(Quantity(nm, "", "input") for nm in names),
        params=(Quantity("rate", "1/s", "inverse time constant"),), p_start=np.ones(1),
        p_tunable=(True,), p_min=(0.0,), p_max=(None,),
        outputs=(state,), output_state=(0,),
        step=float(step),
    )


# ------------------------------------------------------------------- helpers

def _template(name: str) -> string.Template:
    return string.Template((TEMPLATE_DIR / name).read_text())


def _xml_number(x: float) -> str:
    x = float(x)
    if not math.isfinite(x):
        raise InputError(f"expected a finite number for modelDescription.xml, got {x!r}")
    return repr(x)


def _c_number(x: float) -> str:
    text = _xml_number(x)
    return text if any(ch in text for ch in ".e") else text + ".0"


def _c_array(values: Any) -> str:
    vals = [float(v) for v in np.asarray(values, dtype=float).reshape(-1)]
    if not vals:
        return "{0.0}"
    return "{" + ", ".join(_c_number(v) for v in vals) + "}"


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def fmu_identifier(given: str | None, name: str) -> str:
    """An FMU's model identifier (its C prefix): ``given``, else ``name`` with every non-word character made
    '_'; either prefixed with 'm_' when it would start with a digit."""
    ident = given or re.sub(r"\W", "_", name)
    return "m_" + ident if ident[0].isdigit() else ident


def _c_identifier(name: str) -> str:
    ident = re.sub(r"[^A-Za-z0-9_]+", "_", name).strip("_")
    return ident


def _value_attrs(unit: str, derivative: int | None, start: str | None, lo: float | None, hi: float | None) -> list[str]:
    """The value attributes of a variable: unit, derivative (an index in FMI 2.0, a value reference in 3.0),
    start (one number, or an array's numbers), min and max."""
    attrs = [f"unit={quoteattr(unit)}"] if unit else []
    if derivative is not None:
        attrs.append(f'derivative="{derivative}"')
    if start is not None:
        attrs.append(f'start="{start}"')
    if lo is not None:
        attrs.append(f'min="{_xml_number(lo)}"')
    if hi is not None:
        attrs.append(f'max="{_xml_number(hi)}"')
    return attrs


def _unknowns_xml(tag: str, unknowns: Sequence[Unknown]) -> str:
    """One ModelStructure element, or nothing when it has no Unknown (the schema forbids it empty: nx = 0)."""
    if not unknowns:
        return ""
    lines = [f"    <{tag}>"]
    for u in unknowns:
        deps = " ".join(str(d) for d in u.dependencies)
        lines.append(f'      <Unknown index="{u.vr + 1}" dependencies="{deps}"/>')
    lines.append(f"    </{tag}>\n")
    return "\n".join(lines)

