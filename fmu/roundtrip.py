"""FMU-state round trips written once for FMI 2.0 and 3.0 (:mod:`fmu.validate`, :mod:`fmu.validate3`).

The two versions spell the same calls differently (``fmi2GetFMUstate`` / ``fmi3GetFMUState``, ...);
:class:`StateCalls` names them once per instance, and the procedures below use only those names.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

__all__ = ["StateCalls", "cs_roundtrip", "me_roundtrip"]


@dataclass(frozen=True)
class StateCalls:
    """One instance's FMU-state calls (and, for Model Exchange, its continuous-state calls)."""

    get_state: Callable[[], Any]
    set_state: Callable[[Any], None]
    serialize: Callable[[Any], bytes]
    deserialize: Callable[[bytes], Any]
    free_state: Callable[[Any], None]
    end: Callable[[], None]  # terminate and free the instance
    get_x: Callable[[], np.ndarray] | None = None
    set_x: Callable[[np.ndarray], None] | None = None
    dx: Callable[[], np.ndarray] | None = None


def cs_roundtrip(new: Callable[[str], tuple[Any, StateCalls]], run: Callable[[Any, int, int], np.ndarray],
                 steps_before: int, steps_after: int) -> tuple[bool, bool, int]:
    """Run ``steps_before`` steps, save the state, run on; restore and run again; deserialise the saved state in
    a second instance and run again. ``new(name)`` gives an initialised Co-Simulation instance and its calls,
    ``run(instance, k0, n)`` the outputs of steps ``k0 .. k0+n-1``.

    Returns (restored run == first, deserialised run == first, serialised size in bytes), bit for bit.
    """
    a, ca = new("roundtrip_a")
    run(a, 0, steps_before)
    state = ca.get_state()
    data = ca.serialize(state)
    first = run(a, steps_before, steps_after)
    ca.set_state(state)
    again = run(a, steps_before, steps_after)
    ca.free_state(state)
    b, cb = new("roundtrip_b")
    state_b = cb.deserialize(data)
    cb.set_state(state_b)
    restored = run(b, steps_before, steps_after)
    cb.free_state(state_b)
    ca.end()
    cb.end()
    return first.tobytes() == again.tobytes(), first.tobytes() == restored.tobytes(), len(data)


def me_roundtrip(calls: StateCalls, seed: int = 1) -> bool:
    """Model Exchange: the derivatives at a perturbed state, again after setting other states and restoring the
    saved FMU state, and again after restoring its deserialised copy; True when all three are bit for bit equal."""
    assert calls.get_x is not None and calls.set_x is not None and calls.dx is not None
    rng = np.random.default_rng(seed)
    x0 = calls.get_x()
    x1 = x0 + 0.1 * rng.standard_normal(x0.size)
    calls.set_x(x1)
    d1 = calls.dx()
    state = calls.get_state()
    data = calls.serialize(state)
    calls.set_x(x1 + 1.0)
    calls.set_state(state)
    d2 = calls.dx()
    calls.set_x(x1 - 1.0)
    state2 = calls.deserialize(data)
    calls.set_state(state2)
    d3 = calls.dx()
    calls.free_state(state)
    calls.free_state(state2)
    calls.end()
    return d1.tobytes() == d2.tobytes() == d3.tobytes()
