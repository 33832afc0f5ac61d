"""Dymola's result for the Modelica Standard Library's RobotR3.fullRobot, and the checks of issue 23 against it.

``model/robots/manutec_r3_dymola.csv`` (the robot file's ``[cascade] reference``): the FMI cross-check reference
``fullRobot_ref.csv`` (Dymola 2019 FD01, FMI 2.0 CS, ``axisN_w`` = link-side joint speed of axis N, rad/s,
t = 0..1 s; event rows repeat their time stamp), verbatim. Provenance: ``model/robots/URDF-SOURCES.md``.
Nothing here is written from the workbench's model.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

REFERENCE = Path(__file__).resolve().parents[2] / "model" / "robots" / "manutec_r3_dymola.csv"
#: Friction events of the reference, s: the rows with repeated time stamps before 0.1 s (break-aways of the
#: rotors of axes 2, 1, 3 and of the joints 5, 4, 6).
EVENTS = (0.00062883215, 0.00074867799, 0.00154548709, 0.00196265918, 0.00436115405, 0.00466740318)
#: Rotor break-aways (axes 1, 2, 3) of the MSL regression result (README of the data, section 1), s.
ROTOR_BREAKAWAY = (0.00074867799, 0.00062883215, 0.00154548709)


def reference() -> np.ndarray:
    """The reference as a structured array (``time``, ``axis1_w`` .. ``axis6_w``)."""
    return np.genfromtxt(REFERENCE, delimiter=",", names=True)


def reference_speeds() -> tuple[np.ndarray, np.ndarray]:
    """``(t, W)``: reference times (s, with the event rows) and the (N, 6) link-side speeds, rad/s."""
    ref = reference()
    return ref["time"], np.column_stack([ref[f"axis{i}_w"] for i in range(1, 7)])


def link_breakaways() -> np.ndarray:
    """(6,) the reference's last time each axis's speed is exactly 0, s (nan for axes 1-3, never exactly 0)."""
    t, W = reference_speeds()
    out = np.full(6, np.nan)
    for j in range(3, 6):
        out[j] = t[np.flatnonzero(W[:, j] == 0.0).max()]
    return out


@dataclass(frozen=True)
class Comparison:
    """A run's link-side speeds against the reference.

    Attributes
    ----------
    worst
        (6,) largest |speed - reference| over the reference times outside +-2 ms of an event, as a fraction of
        that axis's range (max - min of the reference).
    breakaway
        (6,) for axes 4-6: the first time the run's speed is not 0 minus the reference's last 0, s (nan for 1-3).
    """

    worst: np.ndarray
    breakaway: np.ndarray


def compare(t: np.ndarray, qd: np.ndarray) -> Comparison:
    """Compare a run (times ``t``, s; (N, 6) link-side speeds ``qd``, rad/s, sampled at least every 0.1 ms)."""
    t_ref, W = reference_speeds()
    span = W.max(axis=0) - W.min(axis=0)
    keep = np.ones(t_ref.size, dtype=bool)
    for e in EVENTS:
        keep &= np.abs(t_ref - e) > 2e-3
    keep &= t_ref <= t[-1]
    sim = np.column_stack([np.interp(t_ref[keep], t, qd[:, j]) for j in range(6)])
    worst = np.abs(sim - W[keep]).max(axis=0) / span
    ref_break = link_breakaways()
    breakaway = np.full(6, np.nan)
    for j in range(3, 6):
        breakaway[j] = t[np.flatnonzero(qd[:, j] != 0.0)[0]] - ref_break[j]
    return Comparison(worst=worst, breakaway=breakaway)


def as_result(t: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """A run as the structured array ``fmpy.cross_check.validate_result`` takes (columns named as the reference)."""
    dtype = [("time", float)] + [(f"axis{i}_w", float) for i in range(1, 7)]
    out = np.zeros(t.size, dtype=dtype)
    out["time"] = t
    for i in range(6):
        out[f"axis{i + 1}_w"] = qd[:, i]
    return out
