"""The FMU's own reference experiment, after FMI-LS-REF 1.0.0-beta.1 (the layered standard for references).

Every plant FMU exported by :func:`fmu.build.export_fmu` carries, in
``extra/org.fmi-standard.fmi-ls-ref/`` (:data:`LS_REF_DIR`):

* ``fmi-ls-manifest.xml``: the layered standard's manifest, root ``fmiReferences``
  with ``fmi-ls-name="org.fmi-standard.fmi-ls-ref"``, one ``<Related>`` per file
  (the experiment, role ``experiment/validation``; its stimuli; its reference
  result, role ``result``);
* ``tracking.exp``: one experiment in the MA-HS-Experiments format that
  FMI-LS-REF names for experiments (MIME ``application/x-ma-hs-experiments``):
  ``startTime``, ``stopTime``, ``stepSize`` (the communication step), its
  ``<Stimuli>`` and ``<References>``, and in ``<Annotations>`` the comparison
  tolerance of every reference column (:data:`ANNOTATION_TYPE`);
* ``tracking_in.csv``: the motor torques ``tau_m`` (N m), piecewise constant,
  each switch written twice (value before, value after: the FMI cross-check and
  FMPy convention for a step), ``tracking_ref.csv``: ``q`` (rad or m) and ``qd``
  at every communication point (a robot with drive trains: the torque demands of its
  inputs ``tau_m``, through a current loop where it has one, and the links' ``q`` and
  ``qd``, the first 2n of its states; the run starts, as the FMU does, in the static
  equilibrium of the drive trains).

The CSV files follow the FMI cross-check / FMPy convention: a ``"time"``
column first, one column per variable by its FMI name, numbers as Python's
``repr`` (17 significant digits: they read back exactly); an FMI 3.0 array
variable is one column of space-separated values, as FMPy's ``read_csv`` and
fmusim read it, an FMI 2.0 FMU has one column per scalar (``q[1]``).

The reference is the workbench's own simulation, not the FMU: the one plant
advanced by its fixed-step rule (:func:`fmu.reference.plant_states`, the compiled
plant) at the FMU's ``internal_step``, under the computed-torque feed-forward of
the robot's task (:func:`fmu.reference.feedforward_profile`) over
:data:`EXPERIMENT_T_END`; :func:`fmu.build.export_fmu` computes it and this module
writes the files (it imports nothing of the validator, which imports it). The tolerance of a column is :data:`REF_RTOL` times
``max(1, max |column|)``: the same rule on the same generated expressions is
the same arithmetic (seen bit for bit), and a binary rebuilt from ``sources/`` by
another compiler differs by rounding amplified at most ~1e3 times over this short
open-loop horizon (1e-13): 1e-9 holds both with a margin and still catches any
change of the model (a payload of 1 g moves ``q`` by more, see the tests).

:func:`replay_problems` reads the experiment back from an FMU (through the
archive check; sizes bounded by its limits; XML without DTD via ``defusedxml``)
and replays it with FMPy's Co-Simulation.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from model.errors import InputError

if TYPE_CHECKING:
    from .opened import OpenedFmu

__all__ = [
    "LS_REF_DIR",
    "LS_REF_NAME",
    "LS_REF_VERSION",
    "ANNOTATION_TYPE",
    "EXPERIMENT_T_END",
    "EXPERIMENT_HOLD",
    "EXPERIMENT_MAX_STEP",
    "REF_RTOL",
    "Experiment",
    "experiment_files",
    "read_experiment",
    "replay_problems",
    "compare_with_reference",
    "csv_text",
    "parse_csv",
]

#: The layered standard's name (reverse domain notation) and its folder in the FMU archive.
LS_REF_NAME = "org.fmi-standard.fmi-ls-ref"
LS_REF_DIR = f"extra/{LS_REF_NAME}"
#: The release of FMI-LS-REF this layout follows (tag v1.0.0-beta.1 of modelica/fmi-ls-ref).
LS_REF_VERSION = "1.0.0-beta.1"
_LS_DESCRIPTION = "Layered Standard providing information on related files included in an FMU."
_LS_NS = "http://fmi-standard.org/fmi-ls-manifest"
#: The type of the experiment's annotation that carries the comparison tolerances.
ANNOTATION_TYPE = "org.manipulator-workbench.reference-tolerances"
#: Length of the experiment, s: short enough that the open-loop arm stays near its planned path.
EXPERIMENT_T_END = 0.5
#: Comparison tolerance, relative to max(1, max |column|) (see the module docstring).
REF_RTOL = 1e-9
#: Longest communication step of the experiment, s (an FMU with a longer internal step is sampled at it).
EXPERIMENT_MAX_STEP = 1e-3
#: Hold of the feed-forward torques, s (those of :func:`fmu.reference.feedforward_profile`).
EXPERIMENT_HOLD = 0.01

EXPERIMENT_FILE = "tracking.exp"
INPUT_FILE = "tracking_in.csv"
REFERENCE_FILE = "tracking_ref.csv"
MANIFEST_FILE = "fmi-ls-manifest.xml"
DOCUMENTATION_FILE = "documentation/fmi-ls-ref.txt"


@dataclass(frozen=True)
class Experiment:
    """One reference experiment as read back from an FMU."""

    start_time: float
    stop_time: float
    step_size: float             # s, the communication step of the reference
    inputs: np.ndarray           # structured: "time" then the input columns (FMPy's input table)
    reference: np.ndarray        # structured: "time" then the reference columns
    tolerances: dict[str, float]  # reference column -> absolute tolerance


def csv_text(columns: Sequence[str], t: np.ndarray, values: Sequence[np.ndarray]) -> str:
    """CSV text: ``"time"`` and ``columns``; ``values[j]`` is (len(t),) or (len(t), k) (an array column)."""
    header = ",".join(f'"{c}"' for c in ["time", *columns])
    lines = [header]
    for i, tk in enumerate(t):
        cells = [repr(float(tk))]
        for v in values:
            row = np.atleast_1d(v[i])
            cells.append(" ".join(repr(float(x)) for x in row))
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def parse_csv(text: str, what: str) -> np.ndarray:
    """A CSV of :func:`csv_text` as a structured array (an array column has a subarray dtype).

    Raises InputError naming ``what`` and the line when a row is malformed or not finite.
    """
    lines = [line for line in text.splitlines() if line.strip()]
    if len(lines) < 2:
        raise InputError(f"{what}: expected a header and at least one row", parameter=what)
    names = [c.strip().strip('"') for c in lines[0].split(",")]
    if names[0] != "time" or len(set(names)) != len(names):
        raise InputError(f"{what}: expected a first column \"time\" and distinct names, got {names[:4]}",
                         parameter=what)
    widths = [len(c.split()) for c in lines[1].split(",")]
    if len(widths) != len(names):
        raise InputError(f"{what}: line 2 has {len(widths)} cells for {len(names)} columns", parameter=what)
    dtype = [(n, np.float64, (w,)) if w > 1 else (n, np.float64) for n, w in zip(names, widths)]
    rows = []
    for k, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        try:
            parsed = [tuple(float(x) for x in c.split()) if w > 1 else float(c) for c, w in zip(cells, widths)]
            ok = len(cells) == len(names) and all(len(c.split()) == w for c, w in zip(cells, widths))
        except ValueError:
            ok = False
        if not ok or not np.all(np.isfinite(np.hstack([np.atleast_1d(p) for p in parsed]))):
            raise InputError(f"{what}: line {k} is not {len(names)} finite numbers", parameter=what)
        rows.append(tuple(parsed))
    table = np.array(rows, dtype=dtype)
    if np.any(np.diff(table["time"]) < 0):
        raise InputError(f"{what}: time goes back", parameter=what)
    return table


def _columns(base: str, n: int, fmi_version: int) -> list[str]:
    return [base] if fmi_version == 3 else [f"{base}[{i}]" for i in range(1, n + 1)]


def _split(values: np.ndarray, fmi_version: int) -> list[np.ndarray]:
    """(rows, n) values as CSV columns: one array column (FMI 3.0) or n scalar columns."""
    return [values] if fmi_version == 3 else [values[:, j] for j in range(values.shape[1])]


def experiment_files(robot_name: str, t: np.ndarray, t_switch: np.ndarray, tau_switch: np.ndarray,
                     X: np.ndarray, fmi_version: int, description: str) -> dict[str, str]:
    """The FMI-LS-REF files of a plant FMU: archive path -> text.

    ``t`` (K + 1,) are the communication points t0 + k h (s), ``X`` (K + 1, nx) the plant's
    states there, the links' ``[q, qd]`` first (a drive-train plant has more; only ``q`` and ``qd``
    are the reference); the FMU's n inputs ``tau_switch[i]`` (N m: motor torques, or a current
    loop's torque demand) hold on ``[t_switch[i], t_switch[i + 1])``, the last one to ``t[-1]``.
    ``description`` says what the torques are. Raises InputError when the reference is not finite
    or the grid is not increasing.
    """
    t, X = np.asarray(t, dtype=float), np.asarray(X, dtype=float)
    t_switch, tau_switch = np.asarray(t_switch, dtype=float), np.asarray(tau_switch, dtype=float)
    n = tau_switch.shape[1] if tau_switch.ndim == 2 else -1
    if (t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0) or X.ndim != 2 or X.shape[0] != t.size
            or n < 1 or X.shape[1] < 2 * n):
        raise InputError(f"expected increasing times, one state row per time and n inputs with at least 2n states, "
                         f"got {t.shape}, {X.shape} and {tau_switch.shape}", parameter="t")
    drive_trains = X.shape[1] > 2 * n
    if drive_trains:  # a drive-train plant: it starts (as its FMU does) in the static equilibrium
        description += "; from the static equilibrium of the drive trains (the FMU's start values)"
    if drive_trains and not np.all(np.isfinite(X)):
        raise InputError(f"the plant's reference run of {robot_name} diverged within {t[-1]:g} s: its drive "
                         "trains need a shorter internal step (export without a step for the default, "
                         "fmu.build.default_step)", parameter="step")
    X = X[:, :2 * n]
    if not np.all(np.isfinite(X)):
        raise InputError(f"the plant's reference run of {robot_name} diverged within {t[-1]:g} s", parameter="X")
    step = float(t[1] - t[0])
    keep = t_switch < t[-1] - 0.5 * step
    t_sw, tau_sw = t_switch[keep], tau_switch[keep]
    # the stimuli: each switch of the piecewise-constant torques as two rows (before, after)
    rows_t = [t_sw[0]]
    rows_v = [tau_sw[0]]
    for i in range(1, t_sw.size):
        rows_t += [t_sw[i], t_sw[i]]
        rows_v += [tau_sw[i - 1], tau_sw[i]]
    rows_t.append(t[-1])
    rows_v.append(tau_sw[-1])
    V = np.array(rows_v)
    tau_cols = _columns("tau_m", n, fmi_version)
    ref_cols = _columns("q", n, fmi_version) + _columns("qd", n, fmi_version)
    ref_values = _split(X[:, :n], fmi_version) + _split(X[:, n:], fmi_version)
    tolerances = {c: REF_RTOL * max(1.0, float(np.max(np.abs(v)))) for c, v in zip(ref_cols, ref_values)}
    d = LS_REF_DIR
    return {
        f"{d}/{INPUT_FILE}": csv_text(tau_cols, np.array(rows_t), _split(V, fmi_version)),
        f"{d}/{REFERENCE_FILE}": csv_text(ref_cols, t, ref_values),
        f"{d}/{EXPERIMENT_FILE}": _experiment_xml(robot_name, float(t[-1]), step, tolerances, description),
        f"{d}/{MANIFEST_FILE}": _manifest_xml(),
        DOCUMENTATION_FILE: _documentation(robot_name, float(t[-1]), step),
    }


def _attr(value: str) -> str:
    from xml.sax.saxutils import quoteattr

    return quoteattr(value)


def _experiment_xml(name: str, t_end: float, step: float, tolerances: dict[str, float], what: str) -> str:
    tol = "\n".join(f"          <Tolerance name={_attr(c)} absolute=\"{v!r}\"/>" for c, v in tolerances.items())
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<!-- generated, do not edit: written by fmu/ls_ref.py -->\n'
            f'<Experiments name={_attr(name + " reference")} description="The plant\'s fixed-step rule of the '
            'manipulator-workbench under the motor torques of the stimuli: q and qd at every communication point.">\n'
            f'  <Experiment name="open-loop feed-forward" description={_attr(what)} startTime="0.0" '
            f'stopTime="{t_end!r}" stepSize="{step!r}">\n'
            f'    <Stimuli source="{INPUT_FILE}"/>\n'
            f'    <References source="{REFERENCE_FILE}"/>\n'
            '    <Annotations>\n'
            f'      <Annotation type="{ANNOTATION_TYPE}">\n'
            '        <Tolerances interface="CoSimulation" description="|value - reference| at every reference row, '
            'per column">\n'
            f'{tol}\n'
            '        </Tolerances>\n'
            '      </Annotation>\n'
            '    </Annotations>\n'
            '  </Experiment>\n'
            '</Experiments>\n')


def _manifest_xml() -> str:
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<!-- generated, do not edit: written by fmu/ls_ref.py -->\n'
            f'<fmiReferences xmlns:fmi-ls="{_LS_NS}" fmi-ls:fmi-ls-name="{LS_REF_NAME}" '
            f'fmi-ls:fmi-ls-version="{LS_REF_VERSION}" fmi-ls:fmi-ls-description="{_LS_DESCRIPTION}">\n'
            f'  <Related type="application/x-ma-hs-experiments" source="{EXPERIMENT_FILE}" role="experiment/validation" '
            'description="Co-Simulation under the stimuli against the reference, within the tolerances"/>\n'
            f'  <Related type="text/csv" source="{INPUT_FILE}" role="other" '
            'description="Stimuli of the experiment: motor torques tau_m, N m"/>\n'
            f'  <Related type="text/csv" source="{REFERENCE_FILE}" role="result" '
            'description="Reference result of the experiment: q (rad or m) and qd"/>\n'
            '</fmiReferences>\n')


def _documentation(name: str, t_end: float, step: float) -> str:
    return (f"generated, do not edit: written by fmu/ls_ref.py\n\n"
            f"{LS_REF_DIR}/ holds one FMI-LS-REF experiment ({EXPERIMENT_FILE}): the robot {name} in "
            f"Co-Simulation from rest for {t_end:g} s, communication step {step:g} s, under the motor torques of "
            f"{INPUT_FILE} (piecewise constant; a switch is two rows at the same time). {REFERENCE_FILE} holds "
            "q and qd at every communication point, computed by the manipulator-workbench's own fixed-step rule, "
            "not by this FMU. The absolute tolerance of every column is in the experiment's annotation "
            f"{ANNOTATION_TYPE}.\n")


# ------------------------------------------------------------------ reading back

def _member(fmu: "OpenedFmu", name: str) -> str:
    data = fmu.member(name)
    if data is None:
        raise InputError(f"{name}: missing from the FMU", parameter=name)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{name}: not UTF-8 text", parameter=name) from None


def read_experiment(fmu_path: str | os.PathLike[str]) -> Experiment | None:
    """The FMU's reference experiment, or None when it carries none (no manifest).

    The FMU is opened by :func:`fmu.opened.open_fmu` (the archive checked first); the XML is parsed
    without DTDs. Raises InputError naming the member when the files are malformed.
    """
    from defusedxml import ElementTree as SafeET

    from .opened import open_fmu

    with open_fmu(fmu_path, validate=False) as zf:
        if f"{LS_REF_DIR}/{MANIFEST_FILE}" not in zf.members():
            return None
        manifest = SafeET.fromstring(_member(zf, f"{LS_REF_DIR}/{MANIFEST_FILE}"))
        if manifest.tag != "fmiReferences" or manifest.get(f"{{{_LS_NS}}}fmi-ls-name") != LS_REF_NAME:
            raise InputError(f"{LS_REF_DIR}/{MANIFEST_FILE}: not an FMI-LS-REF manifest", parameter=MANIFEST_FILE)
        sources = [r.get("source") for r in manifest.iter("Related") if (r.get("role") or "").startswith("experiment")]
        if not sources or any(s is None or "/" in s or "\\" in s or s.startswith(".") for s in sources):
            raise InputError(f"{LS_REF_DIR}/{MANIFEST_FILE}: expected an experiment beside the manifest, got "
                             f"{sources}", parameter=MANIFEST_FILE)
        root = SafeET.fromstring(_member(zf, f"{LS_REF_DIR}/{sources[0]}"))
        exp = root.find("Experiment")
        if exp is None:
            raise InputError(f"{LS_REF_DIR}/{sources[0]}: no <Experiment>", parameter=sources[0])
        stimuli, refs = exp.find("Stimuli"), exp.find("References")
        files = [e.get("source") if e is not None else None for e in (stimuli, refs)]
        if any(f is None or "/" in f or "\\" in f or f.startswith(".") for f in files):
            raise InputError(f"{LS_REF_DIR}/{sources[0]}: expected <Stimuli> and <References> beside it, got {files}",
                             parameter=sources[0])
        inputs = parse_csv(_member(zf, f"{LS_REF_DIR}/{files[0]}"), f"{LS_REF_DIR}/{files[0]}")
        reference = parse_csv(_member(zf, f"{LS_REF_DIR}/{files[1]}"), f"{LS_REF_DIR}/{files[1]}")
    tolerances: dict[str, float] = {}
    for tol in exp.iter("Tolerance"):
        try:
            tolerances[str(tol.get("name"))] = float(tol.get("absolute", "nan"))
        except ValueError:
            raise InputError(f"{sources[0]}: tolerance of {tol.get('name')!r} is not a number",
                             parameter=sources[0]) from None
    try:
        start, stop, step = (float(exp.get(a, "nan")) for a in ("startTime", "stopTime", "stepSize"))
    except ValueError:
        raise InputError(f"{sources[0]}: startTime, stopTime and stepSize must be numbers", parameter=sources[0]) from None
    if not (np.isfinite([start, stop, step]).all() and step > 0 and stop > start):
        raise InputError(f"{sources[0]}: expected startTime < stopTime and stepSize > 0, got {start}, {stop}, {step}",
                         parameter=sources[0])
    return Experiment(start, stop, step, inputs, reference, tolerances)


def replay_problems(fmu_path: str | os.PathLike[str], exp: Experiment | None = None) -> tuple[float, list[str]]:
    """Replay the FMU's experiment with FMPy's Co-Simulation; (worst |error| / tolerance, problems).

    Each reference column is compared at every reference row with its tolerance; a
    column without a tolerance, or a reference time FMPy did not output, is a problem.
    """
    from fmpy import simulate_fmu

    exp = read_experiment(fmu_path) if exp is None else exp
    if exp is None:
        return float("nan"), ["the FMU carries no FMI-LS-REF experiment"]
    names = list(exp.reference.dtype.names[1:])
    result = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", start_time=exp.start_time,
                          stop_time=exp.stop_time, output_interval=exp.step_size, input=exp.inputs, output=names)
    return compare_with_reference(result, exp)


def compare_with_reference(result: np.ndarray, exp: Experiment) -> tuple[float, list[str]]:
    """A simulation result (structured, ``time`` and the reference columns) against ``exp``'s reference."""
    problems: list[str] = []
    worst = 0.0
    t = np.asarray(result["time"])
    idx = np.searchsorted(t, exp.reference["time"] - 1e-9 * exp.step_size)
    if np.any(idx >= t.size) or np.any(np.abs(t[np.minimum(idx, t.size - 1)] - exp.reference["time"])
                                       > 1e-9 * exp.step_size):
        return float("nan"), ["the replay did not output every reference time"]
    for name in exp.reference.dtype.names[1:]:
        tol = exp.tolerances.get(name)
        if tol is None or not tol > 0:
            problems.append(f"reference column {name}: no positive tolerance")
            continue
        err = float(np.max(np.abs(np.asarray(result[name])[idx] - exp.reference[name])))
        worst = max(worst, err / tol) if np.isfinite(err) else float("inf")
        if not err <= tol:
            problems.append(f"{name}: max |replay - reference| = {err:.3e} > tolerance {tol:.3e}")
    return worst, problems

