"""A singular B(q) in the FMU is an error status with a log message naming the joint and q, never NaN.

The spinner (tests/support/singular_arm.py) carries its only mass on joint 1 as a 2 kg
payload: ``B(q) = diag(m d2^2, m + G2^2 Jm2)``, singular at ``d2 = 0`` and, once the
importer sets ``payload_mass = 0``, at every q. The export check passes (the rest is
``d2 = 0.3``); the FMU meets the singularity at run time: in ExitInitializationMode
(a start state at ``d2 = 0``), in a Co-Simulation step (the payload removed at a
communication point) and in Model Exchange's GetDerivatives. Before, the first two
were "non-finite derivatives" / a discarded step without the cause, and the third
returned NaN with a Discard.
"""

from __future__ import annotations


import numpy as np
import pytest

from tests.support.fmu_support import build_root
from tests.support.singular_arm import spinner


@pytest.fixture(scope="module")
def spinner_fmu():
    from fmu import export_fmu
    from fmu.opened import open_fmu

    with open_fmu(export_fmu(spinner(as_payload=True), build_root() / "spinner.fmu")) as fmu:
        yield fmu


def instance(spinner_fmu, kind: str):
    """An instantiated :class:`fmu.instance.Instance` of interface ``kind``; its log is ``messages``."""
    return spinner_fmu.instance(kind, kind).instantiate()


def last_error(inst, fn: str) -> str:
    """The last logged message, checked to be ``fn``'s error."""
    status, category, message = inst.messages[-1]
    assert (status, category) == ("Error", "logStatusError") and message.startswith(f"{fn}: "), message
    return message


def raised_status(call, *args) -> int:
    from fmu.instance import FmuCallError

    with pytest.raises(FmuCallError) as info:
        call(*args)
    return int(info.value.status)


def test_a_singular_start_state_is_refused_by_exit_initialization(spinner_fmu):
    from fmpy.fmi2 import fmi2Error

    with instance(spinner_fmu, "cs") as fmu:
        assert raised_status(fmu.start, 0.0, {"q[2]": 0.0}) == fmi2Error
        message = last_error(fmu, "fmi2ExitInitializationMode")
        assert "the inertia matrix B(q) is singular at joint 1" in message and "q = [0, 0]" in message


def test_a_co_simulation_step_into_a_singular_plant_is_an_error_naming_the_joint(spinner_fmu):
    from fmpy.fmi2 import fmi2Error

    with instance(spinner_fmu, "cs") as fmu:
        fmu.start(0.0)
        fmu.set(["tau_m[1]"], [0.01])
        fmu.do_step(0.0, 1e-3)                                        # negative control: with the payload it steps
        before = fmu.get(["q[1]", "q[2]"])
        assert np.all(np.isfinite(before))
        fmu.set(["payload_mass"], [0.0])                              # tunable: joint 1 now moves no mass
        assert raised_status(fmu.do_step, 1e-3, 1e-3) == fmi2Error
        message = last_error(fmu, "fmi2DoStep")
        assert "the inertia matrix B(q) is singular at joint 1" in message
        assert "in the step from t = 0.001" in message and f"q = [{before[0]:.9g}, 0.3" in message


def test_model_exchange_derivatives_at_a_singular_state_are_an_error(spinner_fmu):
    from fmpy.fmi2 import fmi2Error

    with instance(spinner_fmu, "me") as fmu:
        fmu.start(0.0)                                                # event iteration, continuous-time mode
        dx = fmu.get_dx()                                             # negative control: at the rest it is finite
        assert dx.size == 4 and np.all(np.isfinite(dx))
        fmu.set_x(np.array([0.2, 0.0, 0.0, 0.0]))
        assert raised_status(fmu.get_dx) == fmi2Error
        message = last_error(fmu, "fmi2GetDerivatives")
        assert "the inertia matrix B(q) is singular at joint 1" in message and "q = [0.2, 0]" in message
