"""The specification of a parameter sweep: what is simulated, what varies, and the cases it makes.

A spec is a TOML file (or the same keys as a dict)::

    robot = "scara"                 # built-in name or robot file
    controller = "ct"               # pd, pd-g, pd-ff, pid, ct, or cascade (the robot file's P-PI cascade)
    bandwidth = 50.0                # rad/s (optional, as `manip track`)
    damping = 0.7                   # (optional)
    rate_hz = 1000.0                # Hz (optional)
    saturate = true                 # clip torques at the design's limits (optional)
    delay = false                   # torques one control period late (optional)
    task = "pick-and-place"         # or waypoints = "file.csv" with segment_time = 2.0
    samples = 1000                  # cases ("grid": points per axis)
    seed = 1
    method = "random"               # "grid", "random" (i.i.d. uniform) or "sobol" (scrambled, scipy.stats.qmc)
    bound = 0.01                    # max_error bound of the summary's exceedance probability (optional)
    batch = 0                       # cases per task (optional; 0: chosen from N and the workers)
    [vary]                          # each quantity: [low, high], uniform
    payload_mass = [0.0, 3.0]

Relative ``robot`` (a ``.toml``/``.urdf`` file) and ``waypoints`` paths are read from the spec's folder.

The varied quantities (:data:`QUANTITIES`): ``payload_mass`` (kg), ``payload_com_x``,
``_y``, ``_z`` (m, last link frame), ``friction_scale`` (every joint's viscous and
Coulomb friction times this) or ``friction_scale_J`` (joint J only, 1-based),
``link_mass_scale``, ``bandwidth`` (rad/s, a design per case), ``damping``,
``rate_hz`` (Hz, the schedule's periods) and ``delay`` (0 or 1 control period: a grid
takes both, a sample rounds). Plant quantities are unknown to the controller.

``controller = "cascade"`` is the robot file's motor-side P-PI cascade (its ``[cascade]``
table: gains and rate, :mod:`control_design.cascade`) on a robot with drive trains (elastic
gears, current loops, friction peaks: the compiled closed loop carries their states); its
gains are the file's, so ``bandwidth`` and ``damping`` (fixed or varied) are refused, and
``rate_hz`` defaults to the table's ``rate``.

Random cases are seeded per case (case i draws from ``SeedSequence([seed, i])``), so
a case's values do not depend on N or on who computes it; Sobol and grid designs are
computed whole from (N, seed). Every violation (unknown key or quantity, empty range,
N = 0, more than :data:`~model.limits.MAX_SWEEP_CASES` cases, a file beyond
:data:`~model.limits.MAX_SPEC_BYTES`) is a :class:`SweepSpecError` naming the file
and the key, raised before any work.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from model.errors import InputError
from model.limits import MAX_SPEC_BYTES, MAX_SWEEP_CASES, load_toml

__all__ = ["METHODS", "QUANTITIES", "SweepSpec", "SweepSpecError", "case_values", "check_joints", "load_spec",
           "spec_from_dict"]

#: Sampling methods.
METHODS: tuple[str, ...] = ("grid", "random", "sobol")
#: Varied quantities: name -> (unit, lowest allowed value, strictly above it?).
QUANTITIES: dict[str, tuple[str, float, bool]] = {
    "payload_mass": ("kg", 0.0, False),
    "payload_com_x": ("m", -math.inf, False),
    "payload_com_y": ("m", -math.inf, False),
    "payload_com_z": ("m", -math.inf, False),
    "friction_scale": ("", 0.0, False),
    "link_mass_scale": ("", 0.0, True),
    "bandwidth": ("rad/s", 0.0, True),
    "damping": ("", 0.0, True),
    "rate_hz": ("Hz", 0.0, True),
    "delay": ("periods", 0.0, False),
}
_KEYS = ("robot", "controller", "bandwidth", "damping", "rate_hz", "saturate", "delay", "task", "waypoints",
         "segment_time", "samples", "seed", "method", "bound", "batch", "vary")


class SweepSpecError(InputError):
    """A sweep spec that cannot run: the message names the file (or ``spec``) and the key."""


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep (see the module docstring for the keys, units and defaults).

    ``vary`` maps each varied quantity to its ``(low, high)``, in the file's order; ``source`` names the file.
    """

    robot: str
    controller: str
    vary: dict[str, tuple[float, float]]
    samples: int
    seed: int = 0
    method: str = "random"
    bandwidth: float | None = None
    damping: float | None = None
    rate_hz: float | None = None
    saturate: bool = True
    delay: bool = False
    task: str | None = None
    waypoints: str | None = None
    segment_time: float | None = None
    bound: float | None = None
    batch: int = 0
    source: str = field(default="spec", compare=False)

    @property
    def quantities(self) -> tuple[str, ...]:
        """Relative ``robot`` (a ``.toml``/``.urdf`` file) and ``waypoints`` paths are read from the spec's folder.

The varied quantities, in column order."""
        return tuple(self.vary)

    @property
    def n_cases(self) -> int:
        """Number of cases: ``samples``, or ``samples ** d`` for a grid (``delay`` takes 2 grid points)."""
        if self.method != "grid":
            return self.samples
        return math.prod(2 if q == "delay" else self.samples for q in self.vary)

    def digest(self) -> str:
        """SHA-256 of everything that sets the cases and their results (a resumed sweep must match it)."""
        data = {k: v for k, v in asdict(self).items() if k not in ("source", "batch")}
        return hashlib.sha256(json.dumps(data, sort_keys=True, default=list).encode()).hexdigest()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready keys (the spec file's)."""
        data = {k: v for k, v in asdict(self).items() if k != "source" and v is not None}
        data["vary"] = {k: list(v) for k, v in self.vary.items()}
        return data


def _quantity_ok(name: str, n_joints: int | None) -> bool:
    if name in QUANTITIES:
        return True
    if name.startswith("friction_scale_"):
        tail = name[len("friction_scale_"):]
        return tail.isdigit() and int(tail) >= 1 and (n_joints is None or int(tail) <= n_joints)
    return False


def _bounds(name: str) -> tuple[str, float, bool]:
    return QUANTITIES.get(name, QUANTITIES["friction_scale"])


def spec_from_dict(data: Mapping[str, Any], source: str = "spec", n_joints: int | None = None) -> SweepSpec:
    """Validate the keys of a spec (as parsed from TOML) into a :class:`SweepSpec`.

    ``n_joints`` (if known) bounds ``friction_scale_J``. Raises :class:`SweepSpecError` naming ``source`` and the key.
    """
    def fail(key: str, message: str) -> SweepSpecError:
        return SweepSpecError(f"{source}: {key}: {message}")

    if not isinstance(data, Mapping):
        raise SweepSpecError(f"{source}: expected a table of keys, got {type(data).__name__}")
    unknown = [k for k in data if k not in _KEYS]
    if unknown:
        raise fail(unknown[0], f"unknown key; expected one of {', '.join(_KEYS)}")

    def text(key: str, default: str | None = None) -> str | None:
        v = data.get(key, default)
        if v is not None and not isinstance(v, str):
            raise fail(key, f"expected a string, got {v!r}")
        return v

    def number(key: str, default: float | None = None, positive: bool = True) -> float | None:
        v = data.get(key, default)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0):
            raise fail(key, f"expected a {'positive ' if positive else ''}finite number, got {v!r}")
        return float(v)

    def integer(key: str, default: int | None, low: int) -> int:
        v = data.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise fail(key, f"expected a whole number >= {low}, got {v!r}")
        return int(v)

    def flag(key: str) -> bool:
        v = data.get(key, False)
        if not isinstance(v, bool):
            raise fail(key, f"expected true or false, got {v!r}")
        return v

    robot = text("robot")
    if not robot:
        raise fail("robot", "missing: name a built-in robot or a robot file")
    controller = text("controller", "pd")
    from control_design.laws import LAW_KINDS

    if controller not in (*LAW_KINDS, "cascade"):
        raise fail("controller", f"expected one of {', '.join(LAW_KINDS)}, cascade, got {controller!r}")
    if controller == "cascade":
        for key in ("bandwidth", "damping"):
            if key in data or key in (data.get("vary") or {}):
                raise fail(key if key in data else f"vary.{key}",
                           "the cascade's gains are the robot file's [cascade] table: no design to vary")
    method = text("method", "random")
    if method not in METHODS:
        raise fail("method", f"expected one of {', '.join(METHODS)}, got {method!r}")
    if "samples" not in data:
        raise fail("samples", "missing: the number of cases (points per axis for a grid)")
    samples = integer("samples", None, 1)
    task, waypoints = text("task"), text("waypoints")
    if task is not None and waypoints is not None:
        raise fail("waypoints", "give either task or waypoints, not both")
    vary_in = data.get("vary")
    if not isinstance(vary_in, Mapping) or not vary_in:
        raise fail("vary", "expected a table of at least one quantity = [low, high]")
    vary: dict[str, tuple[float, float]] = {}
    for name, rng in vary_in.items():
        key = f"vary.{name}"
        if not _quantity_ok(name, n_joints):
            raise fail(key, f"unknown quantity; expected one of {', '.join(QUANTITIES)} or friction_scale_J "
                            f"(J = 1..{n_joints if n_joints else 'n'})")
        if (not isinstance(rng, list) or len(rng) != 2
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in rng)):
            raise fail(key, f"expected [low, high] (two finite numbers), got {rng!r}")
        low, high = float(rng[0]), float(rng[1])
        if not low < high:
            raise fail(key, f"empty range [{low:g}, {high:g}]: expected low < high")
        unit, floor, strict = _bounds(name)
        if low < floor or (strict and low == floor):
            raise fail(key, f"expected values {'>' if strict else '>='} {floor:g} {unit}".rstrip() + f", got low = {low:g}")
        if name == "delay" and (low != 0.0 or high != 1.0):
            raise fail(key, f"expected [0, 1] (no delay or one control period), got {rng!r}")
        vary[name] = (low, high)
    if "friction_scale" in vary and any(q.startswith("friction_scale_") for q in vary):
        raise fail("vary.friction_scale", "give friction_scale or friction_scale_J per joint, not both")
    spec = SweepSpec(
        robot=robot, controller=controller, vary=vary, samples=samples, seed=integer("seed", 0, 0), method=method,
        bandwidth=number("bandwidth"), damping=number("damping"), rate_hz=number("rate_hz"),
        saturate=flag("saturate") if "saturate" in data else True, delay=flag("delay"), task=task,
        waypoints=waypoints, segment_time=number("segment_time"), bound=number("bound"),
        batch=integer("batch", 0, 0), source=source,
    )
    if spec.delay and "delay" in vary:
        raise fail("delay", "delay = true and a varied delay: give one")
    n = spec.n_cases
    if n > MAX_SWEEP_CASES:
        axes = " x ".join(str(2 if q == "delay" else samples) for q in vary)
        raise fail("samples", f"{n:,} cases ({axes}) exceed the sweep limit of {MAX_SWEEP_CASES:,} cases")
    return spec


