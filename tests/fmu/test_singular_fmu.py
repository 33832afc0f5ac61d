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

import ctypes

import numpy as np
import pytest

from tests.support.fmu_support import LogRecorder, build_root, make_callbacks
from tests.support.singular_arm import spinner


@pytest.fixture(scope="module")
def spinner_fmu():
    from fmpy import extract, read_model_description

    from fmu import export_fmu

    path = export_fmu(spinner(as_payload=True), build_root() / "spinner.fmu")
    return read_model_description(str(path)), extract(str(path), unzipdir=str(build_root() / "spinner_unzipped"))


def instance(spinner_fmu, kind: str):
    from fmpy.fmi2 import FMU2Model, FMU2Slave

    md, unzip = spinner_fmu
    cls = FMU2Slave if kind == "cs" else FMU2Model
    fmu = cls(guid=md.guid, unzipDirectory=unzip, modelIdentifier="spinner", instanceName=kind)
    log = LogRecorder()
    callbacks = make_callbacks(log)
    fmu.instantiate(callbacks=callbacks)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return fmu, vr, log, callbacks


def initialise(fmu, values=None) -> None:
    """setupExperiment and initialisation with ``values`` ({value reference: value}) set in it."""
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    if values:
        fmu.setReal(list(values), list(values.values()))
    fmu.exitInitializationMode()


def last_error(log, fn: str) -> str:
    """The last logged message, checked to be ``fn``'s error."""
    from fmpy.fmi2 import fmi2Error

    status, category, message = log.messages[-1]
    assert (status, category) == (fmi2Error, "logStatusError") and message.startswith(f"{fn}: "), message
    return message


def raised_status(call, *args) -> int:
    from fmpy.fmi1 import FMICallException

    with pytest.raises(FMICallException) as info:
        call(*args)
    return int(info.value.status)


def test_a_singular_start_state_is_refused_by_exit_initialization(spinner_fmu):
    from fmpy.fmi2 import fmi2Error

    fmu, vr, log, _callbacks = instance(spinner_fmu, "cs")
    try:
        assert raised_status(initialise, fmu, {vr["q[2]"]: 0.0}) == fmi2Error
        message = last_error(log, "fmi2ExitInitializationMode")
        assert "the inertia matrix B(q) is singular at joint 1" in message and "q = [0, 0]" in message
    finally:
        fmu.freeInstance()


def test_a_co_simulation_step_into_a_singular_plant_is_an_error_naming_the_joint(spinner_fmu):
    from fmpy.fmi2 import fmi2Error

    fmu, vr, log, _callbacks = instance(spinner_fmu, "cs")
    try:
        initialise(fmu)
        fmu.setReal([vr["tau_m[1]"]], [0.01])
        fmu.doStep(0.0, 1e-3)                                         # negative control: with the payload it steps
        before = np.array(fmu.getReal([vr["q[1]"], vr["q[2]"]]))
        assert np.all(np.isfinite(before))
        fmu.setReal([vr["payload_mass"]], [0.0])                      # tunable: joint 1 now moves no mass
        assert raised_status(fmu.doStep, 1e-3, 1e-3) == fmi2Error
        message = last_error(log, "fmi2DoStep")
        assert "the inertia matrix B(q) is singular at joint 1" in message
        assert "in the step from t = 0.001" in message and f"q = [{before[0]:.9g}, 0.3" in message
    finally:
        fmu.freeInstance()


def test_model_exchange_derivatives_at_a_singular_state_are_an_error(spinner_fmu):
    from fmpy.fmi2 import fmi2Error

    fmu, vr, log, _callbacks = instance(spinner_fmu, "me")
    try:
        initialise(fmu)
        fmu.newDiscreteStates()
        fmu.enterContinuousTimeMode()
        dx = (ctypes.c_double * 4)()
        fmu.getDerivatives(dx, 4)                                     # negative control: at the rest it is finite
        assert np.all(np.isfinite(np.array(dx)))
        fmu.setContinuousStates((ctypes.c_double * 4)(0.2, 0.0, 0.0, 0.0), 4)
        assert raised_status(fmu.getDerivatives, dx, 4) == fmi2Error
        message = last_error(log, "fmi2GetDerivatives")
        assert "the inertia matrix B(q) is singular at joint 1" in message and "q = [0.2, 0]" in message
    finally:
        fmu.freeInstance()
