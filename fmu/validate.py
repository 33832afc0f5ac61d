"""Validate an exported FMU: description, binary, simulations against the Python model.

:func:`validate_fmu` runs every check and returns a :class:`fmu.report.ValidationReport`:

* what the FMU is without running it (:mod:`fmu.inspection`): FMPy's validation of ``modelDescription.xml``,
  its binaries (this machine's: FMI functions only, libc and libm only; the other platforms' structurally);
* the FMU's own FMI-LS-REF experiment replayed with FMPy (:mod:`fmu.ls_ref`);
* Co-Simulation and Model Exchange (CVode) runs by FMPy against the one plant (:mod:`fmu.reference`, the
  robot read back from the FMU) advanced by its fixed-step rule at an eighth of the FMU's internal step, on
  the computed-torque feed-forward of the robot's task (open loop, so over a short horizon where the
  comparison is meaningful): Co-Simulation within ten times RK4's own error estimate, Model Exchange within
  its tolerance, and Co-Simulation against the same rule at the FMU's own step to rounding (the FMU is the
  plant);
* FMU state round trips and directional (FMI 3.0: and adjoint) derivatives (:mod:`fmu.numeric_checks`, one
  implementation for both FMI versions, so the list of checks is the same for both);
* libcosim, the second importer (FMI 2.0 only: skipped for an FMI 3.0 FMU): two instances side by side,
  against FMPy.

Every check runs in its own guard: one that raises (a refused FMI call, a run that cannot be read) is a
failed check with the exception's message, under its usual name, and the others still run.

The archive is checked (:func:`fmu.archive.check_fmu_archive`: limits, paths, links, zip bombs) before
anything else: a hostile archive is refused before anything is extracted or loaded. The checks after it
load and run the FMU's binary: validate only FMUs whose binary you would run.
"""

from __future__ import annotations

import math
import os
from typing import Any, Callable, Sequence

import numpy as np

from model.errors import InputError
from model.limits import MAX_SAMPLES

from .archive import check_fmu_archive
from .inspection import binary_problems, internal_step, model_description_problems
from .numeric_checks import (ME_RTOL, TOLERANCES, TRACKED, RoundTrip, TrackingError, directional_derivative_error,
                             state_roundtrip, tracking_checks, tracking_error)
from .opened import open_fmu
from .reference import (DIVERGENCE_GAIN, REFERENCE_REFINEMENT, TorqueProfile, divergence_horizon,
                        feedforward_profile, plant_states, reference_response, start_state)
from .report import Check, ValidationReport, failed_check
from .robot_resource import RobotNotReloadableError, fmu_robot, reload_fmu_robot

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
    "model_description_problems",
    "binary_problems",
    "tracking_error",
    "state_roundtrip",
    "directional_derivative_error",
    "validate_fmu",
]

Progress = Callable[[str], None]


def _say(progress: Progress | None, message: str) -> None:
    if progress is not None:
        progress(message)


def _guarded(report: ValidationReport, names: Sequence[str], run: Callable[[], list[Check]]) -> None:
    """Append the checks ``run`` gives, which are named ``names``; if it raises, ``names`` all fail with its message."""
    try:
        checks = run()
    except Exception as exc:  # noqa: BLE001 - any failure of one check is reported, and the others still run
        report.checks += [failed_check(name, exc) for name in names]
        return
    report.checks += checks


def _not_run(what: str, exc: Exception) -> str:
    return f"{what}: not run to the end: {type(exc).__name__}: {' '.join(str(exc).split())}"


def _tracked(kind: str) -> list[str]:
    return [f"{kind} {figure}" for figure in TRACKED]


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
    report = ValidationReport(fmu_path, [], [], {})
    try:
        report.description_problems += model_description_problems(fmu_path)
    except Exception as exc:  # noqa: BLE001 - reported, and the other checks still run
        report.description_problems.append(_not_run("FMPy validation", exc))
    try:
        found, report.binary_facts = binary_problems(fmu_path)
        report.binary_problems += found
    except Exception as exc:  # noqa: BLE001 - reported, and the other checks still run
        report.binary_problems.append(_not_run("binary check", exc))
    try:
        _ls_ref_check(report, fmu_path, progress)
    except Exception as exc:  # noqa: BLE001 - a failed check, and the other checks still run
        report.checks.append(failed_check("FMI-LS-REF replay", exc))
    try:
        report.robot = fmu_robot(fmu_path)
    except Exception as exc:  # noqa: BLE001 - reported as a problem of the description
        report.description_problems.append(_not_run("the robot recorded in the description", exc))
        return report
    if report.robot is None:
        return report
    try:
        robot = reload_fmu_robot(fmu_path)
    except RobotNotReloadableError as exc:
        report.robot_skipped = f"robot not reloadable: {exc}"
        return report
    except Exception as exc:  # noqa: BLE001 - a resource that does not read back is reported, not raised
        report.robot_skipped = _not_run("robot not read back from the FMU", exc)
        return report
    _numeric_checks(report, robot, fmu_path, t_end, step, with_cosim, progress)
    return report