def load_spec(path: str | Path, n_joints: int | None = None) -> SweepSpec:
    """Read and validate a sweep spec file (TOML, at most :data:`~model.limits.MAX_SPEC_BYTES`); nothing is executed.

    A relative ``waypoints`` path is taken relative to the spec file's folder.
    """
    path = Path(path)
    data = load_toml(path, "sweep spec", SweepSpecError, MAX_SPEC_BYTES)
    spec = spec_from_dict(data, str(path), n_joints)
    changes = {}
    if spec.waypoints is not None and not Path(spec.waypoints).is_absolute():
        changes["waypoints"] = str(path.parent / spec.waypoints)
    if spec.robot.endswith((".toml", ".urdf")) and not Path(spec.robot).is_absolute():
        changes["robot"] = str(path.parent / spec.robot)
    return replace(spec, **changes) if changes else spec


def check_joints(spec: SweepSpec, n_joints: int) -> None:
    """Refuse a ``friction_scale_J`` beyond the robot's ``n_joints`` (:class:`SweepSpecError`)."""
    for q in spec.vary:
        if q.startswith("friction_scale_") and int(q[len("friction_scale_"):]) > n_joints:
            raise SweepSpecError(f"{spec.source}: vary.{q}: the robot {spec.robot!r} has {n_joints} joints")


