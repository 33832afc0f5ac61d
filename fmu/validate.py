"""Validate an exported FMU: description, binary, simulations against the Python model.

:func:`validate_fmu` runs every check and returns a :class:`ValidationReport`:

* FMPy's validation of ``modelDescription.xml`` (schema, names, units, ModelStructure);
* the binary: it exports the ``fmi2`` or ``fmi3`` functions (its FMI version's) only and needs only libc and libm; the
  binaries of other platforms (Windows, macOS, Linux on aarch64) are listed and
  checked structurally (:mod:`fmu.binaries`);
* Co-Simulation and Model Exchange (CVode) runs by FMPy against the one plant
  (:mod:`model.plant`, the robot read back from the FMU) advanced by its fixed-step
  rule (the rule every engine runs, stick-slip friction events included) at an
  eighth of the FMU's internal step, on the computed-torque feed-forward of the
  robot's task (open loop, so over a short horizon where the comparison is
  meaningful): Co-Simulation within ten times RK4's own error estimate,
  Model Exchange within its tolerance, and Co-Simulation against the same rule at
  the FMU's own step to rounding (the FMU is the plant);
* FMU state get/set and serialise/deserialise round trips, bit for bit;
* directional derivatives against central finite differences (FMI 3.0: the adjoint against them too;
  the FMI 3.0 calls are :mod:`fmu.validate3`'s, the list of checks is the same for both versions);
* the FMU's own FMI-LS-REF experiment replayed with FMPy (:mod:`fmu.ls_ref`);
* libcosim, the second importer (FMI 2.0 only: skipped for an FMI 3.0 FMU): two instances side by side,
  against FMPy.

Every function here that opens an FMU first passes it through
:func:`fmu.archive.check_fmu_archive` (limits, paths, links, zip bombs): a
hostile archive is refused before anything is extracted or loaded. The checks
after it load and run the FMU's binary: validate only FMUs whose binary you
would run.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from model.errors import InputError

from .archive import check_fmu_archive, model_description_xml
from .roundtrip import StateCalls, cs_roundtrip, me_roundtrip
from .check_results import RoundTrip, fd_mismatch
from .variables import substeps
from .robot_resource import RobotNotReloadableError, fmu_robot, reload_fmu_robot
from model.limits import MAX_SAMPLES

__all__ = [
    "TOLERANCES",
    "ME_RTOL",
    "DIVERGENCE_GAIN",
    "Check",
    "divergence_horizon",
    "REFERENCE_REFINEMENT",
    "plant_states",
    "start_state",
    "TorqueProfile",
    "TrackingError",
    "RoundTrip",
    "ValidationReport",
    "feedforward_profile",
    "reference_response",
    "model_description_xml",
    "model_description_problems",
    "binary_problems",
    "tracking_error",
    "state_roundtrip",
    "directional_derivative_error",
    "validate_fmu",
]

ME_RTOL = 1e-10
#: The reference is the plant's fixed-step rule at the FMU's internal step divided by this: RK4's error,
#: O(h^4), is then 8^4 = 4096 times smaller than the FMU's, below what the Co-Simulation check resolves.
REFERENCE_REFINEMENT = 8
#: The comparison horizon ends where the open-loop arm amplifies a perturbation of its state this much:
#: beyond it a tolerance-sized difference grows into anything and a comparison says nothing.
DIVERGENCE_GAIN = 1e3
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

Progress = Callable[[str], None]


def _say(progress: Progress | None, message: str) -> None:
    if progress is not None:
        progress(message)


# ------------------------------------------------------------ torque profile

@dataclass(frozen=True)
class TorqueProfile:
    """Piecewise-constant motor torques: ``tau_m[i]`` (N m, motor side) holds on ``[t_switch[i], t_switch[i+1])``."""

    t_switch: np.ndarray
    tau_m: np.ndarray
    t_end: float
    q_plan: np.ndarray  # (K + 1, n) planned joint positions at t_switch and t_end
    description: str

    def at(self, t: float) -> np.ndarray:
        """The torques held at time ``t``."""
        i = int(np.searchsorted(self.t_switch, t + 1e-12 * max(1.0, abs(t)), side="right")) - 1
        return self.tau_m[min(max(i, 0), self.tau_m.shape[0] - 1)]

    @property
    def hold(self) -> float:
        return float(self.t_switch[1] - self.t_switch[0]) if self.t_switch.size > 1 else self.t_end


def feedforward_profile(robot: Any, t_end: float = 3.0, hold: float = 0.01) -> TorqueProfile:
    """Computed-torque feed-forward of the robot's task, held for ``hold`` s at a time.

    A robot whose file has ``[[tasks]]`` follows its first task from the start
    (the SCARA: the seed's pick-and-place, first segment rest to above the pick
    point in 3 s); other robots a quintic from rest, +0.5 rad or m per joint
    (within the limits). Motor torques are ``robot.rne(q, qd, qdd) / G`` at the
    middle of each hold interval.
    """
    from model.tasks import robot_tasks
    from model.trajectory import jtraj

    k = int(round(t_end / hold))
    if k < 1 or abs(k * hold - t_end) > 1e-9 * t_end:
        raise InputError(f"expected a whole number of hold intervals of {hold} s, got {t_end}", parameter="t_end")
    tasks = robot_tasks(robot.description)
    if tasks:
        task = next(iter(tasks.values()))
        traj = task.trajectory(dt=0.01)
        what = f"task {task.name!r} of the robot file, from its start"
    else:
        lo, hi = robot.qlim
        q0 = robot.q_rest
        q1 = np.clip(q0 + 0.5, lo, hi)
        traj = jtraj(q0, q1, T=t_end, dt=hold)
        what = "quintic from rest, +0.5 per joint"
    t_switch = np.arange(k) * hold
    t_mid = t_switch + 0.5 * hold
    samples = [traj.sample(float(t)) for t in t_mid]
    Q, QD, QDD = (np.array([s[j] for s in samples]) for j in range(3))
    tau = robot.rne_batch(Q, QD, QDD)
    q_plan = np.array([traj.sample(float(t))[0] for t in np.append(t_switch, t_end)])
    return TorqueProfile(t_switch, tau / robot.gear_ratio, float(t_end), q_plan,
                         f"{what}: computed-torque feed-forward, held {hold * 1e3:g} ms")


def start_state(robot: Any) -> np.ndarray:
    """(nx,) the state the robot's plant FMU starts in: ``[q_rest, 0]`` (rad or m, rad/s or m/s) for a rigid
    arm, the static equilibrium at ``q_rest`` (:func:`model.drive_train.equilibrium_state`, the plant's
    ``x0``) for one with drive trains, its states ``[q, qd, q_m, qd_m, tau_motor, xi]``."""
    from model.drive_train import equilibrium_state, has_drive_trains

    desc = robot.description
    if not has_drive_trains(desc):
        return np.concatenate([robot.q_rest, np.zeros(robot.n)])
    return equilibrium_state(desc, desc.q_rest, np.asarray(robot.gravload(desc.q_rest), dtype=float))


def plant_states(robot: Any, t: np.ndarray, tau_m: np.ndarray, sub_step: float, p: np.ndarray | None = None,
                 x0: np.ndarray | None = None) -> np.ndarray:
    """(len(t), nx) states of the one plant at the times ``t`` under its inputs ``tau_m[k]`` (N m, the motor
    torques or torque demands) held on ``[t_k, t_k+1]``; ``q`` and ``qd`` are the first 2n columns.

    ``robot``'s plant (:mod:`model.plant`, parameters ``p``, default the robot's) is advanced by its
    fixed-step rule (:mod:`model.compiled_plant`) over each interval in sub-steps of at most ``sub_step``
    s (counted as the FMU counts them, :func:`fmu.variables.substeps`) from ``x0`` (default
    :func:`start_state`, where the FMU starts; nx = 2n for a rigid arm, more with drive trains). The
    modes start as an importer starts the FMU: the first torques set before initialisation ends. Rows
    after a divergence are NaN.
    """
    from model.compiled_plant import compiled_plant

    run = compiled_plant(robot).run(robot.parameters.vector if p is None else p)
    x_start = start_state(robot) if x0 is None else np.asarray(x0, dtype=float)
    X = np.full((len(t), run.x.size), np.nan)
    try:
        run.start(x_start, tau_m[0])
        X[0] = run.x
        for k in range(len(t) - 1):
            h = float(t[k + 1] - t[k])
            if not run.advance(tau_m[k], h, substeps(h, sub_step)):
                break
            X[k + 1] = run.x
    finally:
        run.close()
    return X


def reference_response(robot: Any, profile: TorqueProfile, p: np.ndarray | None = None,
                       x0: np.ndarray | None = None, internal_step: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """The one plant under ``profile``: times ``t_switch`` and ``t_end``, and the states there, by
    :func:`plant_states` at ``internal_step / REFERENCE_REFINEMENT``."""
    t = np.append(profile.t_switch, profile.t_end)
    return t, plant_states(robot, t, profile.tau_m, internal_step / REFERENCE_REFINEMENT, p=p, x0=x0)


# ------------------------------------------------------- description, binary

def model_description_problems(fmu_path: str | os.PathLike[str]) -> list[str]:
    """FMPy's validation of the FMU (schema, variable names, units, ModelStructure)."""
    from fmpy.validation import validate_fmu as fmpy_validate_fmu

    check_fmu_archive(fmu_path)
    return list(fmpy_validate_fmu(str(fmu_path)))