def _numeric_checks(report: ValidationReport, robot: Any, fmu_path: str, t_end: float, step: float,
                    with_cosim: bool, progress: Progress | None) -> None:
    """The comparisons with the Python model, the FMU-state and derivative checks and libcosim, each guarded."""
    from model.plant import build_plant

    from .simulate import fmi_version, simulate_cs, simulate_me, step_input

    n = robot.n
    tau_names = [f"tau_m[{i}]" for i in range(1, n + 1)]
    state_names = [f"q[{i}]" for i in range(1, n + 1)] + [f"qd[{i}]" for i in range(1, n + 1)]
    tracked = _tracked("Co-Simulation") + _tracked("Co-Simulation = plant") + _tracked("Model Exchange")
    try:
        with open_fmu(fmu_path, validate=False) as fmu:
            version = fmu.fmi_version
            internal = internal_step(fmu)
        plant = build_plant(robot)
        p_ref = np.array(plant.param_defaults, dtype=float)
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
        tool_names = [plant.output_names[3 * n + k] for k in range(3)]
    except Exception as exc:  # noqa: BLE001 - without a reference the comparisons fail; the derivatives still run
        report.checks += [failed_check(name, exc) for name in tracked + ["FMU state round trips"]]
        _guarded(report, ["directional derivatives"], lambda: [_directional_check(fmu_path, progress, report)])
        _cosim_skipped(report, fmi_version(fmu_path), with_cosim, reason=_not_run("the reference", exc))
        return

    table = step_input(tau_names, profile.t_switch, profile.tau_m)
    outputs = state_names + tool_names
    X_links = X_ref[:, :2 * n]  # q and qd of the links: the states compared (a drive train's own are not outputs)
    runs: dict[str, Any] = {}

    def co_simulation() -> list[Check]:
        _say(progress, f"FMPy Co-Simulation over {horizon:g} s, communication step {step:g} s, and again at half "
                       f"the internal step (RK4's own error)")
        runs["cs"] = cs = simulate_cs(fmu_path, horizon, step, inputs=table, outputs=outputs, start_values={})
        cs_half = simulate_cs(fmu_path, horizon, step, inputs=table, outputs=outputs,
                              start_values={"internal_step": internal / 2})
        cs_err = tracking_error(f"Co-Simulation (RK4, h={step:g})", cs.t, cs.stack(state_names),
                                cs.stack(tool_names), t_ref, X_links, P_ref)
        rk4 = tracking_error("RK4 h vs h/2", cs.t, cs.stack(state_names), cs.stack(tool_names),
                             cs_half.t, cs_half.stack(state_names), cs_half.stack(tool_names))
        report.errors.append(cs_err)
        rk4_rel = max(v for v in (16 / 15 * rk4.q.max() / cs_err.q_scale, 16 / 15 * rk4.qd.max() / cs_err.qd_scale,
                                  16 / 15 * rk4.tool_position / cs_err.p_scale))
        cs_bound = TOLERANCES["cs_richardson"] * rk4_rel + TOLERANCES["cs_floor"]
        return tracking_checks(cs_err, "Co-Simulation", cs_bound,
                               f"bound {TOLERANCES['cs_richardson']:g} x RK4's error estimate "
                               f"{rk4_rel:.2e} + {TOLERANCES['cs_floor']:g}")

    def same_rule() -> list[Check]:
        cs = runs.get("cs") or simulate_cs(fmu_path, horizon, step, inputs=table, outputs=outputs, start_values={})
        _say(progress, "the plant's rule on the importer's communication steps: the FMU's Co-Simulation to rounding")
        X_same = plant_states(robot, cs.t, np.array([profile.at(float(tk)) for tk in cs.t[:-1]]), internal)
        P_same = np.array([np.asarray(plant.out(x, np.zeros(n), p_ref)).reshape(-1)[3 * n:3 * n + 3] for x in X_same])
        same_err = tracking_error(f"the plant's rule (h={internal:g})", cs.t, cs.stack(state_names),
                                  cs.stack(tool_names), cs.t, X_same[:, :2 * n], P_same)
        report.errors.append(same_err)
        return tracking_checks(same_err, "Co-Simulation = plant", TOLERANCES["plant"],
                               "the same rule on the same plant: rounding only")

    def model_exchange() -> list[Check]:
        _say(progress, f"FMPy Model Exchange with CVode, rtol {ME_RTOL:g}")
        me = simulate_me(fmu_path, horizon, step, inputs=table, outputs=outputs, start_values={},
                         relative_tolerance=ME_RTOL)
        me_err = tracking_error(f"Model Exchange (CVode {ME_RTOL:g})", me.t, me.stack(state_names),
                                me.stack(tool_names), t_ref, X_links, P_ref)
        report.errors.append(me_err)
        return tracking_checks(me_err, "Model Exchange", TOLERANCES["me"],
                               f"bound 1e3 x rtol {ME_RTOL:g} x gain {DIVERGENCE_GAIN:g}")

    def round_trips() -> list[Check]:
        _say(progress, "FMU state get/set and serialisation round trips")
        r = report.roundtrip = state_roundtrip(fmu_path, profile.at, tau_names, outputs, step=step)
        return [Check("FMU state round trips", float(3 - sum((r.get_set_identical, r.deserialized_identical,
                                                              r.me_identical))), 0.0,
                      "continuations that differ from the original run, bit for bit (of 3)")]

    _guarded(report, _tracked("Co-Simulation"), co_simulation)
    _guarded(report, _tracked("Co-Simulation = plant"), same_rule)
    _guarded(report, _tracked("Model Exchange"), model_exchange)
    _guarded(report, ["FMU state round trips"], round_trips)
    _guarded(report, ["directional derivatives"], lambda: [_directional_check(fmu_path, progress, report)])
    if _cosim_skipped(report, version, with_cosim):
        return

    def libcosim() -> list[Check]:
        from .cosim import run_libcosim

        _say(progress, "libcosim: two instances side by side")
        res = run_libcosim(fmu_path, stop_time=horizon, step=step, inputs=profile.at, input_names=tau_names,
                           output_names=outputs, start_values={})
        a, b = (res.values[k] for k in res.values)
        report.cosim_between_instances = float(np.max(np.abs(a - b)))
        cs = runs.get("cs") or simulate_cs(fmu_path, horizon, step, inputs=table, outputs=outputs, start_values={})
        fm = cs.stack(outputs)
        idx = [int(round(tk / step)) for tk in res.t]
        report.cosim_vs_fmpy = float(np.max(np.abs(a - fm[idx])))
        scale = max(1.0, float(np.max(np.abs(fm))))
        return [Check("libcosim instances", report.cosim_between_instances / scale, TOLERANCES["cosim"],
                      f"max difference between two libcosim instances / {scale:.3g}"),
                Check("libcosim vs FMPy", report.cosim_vs_fmpy / scale, TOLERANCES["cosim"],
                      f"max difference between libcosim and FMPy Co-Simulation / {scale:.3g}")]

    _guarded(report, ["libcosim instances", "libcosim vs FMPy"], libcosim)


