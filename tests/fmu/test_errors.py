"""Robustness of the FMI wrapper: every bad call returns fmi2Error or fmi2Discard with a message.

Driven at the C-API level through FMPy's low-level ``FMU2Slave`` / ``FMU2Model``
with a logger that records every message; one test per bad-call case.
"""

from __future__ import annotations

from ctypes import addressof as ctypes_address
from ctypes import byref, c_char, c_double, c_int, c_size_t, c_void_p, create_string_buffer

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (fmi2CoSimulation, fmi2Discard, fmi2DoStepStatus, fmi2Error, fmi2EventInfo, fmi2FMUstate,
                       fmi2LastSuccessfulTime, fmi2OK, fmi2Real, fmi2Status,
                       fmi2ValueReference, fmi2Warning)

from tests.support.fmu_support import Harness, LogRecorder, make_callbacks

TAU = ["tau_m[1]", "tau_m[2]", "tau_m[3]", "tau_m[4]"]


@pytest.fixture
def cs():
    h = Harness("cs").start()
    yield h
    h.close()


@pytest.fixture
def cs_fresh():
    h = Harness("cs").start(initialise=False)
    yield h
    h.close()


@pytest.fixture
def me():
    h = Harness("me").start()
    h.fmu.enterContinuousTimeMode()
    yield h
    h.close()


def status_of(call, *args, **kwargs) -> int:
    """The status of an FMPy call that may raise FMICallException."""
    try:
        result = call(*args, **kwargs)
    except FMICallException as exc:
        return exc.status
    return fmi2OK if result is None else int(result)


def last(h: Harness) -> tuple[int, str, str]:
    assert h.log.messages, "the FMU logged nothing"
    return h.log.messages[-1]


def assert_logged(h: Harness, status: int, category: str, *fragments: str) -> None:
    got_status, got_category, message = last(h)
    assert (got_status, got_category) == (status, category), message
    for fragment in fragments:
        assert fragment in message, message


# -------------------------------------------------------------- instantiation

def _instantiate(h: Harness, guid: bytes | None, callbacks=None, name: bytes = b"x", kind: int = fmi2CoSimulation):
    cb = h.callbacks if callbacks is None else callbacks
    return h.fmu.fmi2Instantiate(name, kind, guid, b"file:///tmp", byref(cb) if cb is not False else None, 0, 0)


def test_wrong_guid_is_refused_with_a_message():
    h = Harness("cs")
    try:
        assert _instantiate(h, b"{00000000-0000-0000-0000-000000000000}") is None
        assert_logged(h, fmi2Error, "logStatusError", "fmi2Instantiate: wrong GUID")
    finally:
        h.close()


def test_null_guid_is_refused():
    h = Harness("cs")
    try:
        assert _instantiate(h, None) is None
        assert_logged(h, fmi2Error, "logStatusError", "wrong GUID")
    finally:
        h.close()


def test_null_callbacks_return_null_without_crashing():
    h = Harness("cs")
    try:
        assert _instantiate(h, h.md.guid.encode(), callbacks=False) is None
    finally:
        h.close()


def test_missing_memory_callbacks_are_refused():
    h = Harness("cs")
    log = LogRecorder()
    callbacks = make_callbacks(log, with_memory=False)
    try:
        assert _instantiate(h, h.md.guid.encode(), callbacks=callbacks) is None
        assert "allocateMemory and freeMemory are required" in log.text()
    finally:
        h.close()


def test_empty_instance_name_is_refused():
    h = Harness("cs")
    try:
        assert _instantiate(h, h.md.guid.encode(), name=b"") is None
        assert_logged(h, fmi2Error, "logStatusError", "instanceName is NULL or empty")
    finally:
        h.close()


def test_unknown_fmu_type_is_refused():
    h = Harness("cs")
    try:
        assert _instantiate(h, h.md.guid.encode(), kind=7) is None
        assert_logged(h, fmi2Error, "logStatusError", "neither fmi2ModelExchange nor fmi2CoSimulation")
    finally:
        h.close()


def test_null_component_is_an_error_not_a_crash():
    h = Harness("cs")
    try:
        assert h.fmu.dll.fmi2DoStep(None, c_double(0.0), c_double(1e-3), c_int(1)) == fmi2Error
        assert h.fmu.dll.fmi2GetReal(None, None, c_size_t(0), None) == fmi2Error
        h.fmu.dll.fmi2FreeInstance(None)
    finally:
        h.close()