def case_values(spec: SweepSpec, cases: np.ndarray | None = None) -> np.ndarray:
    """(len(cases), d) values of the varied quantities of ``cases`` (default all, 0..N-1), in column order.

    ``random``: case i is ``low + (high - low) u`` with u from ``default_rng(SeedSequence([seed, i]))``;
    ``sobol``: the first N points of a scrambled Sobol' design of ``2^ceil(log2 N)`` points seeded by ``seed``
    (balanced when N is a power of two); ``grid``: every combination of
    ``samples`` evenly spaced values per axis (the last quantity fastest). ``delay`` is rounded to 0 or 1.
    """
    N, d = spec.n_cases, len(spec.vary)
    idx = np.arange(N) if cases is None else np.asarray(cases, dtype=np.int64)
    lows = np.array([lo for lo, _ in spec.vary.values()])
    highs = np.array([hi for _, hi in spec.vary.values()])
    if spec.method == "grid":
        axes = [np.array([0.0, 1.0]) if q == "delay" else np.linspace(lo, hi, spec.samples)
                for q, (lo, hi) in spec.vary.items()]
        shape = [a.size for a in axes]
        sub = np.unravel_index(idx, shape)
        values = np.column_stack([a[s] for a, s in zip(axes, sub)])
    else:
        if spec.method == "random":
            u = np.array([np.random.default_rng(np.random.SeedSequence([spec.seed, int(i)])).random(d) for i in idx])
        else:
            u = _sobol_design(d, spec.seed, max(0, math.ceil(math.log2(N))))[:N][idx]
        values = lows + (highs - lows) * u.reshape(len(idx), d)
    for j, q in enumerate(spec.vary):
        if q == "delay":
            values[:, j] = np.where(values[:, j] >= 0.5, 1.0, 0.0)
    return values.reshape(len(idx), d)


@lru_cache(maxsize=4)
def _sobol_design(d: int, seed: int, m: int) -> np.ndarray:
    """The scrambled Sobol points (2**m, d) in [0, 1) of ``seed``, made once per process (every task reads it)."""
    from scipy.stats import qmc

    u = qmc.Sobol(d, scramble=True, seed=seed).random_base2(m)
    u.flags.writeable = False
    return u