def binary_problems(fmu_path: str | os.PathLike[str]) -> tuple[list[str], dict[str, Any]]:
    """Check the FMU's binary: only ``fmi2`` (FMI 2.0) or ``fmi3`` (FMI 3.0) functions exported, only libc and libm needed.

    Returns the problems and facts (``exports``, ``needed``) for the report.
    """
    check_fmu_archive(fmu_path)
    problems: list[str] = []
    facts: dict[str, Any] = {}
    from .binaries import carried_platforms
    from .platforms import host_platform, platform_folder
    from .simulate import fmi_version

    version = fmi_version(fmu_path)
    prefix = f"fmi{version}"
    host = host_platform()
    carried = carried_platforms(fmu_path, version)
    facts["platforms"] = list(carried)
    with tempfile.TemporaryDirectory(prefix="mw_fmu_check_") as tmp, zipfile.ZipFile(fmu_path) as zf:
        problems += _other_platforms(zf, carried, host.name, Path(tmp), facts, prefix)
        binaries = [carried[host.name]] if host.name in carried else []
        if not binaries:
            folder = platform_folder(host.name, version)
            return problems + [f"{fmu_path}: no binaries/{folder}/*{host.suffix} (this machine's) in the FMU"], facts
        lib = Path(zf.extract(binaries[0], tmp))
        tools = [t for t in ("nm", "readelf") if shutil.which(t) is None]
        if tools:
            return [f"binary check: expected {tools} on PATH (binutils)"], facts
        nm = subprocess.run(["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True, check=False)
        if nm.returncode != 0:  # not a shared object nm can read: a problem of the FMU, not a crash
            reason = " ".join(nm.stderr.split())[:200]
            return [f"{binaries[0]} is not a shared object nm can read ({reason})"], facts
        exports = sorted(line.split()[-1] for line in nm.stdout.splitlines() if line.strip())
        others = [s for s in exports if not s.startswith(prefix)]
        if others:
            problems.append(f"{binaries[0]} exports non-FMI symbols: {others}")
        facts["exports"] = len(exports)
        elf = subprocess.run(["readelf", "-d", str(lib)], capture_output=True, text=True, check=False)
        needed = re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", elf.stdout)
        extra = [lib_name for lib_name in needed if not re.fullmatch(r"lib(c|m)\.so\.\d+", lib_name)]
        if extra:
            problems.append(f"{binaries[0]} needs libraries beyond libc and libm: {extra}")
        facts["needed"] = needed
    return problems, facts


def _other_platforms(zf: zipfile.ZipFile, carried: dict[str, str], host: str, tmp: Path,
                     facts: dict[str, Any], prefix: str) -> list[str]:
    """Structural checks (llvm-objdump) of the binaries this machine does not load; problems named by member."""
    from .binaries import check_binary, objdump
    from .platforms import PLATFORMS

    others = [p for p in PLATFORMS if p.name in carried and p.name != host]
    tool = objdump()
    if not others or tool is None:
        facts["structure"] = "no other platforms" if not others else "not checked: llvm-objdump not on PATH"
        return []
    problems = []
    for target in others:
        found = check_binary(zf.extract(carried[target.name], tmp / target.name), target, tool, prefix=prefix)
        problems += [f"{carried[target.name]} ({target.name}): {p}" for p in found.problems]
    facts["structure"] = f"checked with llvm-objdump: {', '.join(p.name for p in others)}"
    return problems


# ---------------------------------------------------------------- tracking

@dataclass(frozen=True)
class TrackingError:
    """Largest deviation of an FMU run from the reference over the horizon, per joint, and the motion scales.

    ``q``, ``qd`` (per joint) and ``tool_position`` are absolute; ``*_scale`` are the
    largest joint excursion, joint speed and tool excursion of the reference, by
    which :attr:`relative` divides them.
    """

    label: str
    horizon: float
    q: np.ndarray
    qd: np.ndarray
    tool_position: float
    q_scale: float = 1.0
    qd_scale: float = 1.0
    p_scale: float = 1.0

    @property
    def relative(self) -> dict[str, float]:
        """Largest errors over the motion scales: keys ``q``, ``qd``, ``tool``."""
        return {"q": float(self.q.max()) / self.q_scale, "qd": float(self.qd.max()) / self.qd_scale,
                "tool": self.tool_position / self.p_scale}

    def line(self) -> str:
        return (f"{self.label:<28} max|q - q_ref| = {self.q.max():.3e}   max|qd - qd_ref| = {self.qd.max():.3e}   "
                f"max|p_tool - p_ref| = {self.tool_position:.3e} m   (over {self.horizon:g} s)")


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


def divergence_horizon(robot: Any, profile: TorqueProfile, X_ref: np.ndarray, delta: float = 1e-6,
                       internal_step: float = 1e-3) -> float:
    """Time (s, a switching time of ``profile``) until which the open-loop arm amplifies a perturbation
    of its initial joint positions at most :data:`DIVERGENCE_GAIN` times.

    The reference is integrated again from ``x0 + delta`` on every position (rad or m; positions,
    so that joints at rest stay at rest and stuck; an elastic gear's rotor turned with its link) and
    compared with ``X_ref`` on the links' ``q`` and ``qd`` (its first 2n columns); the horizon is the
    last switching time before the difference exceeds ``DIVERGENCE_GAIN * delta`` (the whole
    profile if it never does).
    """
    from model.drive_train import drive_layout

    n = robot.n
    lay = drive_layout(robot.description)
    x0 = X_ref[0].copy()
    x0[:n] += delta
    # an elastic gear's rotor turns with its link (G delta): the spring keeps its deflection, as it does on a rigid gear
    x0[lay.qm_slice] += np.asarray(robot.gear_ratio, dtype=float)[list(lay.elastic)] * delta
    t, X = reference_response(robot, profile, x0=x0, internal_step=internal_step)
    gain = np.max(np.abs(X[:, :2 * n] - X_ref[:, :2 * n]), axis=1) / delta
    beyond = np.flatnonzero(gain > DIVERGENCE_GAIN)
    return float(t[-1] if beyond.size == 0 else t[max(int(beyond[0]) - 1, 0)])


@dataclass(frozen=True)
class Check:
    """One acceptance check: a figure, its bound and what the figure is."""

    name: str
    value: float
    bound: float
    what: str

    @property
    def passed(self) -> bool:
        return bool(self.value <= self.bound)   # NaN fails

    def line(self) -> str:
        verdict = "ok  " if self.passed else "FAIL"
        relation = "<=" if self.passed else ">"
        return f"{verdict} {self.name}: {self.what} = {self.value:.3e} {relation} bound {self.bound:.3e}"


# ---------------------------------------------------------- low-level checks

def _vrs(md: Any, names: Sequence[str]) -> list[int]:
    by_name = {v.name: v.valueReference for v in md.modelVariables}
    return [by_name[n] for n in names]


def _slave(fmu_path: str | os.PathLike[str], unzip_dir: str, name: str, kind: str = "cs") -> Any:
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Model, FMU2Slave

    check_fmu_archive(fmu_path)
    md = read_model_description(str(fmu_path))
    cls = FMU2Slave if kind == "cs" else FMU2Model
    ident = md.coSimulation.modelIdentifier if kind == "cs" else md.modelExchange.modelIdentifier
    return cls(guid=md.guid, unzipDirectory=unzip_dir, modelIdentifier=ident, instanceName=name)


def _initialised(fmu_path: str | os.PathLike[str], unzip_dir: str, name: str, kind: str = "cs") -> Any:
    """A new :func:`_slave` instantiated and initialised at t = 0 (Model Exchange: in continuous-time mode)."""
    s = _slave(fmu_path, unzip_dir, name, kind=kind)
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    if kind == "me":
        s.enterContinuousTimeMode()
    return s


def state_roundtrip(fmu_path: str | os.PathLike[str], inputs: Callable[[float], Sequence[float]],
                    input_names: Sequence[str], output_names: Sequence[str], step: float = 1e-3,
                    steps_before: int = 500, steps_after: int = 500) -> RoundTrip:
    """Run, save the FMU state, run on; restore (and deserialise in a second instance) and run again.

    All three continuations must agree bit for bit. Model Exchange: derivatives
    after ``fmi2SetFMUstate`` must equal those when the state was taken.
    """
    from fmpy import extract, read_model_description

    check_fmu_archive(fmu_path)
    md = read_model_description(str(fmu_path))
    vin, vout = _vrs(md, input_names), _vrs(md, output_names)
    unzip = extract(str(fmu_path))
    try:
        def run(s: Any, k0: int, n: int) -> np.ndarray:
            out = np.zeros((n, len(vout)))
            for k in range(k0, k0 + n):
                t = k * step
                s.setReal(vin, list(inputs(t)))
                s.doStep(currentCommunicationPoint=t, communicationStepSize=step)
                out[k - k0] = s.getReal(vout)
            return out

        get_set, deserialized, size = cs_roundtrip(
            lambda name: (s := _initialised(fmu_path, unzip, name), _calls2(s)), run, steps_before, steps_after)
        me_same = _me_roundtrip(fmu_path, unzip, md)
    finally:
        shutil.rmtree(unzip, ignore_errors=True)
    return RoundTrip(steps_before, steps_after, size, get_set, deserialized, me_same)


def _calls2(m: Any, nx: int = 0) -> StateCalls:
    """The FMI 2.0 spellings of the round trip's calls on instance ``m`` (``nx`` states for Model Exchange)."""
    def end() -> None:
        m.terminate()
        m.freeInstance()

    return StateCalls(m.getFMUstate, m.setFMUstate, m.serializeFMUstate, m.deSerializeFMUstate, m.freeFMUstate, end,
                      lambda: _states(m, nx), lambda x: _set_states(m, x), lambda: _derivatives(m, nx))


def _me_roundtrip(fmu_path: str | os.PathLike[str], unzip: str, md: Any) -> bool:
    m = _initialised(fmu_path, unzip, "roundtrip_me", kind="me")
    return me_roundtrip(_calls2(m, len(md.derivatives)))


def _states(m: Any, nx: int) -> np.ndarray:
    from fmpy.fmi2 import fmi2Real

    buf = (fmi2Real * nx)()
    m.fmi2GetContinuousStates(m.component, buf, nx)
    return np.array(buf[:])


def _set_states(m: Any, x: np.ndarray) -> None:
    from fmpy.fmi2 import fmi2Real

    buf = (fmi2Real * x.size)(*x)
    m.fmi2SetContinuousStates(m.component, buf, x.size)


def _derivatives(m: Any, nx: int) -> np.ndarray:
    from fmpy.fmi2 import fmi2Real

    buf = (fmi2Real * nx)()
    m.fmi2GetDerivatives(m.component, buf, nx)
    return np.array(buf[:])




def directional_derivative_error(fmu_path: str | os.PathLike[str], seed: int = 7,
                                 rel_step: float = 1e-4) -> tuple[float, int]:
    """Largest ``|AD - FD| / (1 + |FD|)`` over the Jacobian of derivatives and outputs (Model Exchange).

    Knowns: every state, every input and every tunable parameter; the point is
    a seeded random perturbation of the start state with random inputs; the
    finite differences are central at ``h`` and ``2 h``, Richardson-combined
    (error O(h^4)), for ``h = rel_step * max(1, |value|) * 10^-k``, k < :data:`fmu.check_results.FD_LADDER`;
    each entry keeps its best rung.
    Returns the error and the number of Jacobian entries compared.
    """
    from fmpy import extract, read_model_description

    check_fmu_archive(fmu_path)
    md = read_model_description(str(fmu_path))
    unzip = extract(str(fmu_path))
    try:
        variables = sorted(md.modelVariables, key=lambda v: v.valueReference)
        derivs = [u.variable for u in md.derivatives]
        states = [d.derivative for d in derivs]
        state_vrs = {s.valueReference for s in states}
        outputs = [v for v in variables if v.causality == "output" and v.valueReference not in state_vrs]
        inputs = [v for v in variables if v.causality == "input"]
        params = [v for v in variables if v.causality == "parameter" and v.variability == "tunable"]
        unknowns = [v.valueReference for v in derivs + outputs]
        nx = len(states)
        rng = np.random.default_rng(seed)

        m = _initialised(fmu_path, unzip, "directional", kind="me")
        x = _states(m, nx) + 0.2 * rng.standard_normal(nx)
        _set_states(m, x)
        u = 0.05 * rng.standard_normal(len(inputs))
        m.setReal([v.valueReference for v in inputs], list(u))
        # move parameters that sit on a bound (no payload, no Coulomb friction) inside their range
        m.enterEventMode()
        for v in params:
            value = m.getReal([v.valueReference])[0]
            lo = float(v.min) if v.min is not None else -np.inf
            hi = float(v.max) if v.max is not None else np.inf
            if value - lo < 1e-3:
                m.setReal([v.valueReference], [lo + 0.5])
            elif hi - value < 1e-3:
                m.setReal([v.valueReference], [hi - 0.5])
        m.enterContinuousTimeMode()

        def evaluate() -> np.ndarray:
            return np.concatenate([_derivatives(m, nx), np.array(m.getReal([v.valueReference for v in outputs]))])

        def set_param(vr: int, value: float) -> None:
            m.enterEventMode()
            m.setReal([vr], [value])
            m.enterContinuousTimeMode()

        worst, count = 0.0, 0
        for j, known in enumerate(states + inputs + params):
            ad = np.array(m.getDirectionalDerivative(unknowns, [known.valueReference], [1.0]))
            if j < nx:
                base = x[j]
            else:
                base = m.getReal([known.valueReference])[0]
            scale = max(1.0, abs(base))

            def at(step: float) -> np.ndarray:
                if j < nx:
                    xp = x.copy()
                    xp[j] = base + step
                    _set_states(m, xp)
                elif known in inputs:
                    m.setReal([known.valueReference], [base + step])
                else:
                    set_param(known.valueReference, base + step)
                return evaluate()

            best = fd_mismatch(ad, at, scale, rel_step)
            if j < nx:
                _set_states(m, x)
            elif known in inputs:
                m.setReal([known.valueReference], [base])
            else:
                set_param(known.valueReference, base)
            worst = max(worst, float(np.max(best)))
            count += ad.size
        m.terminate()
        m.freeInstance()
    finally:
        shutil.rmtree(unzip, ignore_errors=True)
    return worst, count


# ------------------------------------------------------------------ report

@dataclass
class ValidationReport:
    """Everything :func:`validate_fmu` found; :meth:`problems` lists what failed, :meth:`format` prints it.

    Every numerical comparison is a :class:`Check` in ``checks`` (figure and bound);
    :meth:`format` prints each one, passed or failed, so a failure names itself.
    """

    fmu: str
    description_problems: list[str]
    binary_problems: list[str]
    binary_facts: dict[str, Any]
    robot: tuple[str, str] | None = None
    profile: str = ""
    plan_drift: float = float("nan")
    horizon: float | None = None       # the compared horizon, s (divergence_horizon)
    errors: list[TrackingError] = field(default_factory=list)
    roundtrip: RoundTrip | None = None
    directional: tuple[float, int] | None = None
    cosim_between_instances: float | None = None
    cosim_vs_fmpy: float | None = None
    checks: list[Check] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    robot_skipped: str | None = None   # why the recorded robot was not reloaded (comparisons not run)
    cosim_skipped: str | None = None   # why the libcosim check was not run

    def problems(self) -> list[str]:
        found = list(self.description_problems) + list(self.binary_problems)
        found += [c.line() for c in self.checks if not c.passed]
        return found

    @property
    def ok(self) -> bool:
        return not self.problems()

    def format(self) -> str:
        lines = [f"FMU {self.fmu}"]
        lines.append(f"  modelDescription.xml (FMPy validation): {len(self.description_problems)} problems")
        lines += [f"    - {p}" for p in self.description_problems]
        facts = self.binary_facts
        lines.append(f"  binary: {facts.get('exports', '?')} exported symbols, needs {facts.get('needed', '?')}: "
                     f"{len(self.binary_problems)} problems")
        lines += [f"    - {p}" for p in self.binary_problems]
        if facts.get("platforms"):
            lines.append(f"  platforms: {', '.join(facts['platforms'])} (this machine's loaded and run; others "
                         f"{facts.get('structure', 'not checked')})")
        if self.robot is not None and self.robot_skipped is not None:
            lines.append(f"  robot {self.robot[0]!r} ({self.robot[1]} motors): {self.robot_skipped}; "
                         "simulations against the Python model not run")
        elif self.robot is not None:
            lines.append(f"  robot {self.robot[0]!r} ({self.robot[1]} motors, from the FMU's resources); "
                         f"input: {self.profile}")
            lines += [f"  note: {note}" for note in self.notes]
            if self.horizon is not None:
                lines.append(f"  horizon {self.horizon:g} s: the open-loop arm amplifies a perturbation at most "
                             f"{DIVERGENCE_GAIN:g} times up to there")
            lines.append(f"  open loop: the Python model leaves the planned path by {self.plan_drift:.3e} "
                         f"(max |q - q_plan|) over the horizon")
            for e in self.errors:
                lines.append("  " + e.line())
        else:
            lines.append("  no robot recorded in VendorAnnotations: simulations against the Python model not run")
        if self.roundtrip is not None:
            r = self.roundtrip
            lines.append(f"  FMU state: {r.serialized_size}-byte serialisation; after {r.steps_before} + "
                         f"{r.steps_after} steps get/set {'identical' if r.get_set_identical else 'DIFFERENT'}, "
                         f"deserialised in a second instance {'identical' if r.deserialized_identical else 'DIFFERENT'}, "
                         f"Model Exchange {'identical' if r.me_identical else 'DIFFERENT'} (bit for bit)")
        if self.directional is not None:
            lines.append(f"  directional derivatives vs central differences: max |AD - FD| / (1 + |FD|) = "
                         f"{self.directional[0]:.3e} over {self.directional[1]} entries")
        if self.cosim_between_instances is not None:
            lines.append(f"  libcosim, two instances: max difference between them {self.cosim_between_instances:.3e}, "
                         f"against FMPy Co-Simulation {self.cosim_vs_fmpy:.3e}")
        if self.cosim_skipped is not None:
            lines.append(f"  libcosim: skipped ({self.cosim_skipped})")
        if self.checks:
            lines.append("  checks:")
            lines += [f"    {c.line()}" for c in self.checks]
        found = self.problems()
        lines.append(f"  result: {'OK' if not found else f'{len(found)} problems'}")
        lines += [f"    failed: {p}" for p in found]
        return "\n".join(lines)


def _tracking_checks(e: TrackingError, kind: str, bound: float, basis: str) -> list[Check]:
    rel = e.relative
    return [
        Check(f"{kind} q", rel["q"], bound, f"max|q - q_ref| / {e.q_scale:.3g} (largest joint excursion), {basis}"),
        Check(f"{kind} qd", rel["qd"], bound, f"max|qd - qd_ref| / {e.qd_scale:.3g} (largest joint speed), {basis}"),
        Check(f"{kind} tool", rel["tool"], bound,
              f"max|p_tool - p_ref| / {e.p_scale:.3g} m (largest tool excursion), {basis}"),
    ]


def validate_fmu(fmu_path: str | os.PathLike[str], *, t_end: float = 3.0, step: float = 1e-3,
                 with_cosim: bool = True, progress: Progress | None = None) -> ValidationReport:
    """Run every check on an FMU (see the module docstring).

    ``t_end`` (s) is the longest horizon simulated; the comparisons with the Python
    model end earlier where the open-loop arm diverges (:func:`divergence_horizon`).
    Nothing but the FMU is needed: the robot comes from its ``resources/robot.json``.
    """
    if not (math.isfinite(step) and 0 < step <= t_end):
        raise InputError(f"expected a communication step > 0 and no longer than the horizon of {t_end:g} s, got "
                         f"{step:g} s", parameter="step")
    if t_end / step + 1 > MAX_SAMPLES:  # before any work: the runs sample every step
        raise InputError(f"{t_end:g} s at a step of {step:g} s: {t_end / step + 1:.4g} samples, more than the "
                         f"sample limit of {MAX_SAMPLES}", parameter="t_end")
    fmu_path = str(fmu_path)
    check_fmu_archive(fmu_path)  # FmuArchiveError (a ValueError) naming the file, before anything is extracted
    _say(progress, "validating modelDescription.xml with FMPy")
    report = ValidationReport(fmu_path, model_description_problems(fmu_path), *binary_problems(fmu_path))
    _ls_ref_check(report, fmu_path, progress)
    report.robot = fmu_robot(fmu_path)
    if report.robot is None:
        return report

    from model.plant import build_plant

    from .simulate import simulate_cs, simulate_me, step_input

    try:
        robot = reload_fmu_robot(fmu_path)
    except RobotNotReloadableError as exc:
        report.robot_skipped = f"robot not reloadable: {exc}"
        return report
    n = robot.n
    plant = build_plant(robot)
    p_ref = np.array(plant.param_defaults, dtype=float)
    start: dict[str, float] = {}
    internal = _internal_step(fmu_path)
    if np.any(robot.parameters.field("coulomb_friction_pos") - robot.parameters.field("coulomb_friction_neg") > 0):
        report.notes.append("Coulomb friction with stick-slip: the reference is the plant's rule with its friction "
                            "modes (events located by bisection)")
    _say(progress, f"computed-torque feed-forward over {t_end:g} s")
    profile = feedforward_profile(robot, t_end=t_end)
    report.profile = profile.description
    _say(progress, f"reference: the plant's fixed-step rule at internal_step / {REFERENCE_REFINEMENT}")
    t_ref, X_ref = reference_response(robot, profile, internal_step=internal)
    _say(progress, "divergence horizon: the reference again from positions perturbed by 1e-6")
    horizon = divergence_horizon(robot, profile, X_ref, internal_step=internal)
    keep = t_ref <= horizon + 1e-12
    if keep.sum() < 2:
        keep[:2] = True
        horizon = float(t_ref[1])
    t_ref, X_ref = t_ref[keep], X_ref[keep]
    report.horizon = horizon
    report.plan_drift = float(np.max(np.abs(X_ref[:, :n] - profile.q_plan[keep])))
    u_mid = np.vstack([profile.tau_m, profile.tau_m[-1]])[keep]
    P_ref = np.array([np.asarray(plant.out(x, u, p_ref)).reshape(-1)[3 * n:3 * n + 3]
                      for x, u in zip(X_ref, u_mid)])

    tau_names = [f"tau_m[{i}]" for i in range(1, n + 1)]
    state_names = [f"q[{i}]" for i in range(1, n + 1)] + [f"qd[{i}]" for i in range(1, n + 1)]
    tool_names = [plant.output_names[3 * n + k] for k in range(3)]
    table = step_input(tau_names, profile.t_switch, profile.tau_m)
    _say(progress, f"FMPy Co-Simulation over {horizon:g} s, communication step {step:g} s, and again at half "
                   f"the internal step (RK4's own error)")
    cs = simulate_cs(fmu_path, horizon, step, inputs=table, outputs=state_names + tool_names, start_values=start)
    cs_half = simulate_cs(fmu_path, horizon, step, inputs=table, outputs=state_names + tool_names,
                          start_values={**start, "internal_step": internal / 2})
    X_links = X_ref[:, :2 * n]  # q and qd of the links: the states compared (a drive train's own are not outputs)
    cs_err = tracking_error(f"Co-Simulation (RK4, h={step:g})", cs.t, cs.stack(state_names),
                            cs.stack(tool_names), t_ref, X_links, P_ref)
    rk4 = tracking_error("RK4 h vs h/2", cs.t, cs.stack(state_names), cs.stack(tool_names),
                         cs_half.t, cs_half.stack(state_names), cs_half.stack(tool_names))
    report.errors.append(cs_err)
    rk4_rel = max(v for v in (16 / 15 * rk4.q.max() / cs_err.q_scale, 16 / 15 * rk4.qd.max() / cs_err.qd_scale,
                              16 / 15 * rk4.tool_position / cs_err.p_scale))
    cs_bound = TOLERANCES["cs_richardson"] * rk4_rel + TOLERANCES["cs_floor"]
    report.checks += _tracking_checks(cs_err, "Co-Simulation", cs_bound,
                                      f"bound {TOLERANCES['cs_richardson']:g} x RK4's error estimate "
                                      f"{rk4_rel:.2e} + {TOLERANCES['cs_floor']:g}")
    _say(progress, "the plant's rule on the importer's communication steps: the FMU's Co-Simulation to rounding")
    X_same = plant_states(robot, cs.t, np.array([profile.at(float(tk)) for tk in cs.t[:-1]]), internal)
    P_same = np.array([np.asarray(plant.out(x, np.zeros(n), p_ref)).reshape(-1)[3 * n:3 * n + 3] for x in X_same])
    same_err = tracking_error(f"the plant's rule (h={internal:g})", cs.t, cs.stack(state_names), cs.stack(tool_names),
                              cs.t, X_same[:, :2 * n], P_same)
    report.errors.append(same_err)
    report.checks += _tracking_checks(same_err, "Co-Simulation = plant", TOLERANCES["plant"],
                                      "the same rule on the same plant: rounding only")
    _say(progress, f"FMPy Model Exchange with CVode, rtol {ME_RTOL:g}")
    me = simulate_me(fmu_path, horizon, step, inputs=table, outputs=state_names + tool_names,
                     start_values=start, relative_tolerance=ME_RTOL)
    me_err = tracking_error(f"Model Exchange (CVode {ME_RTOL:g})", me.t, me.stack(state_names),
                            me.stack(tool_names), t_ref, X_links, P_ref)
    report.errors.append(me_err)
    report.checks += _tracking_checks(me_err, "Model Exchange", TOLERANCES["me"],
                                      f"bound 1e3 x rtol {ME_RTOL:g} x gain {DIVERGENCE_GAIN:g}")

    from .simulate import fmi_version

    version = fmi_version(fmu_path)
    _say(progress, "FMU state get/set and serialisation round trips")
    if version == 3:
        from .validate3 import directional_derivative_error3, state_roundtrip3

        report.roundtrip = state_roundtrip3(fmu_path, profile.at, tau_names, state_names + tool_names, step=step)
    else:
        report.roundtrip = state_roundtrip(fmu_path, profile.at, tau_names, state_names + tool_names, step=step)
    r = report.roundtrip
    report.checks.append(Check("FMU state round trips", float(3 - sum((r.get_set_identical, r.deserialized_identical,
                                                                        r.me_identical))), 0.0,
                               "continuations that differ from the original run, bit for bit (of 3)"))
    _say(progress, "directional derivatives against finite differences")
    if version == 3:  # FMI 3.0 has the reverse mode too: it must be the transpose of the forward mode
        worst, count, adjoint = directional_derivative_error3(fmu_path)
        report.directional = (max(worst, adjoint), count)
        what = (f"max |AD - FD| / (1 + |FD|) over {count} entries ({worst:.2e}), and adjoint against forward "
                f"max |J_adj^T - J| / max |J| ({adjoint:.2e})")
    else:
        report.directional = directional_derivative_error(fmu_path)
        what = f"max |AD - FD| / (1 + |FD|) over {report.directional[1]} entries"
    report.checks.append(Check("directional derivatives", report.directional[0], TOLERANCES["directional"], what))

    if with_cosim and version == 3:
        report.cosim_skipped = "FMI 3.0: libcosim imports FMI 2.0 only"
        with_cosim = False
    if with_cosim:
        from .cosim import libcosim_unavailable, run_libcosim

        report.cosim_skipped = libcosim_unavailable()
    if with_cosim and report.cosim_skipped is None:
        _say(progress, "libcosim: two instances side by side")
        res = run_libcosim(fmu_path, stop_time=horizon, step=step, inputs=profile.at, input_names=tau_names,
                           output_names=state_names + tool_names, start_values=start)
        a, b = (res.values[k] for k in res.values)
        report.cosim_between_instances = float(np.max(np.abs(a - b)))
        fm = cs.stack(state_names + tool_names)
        idx = [int(round(tk / step)) for tk in res.t]
        report.cosim_vs_fmpy = float(np.max(np.abs(a - fm[idx])))
        scale = max(1.0, float(np.max(np.abs(fm))))
        report.checks.append(Check("libcosim instances", report.cosim_between_instances / scale, TOLERANCES["cosim"],
                                   f"max difference between two libcosim instances / {scale:.3g}"))
        report.checks.append(Check("libcosim vs FMPy", report.cosim_vs_fmpy / scale, TOLERANCES["cosim"],
                                   f"max difference between libcosim and FMPy Co-Simulation / {scale:.3g}"))
    return report


def _ls_ref_check(report: ValidationReport, fmu_path: str, progress: Progress | None) -> None:
    """Replay the FMU's FMI-LS-REF experiment (:mod:`fmu.ls_ref`) with FMPy; a malformed one is a failed check."""
    from .ls_ref import LS_REF_DIR, read_experiment, replay_problems

    try:
        exp = read_experiment(fmu_path)
    except InputError as exc:
        report.checks.append(Check("FMI-LS-REF replay", float("nan"), 1.0, f"unreadable experiment: {exc}"))
        return
    if exp is None:
        report.notes.append(f"no FMI-LS-REF experiment in {LS_REF_DIR}/: nothing to replay")
        return
    _say(progress, f"FMI-LS-REF: replaying the FMU's own experiment ({exp.stop_time:g} s) with FMPy")
    worst, problems = replay_problems(fmu_path, exp)
    what = "max |replay - reference| / tolerance over q and qd at every reference row"
    report.checks.append(Check("FMI-LS-REF replay", worst if not problems else float("nan"), 1.0,
                               what if not problems else f"{what}: {'; '.join(problems)}"))


def _internal_step(fmu_path: str) -> float:
    """The start value of the FMU's ``internal_step``, s."""
    from fmpy import read_model_description

    check_fmu_archive(fmu_path)
    md = read_model_description(fmu_path)
    return float(next(v.start for v in md.modelVariables if v.name == "internal_step"))