# ------------------------------------------------------------- call sequence

def test_do_step_before_initialisation(cs_fresh):
    assert status_of(cs_fresh.fmu.doStep, 0.0, 1e-3) == fmi2Error
    assert_logged(cs_fresh, fmi2Error, "logStatusError", "fmi2DoStep: illegal call sequence",
                  'not allowed in mode "instantiated"')


def test_exit_initialisation_without_enter(cs_fresh):
    assert status_of(cs_fresh.fmu.exitInitializationMode) == fmi2Error
    assert_logged(cs_fresh, fmi2Error, "logStatusError", "fmi2ExitInitializationMode: illegal call sequence")


def test_setup_experiment_after_initialisation(cs):
    assert status_of(cs.fmu.setupExperiment, startTime=1.0) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2SetupExperiment: illegal call sequence",
                  '"step complete"')


def test_calls_after_an_error_are_refused_until_reset(cs):
    assert status_of(cs.fmu.doStep, 0.0, 0.0) == fmi2Error
    assert status_of(cs.fmu.doStep, 0.0, 1e-3) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", 'not allowed in mode "error"')
    assert len(cs.fmu.getReal(cs.vr("q[1]"))) == 1            # getters stay legal in the error mode


def test_reset_after_an_error_gives_a_fresh_instance(cs):
    cs.fmu.setReal(cs.vr(*TAU), [0.1, 0.1, 0.0, 0.0])
    cs.fmu.doStep(0.0, 1e-3)
    assert status_of(cs.fmu.doStep, 0.0, 1e-3) == fmi2Error    # wrong communication point
    cs.fmu.reset()
    cs.fmu.setupExperiment(startTime=0.0)
    cs.fmu.enterInitializationMode()
    cs.fmu.exitInitializationMode()
    assert cs.fmu.getReal(cs.vr("q[1]", "tau_m[1]")) == [0.0, 0.0]
    cs.fmu.doStep(0.0, 1e-3)


def test_model_exchange_function_on_a_co_simulation_instance(cs):
    assert cs.fmu.dll.fmi2SetTime(c_void_p(cs.c), c_double(1.0)) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2SetTime: this function belongs to Model Exchange")


def test_co_simulation_function_on_a_model_exchange_instance(me):
    assert me.fmu.dll.fmi2DoStep(c_void_p(me.c), c_double(0.0), c_double(1e-3), c_int(1)) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "fmi2DoStep: this function belongs to Co-Simulation")


def test_new_discrete_states_outside_event_mode(me):
    info = fmi2EventInfo()
    assert status_of(me.fmu.fmi2NewDiscreteStates, me.c, byref(info)) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "fmi2NewDiscreteStates: illegal call sequence",
                  '"continuous-time mode"')


# ----------------------------------------------------------- value references