def _directional_check(fmu_path: str, progress: Progress | None, report: ValidationReport | None = None) -> Check:
    """The directional derivatives (FMI 3.0: and the adjoint against them) as one check."""
    _say(progress, "directional derivatives against finite differences")
    worst, count, adjoint = directional_derivative_error(fmu_path)
    if adjoint is None:
        figure, what = worst, f"max |AD - FD| / (1 + |FD|) over {count} entries"
    else:  # the reverse mode must be the transpose of the forward mode
        figure = max(worst, adjoint)
        what = (f"max |AD - FD| / (1 + |FD|) over {count} entries ({worst:.2e}), and adjoint against forward "
                f"max |J_adj^T - J| / max |J| ({adjoint:.2e})")
    if report is not None:
        report.directional = (figure, count)
    return Check("directional derivatives", figure, TOLERANCES["directional"], what)


def _cosim_skipped(report: ValidationReport, version: int, with_cosim: bool, reason: str | None = None) -> bool:
    """Record why the libcosim check does not run (FMI 3.0, libcosim missing, ``reason``); True when it does not."""
    if not with_cosim:
        return True
    if version == 3:
        report.cosim_skipped = "FMI 3.0: libcosim imports FMI 2.0 only"
    elif reason is not None:
        report.cosim_skipped = reason
    else:
        from .cosim import libcosim_unavailable

        report.cosim_skipped = libcosim_unavailable()
    return report.cosim_skipped is not None


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
