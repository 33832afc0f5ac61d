"""The report's identification section: the demo's robot identified from a simulated excitation log.

:func:`identification_section` optimises a short excitation (:data:`DEMO_ITERATIONS` IPOPT iterations), logs
two periods of it at 1 kHz with the model's own inverse dynamics plus 1 % torque noise and 1e-5 rad encoder
noise (seeded), identifies the arm from positions and torques only, as ``manip identify`` does, and writes
that command's outputs under ``out/identify``. One call from the demo; a few seconds on the SCARA.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from .cmd_identify import write_identification
from .report import Report

__all__ = ["DEMO_ITERATIONS", "IDENTIFY_DIR", "identification_section"]

#: The section's folder in the report's folder.
IDENTIFY_DIR = "identify"
#: IPOPT iterations of the demo's excitation (a full `manip excite` runs up to 300).
DEMO_ITERATIONS = 40
#: The simulated log: torque noise (share of each joint's peak) and encoder noise (rad or m).
TORQUE_NOISE, ENCODER_NOISE = 0.01, 1e-5


def identification_section(report: Report, out: Path, robot, *, plots: bool = True,
                           note: Callable[[str], None] | None = None) -> list[Path]:
    """Identify ``robot`` (a :class:`model.Robot`) from a simulated log into ``out/identify``; add the section.

    The shape of the sections of :mod:`workbench.sections`. Returns the files written.
    """
    from model.identification import Regressor, base_parameters, optimise_excitation
    from model.identification.identify import identify_log
    from model.joint_table import JointTable, write_joint_table

    desc = robot.description
    folder = out / IDENTIFY_DIR
    folder.mkdir(parents=True, exist_ok=True)
    reg = Regressor(desc)
    base = base_parameters(reg)
    exc = optimise_excitation(robot, max_iter=DEMO_ITERATIONS, regressor=reg, base=base)
    t, q, qd, qdd = exc.trajectory.sample(1000.0, periods=2)
    rng = np.random.default_rng(0)
    tau = robot.rne_batch(q, qd, qdd)
    tau = tau + TORQUE_NOISE * np.abs(tau).max(axis=0) * rng.standard_normal(tau.shape)
    q_log = q + ENCODER_NOISE * rng.standard_normal(q.shape)
    files = [write_joint_table(folder / "excite.csv", t, {"q": q, "qd": qd, "qdd": qdd}, desc.joint_names),
             write_joint_table(folder / "log.csv", t, {"q": q_log, "tau": tau}, desc.joint_names)]
    table = JointTable(t=t, groups={"q": q_log, "tau": tau}, joint_names=desc.joint_names)
    result = identify_log(robot, table, regressor=reg, base=base)
    files += write_identification(result, desc, folder, "log.csv", "log.csv", plots=plots)
    pre = result.preprocessing
    report.heading("Identification")
    report.text(f"An excitation for the {base.n_base} base parameters (`manip excite`: {exc.trajectory.harmonics} "
                f"harmonics per joint, period {exc.trajectory.period:g} s, condition number "
                f"{exc.initial_condition_number:.3g} -> {exc.condition_number:.3g} in {DEMO_ITERATIONS} IPOPT "
                f"iterations), logged for two periods at 1 kHz with the model's inverse dynamics, "
                f"{100 * TORQUE_NOISE:g} % torque noise and {ENCODER_NOISE:g} rad encoder noise, then identified "
                f"from positions and torques alone (`manip identify {desc.name} log.csv`): cut-off "
                f"{pre.cutoff_hz:.3g} Hz from the position spectrum, {len(result.fit)} samples fitted, "
                f"{len(result.holdout)} held out, condition number {result.condition_number:.3g}.")
    report.table(["fit", "relative error", "held out", "held-out RMS per joint"],
                 [[m, e.relative_error, e.relative_error_holdout, ", ".join(f"{v:.3g}" for v in e.rms_holdout)]
                  for m, e in result.errors.items()])
    report.text(f"`{IDENTIFY_DIR}/identified.toml` (the {result.chosen} fit: every link's pseudo-inertia positive "
                f"semi-definite) is a robot file every command takes; `{IDENTIFY_DIR}/identification.json` has the "
                "base parameters with their standard deviations.")
    if plots:
        from .identify_plots import excitation_plot
        from .outputs import save_figure

        revolute = [lk.is_revolute for lk in desc.links]
        files.append(save_figure(excitation_plot(exc, desc.joint_names, revolute), folder / "excite.png"))
        report.figures([(f"{IDENTIFY_DIR}/{name}.png", caption) for name, caption in (
            ("excite", "the excitation against its limits"),
            ("holdout_torques", "measured and predicted torque on the held-out data"),
            ("residual_spectrum", "spectrum of the torque residual"))])
    if note is not None:
        note(f"{base.n_base} base parameters; held-out relative error {result.errors[result.chosen].relative_error_holdout:.3g}")
    return files