def test_unknown_value_reference_in_get_real(cs):
    assert status_of(cs.fmu.getReal, [0, 999]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2GetReal: unknown value reference 999")


def test_unknown_value_reference_in_set_real(cs):
    assert status_of(cs.fmu.setReal, [12345], [1.0]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2SetReal: unknown value reference 12345")


def test_there_are_no_integer_variables(cs):
    assert status_of(cs.fmu.getInteger, [0]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "the model has no Integer variables")


def test_null_value_reference_array(cs):
    values = (fmi2Real * 2)()
    assert status_of(cs.fmu.fmi2SetReal, cs.c, None, 2, values) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2SetReal: argument vr[] is NULL")


def test_null_value_array(cs):
    vr = (fmi2ValueReference * 2)(0, 1)
    assert status_of(cs.fmu.fmi2GetReal, cs.c, vr, 2, None) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2GetReal: argument value[] is NULL")


def test_zero_length_calls_need_no_arrays(cs):
    assert status_of(cs.fmu.fmi2GetReal, cs.c, None, 0, None) == fmi2OK
    assert status_of(cs.fmu.fmi2SetReal, cs.c, None, 0, None) == fmi2OK


# ------------------------------------------------------------------- values

def test_nan_input_is_rejected_and_the_input_kept(cs):
    cs.fmu.setReal(cs.vr("tau_m[1]"), [0.5])
    assert status_of(cs.fmu.setReal, cs.vr("tau_m[1]", "tau_m[2]"), [0.25, float("nan")]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2SetReal: variable tau_m[2]: value nan is not finite")
    assert cs.fmu.getReal(cs.vr("tau_m[1]")) == [0.5]         # a rejected call changes nothing


def test_infinite_input_is_rejected(cs):
    assert status_of(cs.fmu.setReal, cs.vr("tau_m[3]"), [float("-inf")]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "variable tau_m[3]: value -inf is not finite")


def test_parameter_out_of_range(cs):
    assert status_of(cs.fmu.setReal, cs.vr("payload_mass"), [-1.0]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "variable payload_mass: value -1 is outside [0, inf]")


def test_setting_a_calculated_output(cs):
    assert status_of(cs.fmu.setReal, cs.vr("tool_position[1]"), [1.0]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "tool_position[1] is calculated by the model and cannot be set")


def test_fixed_parameter_after_initialisation(cs):
    assert status_of(cs.fmu.setReal, cs.vr("gravity[3]"), [-1.62]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError",
                  "variable gravity[3] is fixed: it can only be set before fmi2ExitInitializationMode")


def test_internal_step_after_initialisation(cs):
    assert status_of(cs.fmu.setReal, cs.vr("internal_step"), [1e-4]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "variable internal_step is fixed")


def test_state_start_value_after_initialisation(cs):
    assert status_of(cs.fmu.setReal, cs.vr("q[1]"), [0.3]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "variable q[1] is a continuous state", '"step complete"')


def test_tunable_parameter_in_continuous_time_mode(me):
    assert status_of(me.fmu.setReal, me.vr("payload_mass"), [2.0]) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "variable payload_mass is a tunable parameter",
                  '"continuous-time mode"')


def test_tunable_parameter_between_steps_is_accepted(cs):
    cs.fmu.doStep(0.0, 1e-3)
    cs.fmu.setReal(cs.vr("payload_mass", "viscous_friction[2]"), [3.0, 2e-3])
    cs.fmu.doStep(1e-3, 1e-3)
    assert cs.fmu.getReal(cs.vr("payload_mass")) == [3.0]
    assert not any(status >= fmi2Warning for status, _, _ in cs.log.messages)


# ------------------------------------------------------------------ stepping

def _with_stop_time(kind: str, stop_time: float) -> Harness:
    h = Harness(kind).start(initialise=False)
    h.fmu.setupExperiment(startTime=0.0, stopTime=stop_time)
    h.fmu.enterInitializationMode()
    h.fmu.exitInitializationMode()
    return h


def test_a_step_past_the_stop_time_is_an_error():
    """FMI 2.0 (2.1.6): with stopTimeDefined, computing past stopTime has to be an error."""
    h = _with_stop_time("cs", 0.01)
    try:
        for k in range(9):                                   # t = k h, h = 1 ms: up to 0.009
            h.fmu.doStep(k * 1e-3, 1e-3)
        assert status_of(h.fmu.doStep, 9e-3, 1e-3) == fmi2OK  # 0.009 + 0.001 rounds just off 0.01: still accepted
        assert status_of(h.fmu.doStep, 0.01, 1e-3) == fmi2Error
        assert_logged(h, fmi2Error, "logStatusError", "fmi2DoStep: a step from 0.01 of 0.001 s ends past the stopTime 0.01 ")
    finally:
        h.close()


def test_model_exchange_past_the_stop_time_is_an_error():
    """An accepted integrator step, or event mode, past stopTime is an error; a trial point inside a step is not
    (CVode evaluates past its output point and interpolates back)."""
    h = _with_stop_time("me", 1.0)
    try:
        h.fmu.enterContinuousTimeMode()
        assert status_of(h.fmu.setTime, 1.001) == fmi2OK       # a trial point of the integrator
        assert status_of(h.fmu.setTime, 1.0) == fmi2OK
        assert h.fmu.completedIntegratorStep() == (False, False)
        h.fmu.setTime(1.001)
        assert status_of(h.fmu.completedIntegratorStep) == fmi2Error
        assert_logged(h, fmi2Error, "logStatusError", "fmi2CompletedIntegratorStep: an integrator step completed at "
                      "t = 1.0009999999999999, past the stopTime 1 ")
    finally:
        h.close()


def test_one_do_step_takes_at_most_a_million_sub_steps(cs_fresh):
    """internal_step >= 1e-6 s and <= 1e6 sub-steps per call bound the work of one fmi2DoStep."""
    cs = cs_fresh
    assert status_of(cs.fmu.setReal, cs.vr("internal_step"), [1e-7]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "internal_step: value 9.9999999999999995e-08 is outside [1e-06, inf]")
    cs.fmu.reset()
    cs.fmu.setReal(cs.vr("internal_step"), [1e-6])
    cs.fmu.setupExperiment(startTime=0.0)
    cs.fmu.enterInitializationMode()
    cs.fmu.exitInitializationMode()
    assert status_of(cs.fmu.doStep, 0.0, 1.0) == fmi2OK          # 1e6 sub-steps: the most one call takes
    assert status_of(cs.fmu.doStep, 1.0, 1.5) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError",
                  "fmi2DoStep: communicationStepSize 1.5 needs more than 1000000 sub-steps of internal_step 1e-06 s")


def _substep_counts(cs: Harness, steps: list[float]) -> list[int]:
    import re

    cs.fmu.setDebugLogging(True, ["logCalls"])
    t = 0.0
    for h in steps:
        cs.fmu.doStep(t, h)
        t += h
    found = [re.search(r"fmi2DoStep: from t = \S+, (\d+) sub-steps", m) for _, _, m in cs.log.messages]
    return [int(f.group(1)) for f in found if f is not None]


def test_the_sub_step_count_ignores_rounding_noise_in_the_step(cs):
    """h (1 +- 1e-10) takes as many sub-steps as h; noise used to turn 1 sub-step into 2 (and 2 into 3)."""
    from fmu.variables import substeps

    counts = _substep_counts(cs, [1e-3 * (1 + 1e-10), 1e-3 * (1 - 1e-10), 2e-3 * (1 + 1e-10), 2e-3 * (1 - 1e-10),
                                  2.5e-3, 1e-3 * (1 + 1e-6)])
    assert counts == [1, 1, 2, 2, 3, 2]
    # the Python twin counts as the C wrapper does
    assert [substeps(h, 1e-3) for h in (1e-3 * (1 + 1e-10), 1e-3 * (1 - 1e-10), 2.5e-3, 1e-3 * (1 + 1e-6))] == \
        [1, 1, 3, 2]
    assert substeps(2.0, 1e-6) == 0



def test_zero_communication_step(cs):
    assert status_of(cs.fmu.doStep, 0.0, 0.0) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2DoStep: communicationStepSize 0 must be positive and finite")


def test_negative_communication_step(cs):
    assert status_of(cs.fmu.doStep, 0.0, -1e-3) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "communicationStepSize -0.001 must be positive and finite")


