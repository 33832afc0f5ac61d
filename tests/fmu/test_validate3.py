"""validate-fmu on FMI 3.0 runs every check FMI 2.0 gets, and prints the same list of checks.

The SCARA exported twice (FMI 2.0 and FMI 3.0, same variable table, same C wrapper) is
validated over 0.5 s without libcosim (FMI 2.0 only: skipped on FMI 3.0); the check names
must be the same, in the same order, and all pass. The checks are those of :mod:`fmu.numeric_checks`,
one implementation over :class:`fmu.instance.Instance` for both versions; each can fail (negative
controls: an ``fmi3SetFMUState`` followed by 1 g of payload, an adjoint off by 1e-4 of its value), and a
check that raises is one failed check while the others still run, under the same names.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import pytest

from fmu.instance import FmuCallError
from fmu.numeric_checks import directional_derivative_error, state_roundtrip
from fmu.opened import open_fmu
from fmu.validate import TOLERANCES, feedforward_profile, validate_fmu

from tests.support.fmu_support import _quiet, build_root, scara_fmu

pytestmark = pytest.mark.fmi3

TAU = [f"tau_m[{i}]" for i in range(1, 5)]
STATES = [f"q[{i}]" for i in range(1, 5)] + [f"qd[{i}]" for i in range(1, 5)]


@lru_cache(maxsize=None)
def scara3() -> Path:
    from fmu import export_fmu

    return _quiet(export_fmu, "scara", build_root() / "scara_validate3.fmu", fmi_version=3)


@lru_cache(maxsize=None)
def _profile():
    from model import load_robot

    return feedforward_profile(_quiet(load_robot, "scara"), t_end=0.5)


def test_fmi2_and_fmi3_print_the_same_checks_and_pass():
    r2 = validate_fmu(scara_fmu(), t_end=0.5, with_cosim=False)
    r3 = validate_fmu(scara3(), t_end=0.5, with_cosim=False)
    names = [c.name for c in r2.checks]
    assert names == [c.name for c in r3.checks]
    assert {"FMU state round trips", "directional derivatives", "FMI-LS-REF replay", "Model Exchange q",
            "Co-Simulation = plant q"} <= set(names)
    assert r2.ok and r3.ok, r3.format()
    assert r3.roundtrip.ok and r3.roundtrip.serialized_size == r2.roundtrip.serialized_size
    assert "adjoint against forward" in next(c.what for c in r3.checks if c.name == "directional derivatives")
    assert validate_fmu(scara3(), t_end=0.5, with_cosim=True).cosim_skipped == "FMI 3.0: libcosim imports FMI 2.0 only"


def test_the_round_trip_sees_a_set_state_that_does_nothing(monkeypatch):
    from fmpy.fmi3 import FMU3Slave

    ok = state_roundtrip(scara3(), _profile().at, TAU, STATES, steps_before=50, steps_after=50)
    assert ok.ok
    with open_fmu(scara3()) as fmu:
        payload = fmu.vr("payload_mass")
    original = FMU3Slave.setFMUState

    def restore_then_add_a_gram(self, state):   # a restore that does not give back the same FMU
        original(self, state)
        self.setFloat64([payload], [1e-3])

    monkeypatch.setattr(FMU3Slave, "setFMUState", restore_then_add_a_gram)
    bad = state_roundtrip(scara3(), _profile().at, TAU, STATES, steps_before=50, steps_after=50)
    assert not bad.get_set_identical and not bad.deserialized_identical


def test_the_derivative_check_sees_a_wrong_adjoint(monkeypatch):
    from fmpy.fmi3 import FMU3Model

    worst, count, adjoint = directional_derivative_error(scara3())
    assert count == 612 and worst <= TOLERANCES["directional"] and adjoint <= 1e-12
    original = FMU3Model.getAdjointDerivative
    monkeypatch.setattr(FMU3Model, "getAdjointDerivative",
                        lambda self, *a, **k: [v * (1 + 1e-4) for v in original(self, *a, **k)])
    assert directional_derivative_error(scara3())[2] > TOLERANCES["directional"]


def test_fmi2_has_no_adjoint_to_compare():
    assert directional_derivative_error(scara_fmu()).adjoint is None


@pytest.mark.parametrize("fmu", [scara_fmu, scara3], ids=["fmi2", "fmi3"])
def test_a_check_that_raises_is_one_failed_check_and_the_others_run(fmu, monkeypatch):
    import importlib

    v = importlib.import_module("fmu.validate")   # the submodule (the package's `validate` is the function)
    names = [c.name for c in validate_fmu(scara_fmu(), t_end=0.5, with_cosim=False).checks]

    def refused(*args, **kwargs):
        raise FmuCallError("scara.fmu: fmi2GetFMUstate of instance 'roundtrip_a' returned Error: no state",
                           function="getFMUstate", status=3)

    monkeypatch.setattr(v, "state_roundtrip", refused)
    report = validate_fmu(fmu(), t_end=0.5, with_cosim=False)
    assert [c.name for c in report.checks] == names
    (failed,) = [c for c in report.checks if not c.passed]
    assert failed.name == "FMU state round trips"
    assert failed.line() == ("FAIL FMU state round trips: not run to the end: FmuCallError: scara.fmu: "
                             "fmi2GetFMUstate of instance 'roundtrip_a' returned Error: no state")
    assert report.roundtrip is None and not report.ok and failed.line() in report.format()
    assert "directional derivatives vs central differences" in report.format()   # the next check ran
