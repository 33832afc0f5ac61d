"""What ``validate-fmu`` found and how it is printed: :class:`Check` (one figure against its bound) and
:class:`ValidationReport` (every finding of :func:`fmu.validate.validate_fmu`, :meth:`ValidationReport.format`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .reference import DIVERGENCE_GAIN


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


@dataclass(frozen=True)
class RoundTrip:
    """FMU-state round trips of a Co-Simulation run (bit-for-bit comparisons)."""

    steps_before: int
    steps_after: int
    serialized_size: int
    get_set_identical: bool
    deserialized_identical: bool
    me_identical: bool

    @property
    def ok(self) -> bool:
        return self.get_set_identical and self.deserialized_identical and self.me_identical


__all__ = ["Check", "ValidationReport", "failed_check"]


@dataclass(frozen=True)
class Check:
    """One acceptance check: a figure, its bound and what the figure is."""

    name: str
    value: float
    bound: float
    what: str
    error: str | None = None   # the exception that stopped the check (then it failed without a figure)

    @property
    def passed(self) -> bool:
        return self.error is None and bool(self.value <= self.bound)   # NaN fails

    def line(self) -> str:
        if self.error is not None:
            return f"FAIL {self.name}: not run to the end: {self.error}"
        verdict = "ok  " if self.passed else "FAIL"
        relation = "<=" if self.passed else ">"
        return f"{verdict} {self.name}: {self.what} = {self.value:.3e} {relation} bound {self.bound:.3e}"


def failed_check(name: str, exc: BaseException, bound: float = float("nan")) -> Check:
    """The failed :class:`Check` ``name`` for a check that raised ``exc`` (its type and one-line message)."""
    message = " ".join(str(exc).split()) or type(exc).__name__
    return Check(name, float("nan"), bound, "not run", error=f"{type(exc).__name__}: {message}")


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