def test_non_finite_communication_step(cs):
    assert status_of(cs.fmu.doStep, 0.0, float("nan")) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "communicationStepSize nan must be positive and finite")


def test_communication_point_that_is_not_the_fmu_time(cs):
    cs.fmu.doStep(0.0, 1e-3)
    assert status_of(cs.fmu.doStep, 0.5, 1e-3) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "currentCommunicationPoint 0.5 differs from the FMU time 0.001")


def test_state_that_becomes_non_finite_is_discarded_and_the_last_good_state_kept(cs):
    cs.fmu.setReal(cs.vr(*TAU), [0.01, 0.0, 0.0, 0.0])
    cs.fmu.doStep(0.0, 1e-3)
    good = cs.states()
    cs.fmu.setReal(cs.vr(*TAU), [1e308, 0.0, 0.0, 0.0])   # finite, but G u overflows
    assert status_of(cs.fmu.doStep, 1e-3, 1e-3) == fmi2Discard
    assert_logged(cs, fmi2Discard, "logStatusDiscard", "fmi2DoStep: the state became non-finite in sub-step 1 of 1",
                  "the state at the communication point 0.001 is kept")
    assert cs.states().tobytes() == good.tobytes()
    assert cs.fmu.getRealStatus(fmi2LastSuccessfulTime) == 1e-3


def test_step_after_a_discard_needs_the_state_restored(cs):
    state = cs.fmu.getFMUstate()
    cs.fmu.setReal(cs.vr(*TAU), [1e308, 0.0, 0.0, 0.0])
    assert status_of(cs.fmu.doStep, 0.0, 1e-3) == fmi2Discard
    assert status_of(cs.fmu.doStep, 0.0, 1e-3) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", 'fmi2DoStep: illegal call sequence, not allowed in mode "step failed"')
    cs.fmu.setFMUstate(state)                               # back to the saved state and mode
    cs.fmu.doStep(0.0, 1e-3)
    cs.fmu.freeFMUstate(state)


def test_cancel_step_is_an_error(cs):
    assert status_of(cs.fmu.cancelStep) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2CancelStep: fmi2DoStep is synchronous")


def test_unavailable_status_is_a_discard(cs):
    value = fmi2Status()
    assert status_of(cs.fmu.fmi2GetStatus, cs.c, fmi2DoStepStatus, byref(value)) == fmi2Discard
    assert_logged(cs, fmi2Discard, "logStatusDiscard", "fmi2GetStatus: status kind 0 is not available")


def test_input_derivatives_are_not_supported(cs):
    assert status_of(cs.fmu.setRealInputDerivatives, cs.vr("tau_m[1]"), [1], [1.0]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "canInterpolateInputs")


# ---------------------------------------------------------------- FMU state

def test_deserialise_a_buffer_of_the_wrong_size(cs):
    state = cs.fmu.getFMUstate()
    data = cs.fmu.serializeFMUstate(state)
    assert status_of(cs.fmu.deSerializeFMUstate, data[:-1]) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError",
                  f"fmi2DeSerializeFMUstate: {len(data) - 1} bytes rejected: the size does not match")
    cs.fmu.freeFMUstate(state)


def test_deserialise_a_corrupt_header(cs):
    state = cs.fmu.getFMUstate()
    data = bytearray(cs.fmu.serializeFMUstate(state))
    data[0] ^= 0xFF
    assert status_of(cs.fmu.deSerializeFMUstate, bytes(data)) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "not a serialized FMU state of this wrapper")
    cs.fmu.freeFMUstate(state)


def test_deserialise_the_state_of_another_model(cs):
    state = cs.fmu.getFMUstate()
    data = bytearray(cs.fmu.serializeFMUstate(state))
    data[25] ^= 0x01                                   # inside the recorded GUID
    assert status_of(cs.fmu.deSerializeFMUstate, bytes(data)) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "the state belongs to another model (GUID differs)")
    cs.fmu.freeFMUstate(state)


def test_deserialise_non_finite_values(cs):
    state = cs.fmu.getFMUstate()
    data = bytearray(cs.fmu.serializeFMUstate(state))
    data[136:144] = np.array([np.nan]).tobytes()       # x[0]: the values follow the 136-byte header
    assert status_of(cs.fmu.deSerializeFMUstate, bytes(data)) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "the recorded values are not finite")
    cs.fmu.freeFMUstate(state)


def test_every_bit_flip_of_the_header_and_every_truncation_is_refused(cs):
    """A corrupted state byte string through FMPy: one bit flipped anywhere in bytes 0-103 (magic, version,
    byte order, size, GUID and its zero padding, vector sizes, mode) or the string cut anywhere is refused.
    The times and values from byte 104 are checked for finiteness only (the non-finite test above): a flip
    there that stays finite is another valid state, which no check of the format can tell from a real one."""
    state = cs.fmu.getFMUstate()
    data = cs.fmu.serializeFMUstate(state)
    restored = cs.fmu.deSerializeFMUstate(data)           # the negative control: the intact string is accepted
    cs.fmu.freeFMUstate(restored)
    for at in range(104):
        for bit in range(8):
            bad = bytearray(data)
            bad[at] ^= 1 << bit
            assert status_of(cs.fmu.deSerializeFMUstate, bytes(bad)) == fmi2Error, (at, bit)
    for cut in (0, 1, 8, 103, 104, 128, len(data) - 8, len(data) - 1):
        assert status_of(cs.fmu.deSerializeFMUstate, data[:cut]) == fmi2Error, cut
    assert_logged(cs, fmi2Error, "logStatusError", f"fmi2DeSerializeFMUstate: {len(data) - 1} bytes rejected")
    cs.fmu.freeFMUstate(state)


def test_serialise_into_a_buffer_of_the_wrong_size(cs):
    state = cs.fmu.getFMUstate()
    size = c_size_t()
    cs.fmu.fmi2SerializedFMUstateSize(cs.c, state, byref(size))
    buffer = create_string_buffer(size.value)
    assert status_of(cs.fmu.fmi2SerializeFMUstate, cs.c, state, buffer, size.value + 8) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", f"size {size.value + 8} differs from fmi2SerializedFMUstateSize")
    cs.fmu.freeFMUstate(state)


def test_set_a_null_fmu_state(cs):
    assert status_of(cs.fmu.fmi2SetFMUstate, cs.c, None) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2SetFMUstate: FMUstate is NULL or not an FMU state")


def test_set_a_foreign_fmu_state(cs):
    junk = create_string_buffer(256)
    assert status_of(cs.fmu.fmi2SetFMUstate, cs.c, junk) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "not an FMU state of this instance")


def test_free_fmu_state_with_a_null_pointer(cs):
    assert status_of(cs.fmu.fmi2FreeFMUstate, cs.c, None) == fmi2Error
    assert_logged(cs, fmi2Error, "logStatusError", "fmi2FreeFMUstate: argument FMUstate is NULL")


def test_deserialise_ignores_the_incoming_value_of_the_out_pointer(cs):
    """*FMUstate is an output of fmi2DeSerializeFMUstate: a stale value in it is neither read nor reused."""
    state = cs.fmu.getFMUstate()
    data = cs.fmu.serializeFMUstate(state)
    junk = create_string_buffer(b"\xff" * 256)
    out = fmi2FMUstate(ctypes_address(junk))
    buffer = (c_char * len(data)).from_buffer_copy(data)
    assert status_of(cs.fmu.fmi2DeSerializeFMUstate, cs.c, buffer, len(data), byref(out)) == fmi2OK
    assert out.value != ctypes_address(junk)
    assert junk.raw[:256] == b"\xff" * 256
    assert status_of(cs.fmu.fmi2SetFMUstate, cs.c, out) == fmi2OK
    cs.fmu.freeFMUstate(out)
    cs.fmu.freeFMUstate(state)


def test_a_null_logger_is_refused_with_a_line_on_stderr(capfd):
    h = Harness("cs")
    try:
        callbacks = make_callbacks(LogRecorder())
        callbacks.logger = type(callbacks.logger)()              # a NULL function pointer
        assert _instantiate(h, h.md.guid.encode(), callbacks, name=b"nolog") is None
        err = capfd.readouterr().err
        assert "fmi2Instantiate(nolog): refused: functions->logger is NULL" in err
    finally:
        h.close()


def test_free_of_an_empty_fmu_state_is_a_no_op(cs):
    empty = fmi2FMUstate()
    assert status_of(cs.fmu.fmi2FreeFMUstate, cs.c, byref(empty)) == fmi2OK


def test_co_simulation_state_into_a_model_exchange_instance(cs, me):
    state = cs.fmu.getFMUstate()
    data = cs.fmu.serializeFMUstate(state)
    assert status_of(me.fmu.deSerializeFMUstate, data) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "the recorded mode is not valid for this instance type")
    cs.fmu.freeFMUstate(state)


# ---------------------------------------------------------- Model Exchange

def test_event_indicators_of_the_wrong_size(me):
    z = (fmi2Real * 1)()
    assert status_of(me.fmu.fmi2GetEventIndicators, me.c, z, 1) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "fmi2GetEventIndicators: ni is 1, expected 4")   # one friction mode per joint


def test_continuous_states_of_the_wrong_size(me):
    x = (fmi2Real * 3)()
    assert status_of(me.fmu.fmi2SetContinuousStates, me.c, x, 3) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "fmi2SetContinuousStates: nx is 3, expected 8")


def test_non_finite_continuous_states(me):
    x = (fmi2Real * 8)(*([0.0] * 7 + [float("inf")]))
    assert status_of(me.fmu.fmi2SetContinuousStates, me.c, x, 8) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "the states are not all finite")


def test_non_finite_derivatives_are_a_discard(me):
    me.fmu.setReal(me.vr("tau_m[2]"), [1e308])
    dx = (fmi2Real * 8)()
    assert status_of(me.fmu.fmi2GetDerivatives, me.c, dx, 8) == fmi2Discard
    assert_logged(me, fmi2Discard, "logStatusDiscard",
                  "fmi2GetDerivatives: the derivatives at t = 0 are not all finite")


def test_non_finite_values_from_get_real_are_a_discard_too(me):
    """One policy for non-finite computed values: fmi2GetReal as fmi2GetDerivatives."""
    me.fmu.setReal(me.vr("tau_m[2]"), [1e308])
    vr = (fmi2ValueReference * 1)(*me.vr("der(qd[2])"))
    value = (fmi2Real * 1)()
    assert status_of(me.fmu.fmi2GetReal, me.c, vr, 1, value) == fmi2Discard
    assert not np.isfinite(value[0])
    assert_logged(me, fmi2Discard, "logStatusDiscard", "fmi2GetReal: the values at t = 0 are not all finite")


def test_a_state_can_be_set_in_continuous_time_mode(me):
    """FMI 2.0.1 allows fmi2SetReal on a continuous state in Continuous-Time Mode."""
    before = me.fmu.getReal(me.vr("der(q[1])"))[0]
    assert status_of(me.fmu.setReal, me.vr("qd[1]"), [0.25]) == fmi2OK
    assert me.fmu.getReal(me.vr("qd[1]", "der(q[1])")) == [0.25, 0.25]     # der(q) = qd: the cache was refreshed
    assert before == 0.0


def test_a_state_cannot_be_set_in_event_mode(me):
    """FMI 2.0.5 (3.2.3): in Event Mode fmi2SetReal is for inputs and tunable parameters only; a continuous
    state is refused with fmi2Error and a message, and keeps its value (a rejected call changes nothing)."""
    me.fmu.enterEventMode()
    q2 = me.fmu.getReal(me.vr("q[2]"))
    assert status_of(me.fmu.setReal, me.vr("q[2]"), [0.1]) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "fmi2SetReal: variable q[2] is a continuous state",
                  "not in event mode", 'mode "event mode"')
    assert me.fmu.getReal(me.vr("q[2]")) == q2


def test_inputs_and_tunable_parameters_can_be_set_in_event_mode(me):
    """The negative control of the test above: what Event Mode does allow still works."""
    me.fmu.enterEventMode()
    assert status_of(me.fmu.setReal, me.vr("tau_m[1]"), [0.1]) == fmi2OK
    assert status_of(me.fmu.setReal, me.vr("payload_mass"), [0.5]) == fmi2OK
    assert me.fmu.getReal(me.vr("tau_m[1]", "payload_mass")) == [0.1, 0.5]


def test_set_time_is_refused_in_event_mode(me):
    """FMI 2.0.5 (3.2.3, fmi-standard #394): time advances only in Continuous-Time Mode for a model with
    continuous states; fmi2SetTime in Event Mode is fmi2Error with a message."""
    me.fmu.setTime(0.5)
    me.fmu.enterEventMode()
    assert status_of(me.fmu.setTime, 0.5) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "fmi2SetTime: illegal call sequence", 'mode "event mode"')


def test_directional_derivative_with_an_output_as_known(me):
    assert status_of(me.fmu.getDirectionalDerivative, me.vr("der(qd[1])"), me.vr("tool_position[1]"),
                     [1.0]) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "tool_position[1] cannot be a known")


def test_directional_derivative_with_a_nan_seed(me):
    assert status_of(me.fmu.getDirectionalDerivative, me.vr("der(qd[1])"), me.vr("q[1]"),
                     [float("nan")]) == fmi2Error
    assert_logged(me, fmi2Error, "logStatusError", "the seed of q[1] is not finite")


# ----------------------------------------------------------------- logging

def test_unknown_log_category_is_a_warning(cs):
    cs.fmu.setDebugLogging(True, ["logCalls", "no%such%category"])
    status, category, message = last(cs)
    assert (status, category) == (fmi2Warning, "logStatusWarning")
    # the message is a printf format for the importer: every '%' is doubled
    assert 'unknown log category "no%%such%%category", ignored' in message


def test_log_calls_category_traces_every_call(cs):
    cs.fmu.setDebugLogging(True, ["logCalls"])
    cs.fmu.doStep(0.0, 1e-3)
    assert (fmi2OK, "logCalls", "fmi2DoStep") in cs.log.messages
    cs.fmu.setDebugLogging(False, [])
    count = len(cs.log.messages)
    cs.fmu.doStep(1e-3, 1e-3)
    assert len(cs.log.messages) == count


def test_errors_can_be_silenced_by_category(cs):
    cs.fmu.setDebugLogging(False, ["logStatusError"])
    count = len(cs.log.messages)
    assert status_of(cs.fmu.getReal, [999]) == fmi2Error
    assert len(cs.log.messages) == count


def test_model_exchange_instance_reports_its_mode_in_messages():
    h = Harness("me").start(initialise=False)
    try:
        assert status_of(h.fmu.enterContinuousTimeMode) == fmi2Error
        assert_logged(h, fmi2Error, "logStatusError", "fmi2EnterContinuousTimeMode: illegal call sequence",
                      '"instantiated"')
    finally:
        h.close()
