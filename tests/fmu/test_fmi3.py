"""FMI 3.0 FMUs of the SCARA, the Puma 560 and the Panda: FMPy validation, Co-Simulation and Model Exchange
against the FMI 2.0 FMU of the same robot, directional and adjoint derivatives, FMU state, bad calls.

Each FMU (FMI 3.0 and FMI 2.0 of each robot) is built once per session (about 25 s for all six).
Tolerances:

* Co-Simulation: 1e-12 relative to the motion scale. Both versions run the same instance.c (the same
  RK4, the same event location, the same CasADi code compiled with the same flags), so they agree bit
  for bit in practice; the bound only forgives the last bits.
* Model Exchange: FMPy's CVode at rtol 1e-10 on both FMUs: 1e-7 of the motion scale (1e3 x rtol,
  the allowance of fmu.validate for CVode's global error, without its divergence gain: the two runs
  integrate the same right-hand side).
* Directional derivatives: |AD - FD| / (1 + |FD|) <= 1e-6 (fmu.validate.TOLERANCES["directional"]) against
  central differences of the FMU's own derivatives and outputs; adjoint against forward mode: the full
  Jacobian built both ways agrees to 1e-12 relative to its largest entry (both are exact AD).
"""

from __future__ import annotations

import ctypes
import zipfile
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from fmu.instance import FmuCallError
from fmu.opened import open_fmu

from tests.support.fmu_support import _quiet, build_root

pytestmark = pytest.mark.fmi3
#: The 6- and 7-joint arms take most of this module's time: they are in the full suite only (make test).
ROBOTS = ("scara", pytest.param("puma560", marks=pytest.mark.slow), pytest.param("panda", marks=pytest.mark.slow))
T_END, H = 0.5, 0.01
CS_RTOL = 1e-12
ME_RTOL = 1e-10
ME_BOUND = 1e3 * ME_RTOL
FD_BOUND = 1e-6


@lru_cache(maxsize=None)
def fmu_of(robot: str, version: int) -> Path:
    from fmu import export_fmu

    return _quiet(export_fmu, robot, build_root() / f"{robot}_fmi{version}.fmu", fmi_version=version)


@lru_cache(maxsize=None)
def profile_of(robot: str):
    from model import load_robot

    from fmu.validate import feedforward_profile

    return feedforward_profile(_quiet(load_robot, robot), t_end=T_END, hold=H)


def _md(path: Path):
    with open_fmu(path) as fmu:
        return fmu.md


def _vr(md, name: str) -> int:
    return next(v.valueReference for v in md.modelVariables if v.name == name)


def _cs_run(path: Path, version: int, profile) -> np.ndarray:
    """States [q, qd] at every communication point of a 10 ms step run under the feed-forward torques.

    The same calls for both versions (scalar names through fmu.instance.Instance); ``version`` is checked."""
    n = profile.tau_m.shape[1]
    tau = [f"tau_m[{i + 1}]" for i in range(n)]
    x = [f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)]
    with open_fmu(path) as fmu, fmu.instance("cs", f"cs{version}") as s:
        assert fmu.fmi_version == version
        s.start(0.0)
        rows = [s.get(x)]
        t = 0.0
        for k in range(int(round(T_END / H))):
            s.set(tau, profile.at(t))
            s.do_step(t, H)
            t = (k + 1) * H
            rows.append(s.get(x))
    return np.array(rows)


@pytest.mark.parametrize("robot", ROBOTS)
def test_fmi3_fmu_passes_fmpy_validation(robot):
    from fmpy.validation import validate_fmu

    path = fmu_of(robot, 3)
    assert validate_fmu(str(path)) == []
    md = _md(path)
    assert md.fmiVersion == "3.0"
    q = next(v for v in md.modelVariables if v.name == "q")
    n = profile_of(robot).tau_m.shape[1]
    assert [d.start for d in q.dimensions] == [n]          # one array variable per joint vector
    with zipfile.ZipFile(path) as zf:
        names = set(zf.namelist())
    assert f"binaries/x86_64-linux/{md.coSimulation.modelIdentifier}.so" in names
    assert "sources/buildDescription.xml" in names and "sources/fmi3Functions.h" in names


@pytest.mark.parametrize("robot", ROBOTS)
def test_cs_agrees_with_the_fmi2_fmu(robot):
    profile = profile_of(robot)
    x3 = _cs_run(fmu_of(robot, 3), 3, profile)
    x2 = _cs_run(fmu_of(robot, 2), 2, profile)
    scale = max(1.0, float(np.max(np.abs(x2))))
    err = float(np.max(np.abs(x3 - x2))) / scale
    print(f"{robot}: FMI 3 CS vs FMI 2 CS, max |dx| / scale = {err:.2e}")
    assert np.all(np.isfinite(x3)) and float(np.max(np.abs(x3[-1] - x3[0]))) > 1e-3  # the arm moved
    assert err <= CS_RTOL


@pytest.mark.parametrize("robot", ROBOTS)
def test_me_agrees_with_the_fmi2_fmu_within_solver_tolerance(robot):
    from fmpy import simulate_fmu

    n = profile_of(robot).tau_m.shape[1]
    runs = {}
    for version, names in ((3, ["q", "qd"]), (2, [f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)])):
        raw = simulate_fmu(str(fmu_of(robot, version)), fmi_type="ModelExchange", solver="CVode", stop_time=T_END,
                           output_interval=H, relative_tolerance=ME_RTOL, output=names)
        runs[version] = (np.array(raw["time"]),
                         np.hstack([np.asarray(raw[nm], dtype=float).reshape(len(raw), -1) for nm in names]))
    (t3, x3), (t2, x2) = runs[3], runs[2]
    assert x3.shape == x2.shape == (len(t2), 2 * n)
    np.testing.assert_array_equal(t3, t2)
    scale = max(1.0, float(np.max(np.abs(x2))))
    err = float(np.max(np.abs(x3 - x2))) / scale
    print(f"{robot}: FMI 3 ME vs FMI 2 ME (CVode rtol {ME_RTOL:g}), max |dx| / scale = {err:.2e}")
    assert err <= ME_BOUND


# ------------------------------------------------------------ low-level instances

def _model(robot: str, name: str = "me3"):
    """The opened FMI 3.0 FMU of ``robot`` and a Model Exchange :class:`fmu.instance.Instance` of it."""
    fmu = open_fmu(fmu_of(robot, 3))
    return fmu, fmu.instance("me", name)


@pytest.mark.parametrize("robot", ROBOTS)
def test_directional_and_adjoint_derivatives(robot):
    """Forward mode against central differences of the FMU's own derivatives; reverse mode against forward."""
    fmu, m = _model(robot)
    n = profile_of(robot).tau_m.shape[1]
    scalars = lambda name, k: [f"{name}[{i}]" for i in range(1, k + 1)]  # noqa: E731
    rng = np.random.default_rng(3)
    m.instantiate()
    m.call("enterInitializationMode", None, 0.0, None)
    x = m.get(scalars("q", n) + scalars("qd", n)) + 0.2 * rng.standard_normal(2 * n)
    m.call("exitInitializationMode")
    m.event_iteration()
    m.enter_continuous_time_mode()

    def f() -> np.ndarray:
        return np.concatenate([m.get_dx(), m.get(scalars("tool_position", 3))])

    m.set_x(x)
    u = 0.05 * rng.standard_normal(n)
    m.set(scalars("tau_m", n), u)
    unknowns = scalars("der(q)", n) + scalars("der(qd)", n) + scalars("tool_position", 3)
    knowns = scalars("q", n) + scalars("qd", n) + scalars("tau_m", n)
    ny, nk = 2 * n + 3, 3 * n
    J = np.column_stack([m.directional(unknowns, [known], [1.0]) for known in knowns])
    JT = np.vstack([m.adjoint(unknowns, knowns, np.eye(ny)[i]) for i in range(ny)])
    assert J.shape == JT.shape == (ny, nk)
    worst = 0.0
    for j in range(nk):
        h = 1e-5 * max(1.0, abs(x[j]) if j < 2 * n else abs(u[j - 2 * n]))

        def at(step):
            if j < 2 * n:
                xp = x.copy()
                xp[j] += step
                m.set_x(xp)
            else:
                up = u.copy()
                up[j - 2 * n] += step
                m.set(scalars("tau_m", n), up)
            return f()

        fd = (8 * (at(h) - at(-h)) - (at(2 * h) - at(-2 * h))) / (12 * h)
        m.set_x(x)
        m.set(scalars("tau_m", n), u)
        worst = max(worst, float(np.max(np.abs(J[:, j] - fd) / (1 + np.abs(fd)))))
    adj = float(np.max(np.abs(JT - J))) / float(np.max(np.abs(J)))
    print(f"{robot}: directional vs FD {worst:.1e}; adjoint vs directional {adj:.1e}")
    assert worst <= FD_BOUND
    assert adj <= 1e-12
    # negative control: the check sees a Jacobian column off by 1e-4 of its scale
    assert float(np.max(np.abs(J[:, 0] * (1 + 1e-4) + 1e-4 - J[:, 0]) / (1 + np.abs(J[:, 0])))) > FD_BOUND
    m.close()
    fmu.close()


def _slave(robot: str = "scara", name: str = "cs3"):
    """The opened FMI 3.0 FMU of ``robot`` and a Co-Simulation :class:`fmu.instance.Instance` of it."""
    fmu = open_fmu(fmu_of(robot, 3))
    return fmu, fmu.instance("cs", name)


def test_fmu_state_round_trip_and_a_corrupted_state_refused():
    from fmpy.fmi3 import fmi3FMUState

    fmu, s = _slave()
    n = 4
    x = [f"q[{i}]" for i in range(1, n + 1)] + [f"qd[{i}]" for i in range(1, n + 1)]
    s.start(0.0)
    s.set([f"tau_m[{i}]" for i in range(1, n + 1)], [0.3, -0.2, 0.0, 0.1])
    t = 0.0
    for _ in range(20):
        s.do_step(t, H)
        t += H
    state = s.get_state()
    t_state = t

    def run(t0):
        tt = t0
        for _ in range(20):
            s.do_step(tt, H)
            tt += H
        return s.get(x)

    first = run(t_state)
    s.set_state(state)
    again = run(t_state)
    np.testing.assert_array_equal(again, first)      # bit for bit
    blob = s.serialize(state)
    restored = s.deserialize(blob)
    s.set_state(restored)
    np.testing.assert_array_equal(run(t_state), first)
    dll, component = s.raw.dll, s.raw.component    # the C API itself: a refused blob gives no state
    for corrupt in (blob[:-8], b"X" + blob[1:], blob[:40] + bytes([blob[40] ^ 1]) + blob[41:]):
        out = fmi3FMUState()
        status = dll.fmi3DeserializeFMUState(component, (ctypes.c_ubyte * len(corrupt))(*corrupt),
                                             ctypes.c_size_t(len(corrupt)), ctypes.byref(out))
        assert status == 3 and not out  # fmi3Error, no state
        assert s.status("deserializeFMUState", corrupt) == 3   # the same through the adapter's choke point
        assert dll.fmi3Reset(component) == 0
    s.free_state(state)
    s.free_state(restored)
    s.close()
    fmu.close()


class _Messages:
    """The FMU's log messages of an instance, as a list: ``messages[-1]`` is the last one."""

    def __init__(self, inst) -> None:
        self.inst = inst

    def __getitem__(self, k: int) -> str:
        return self.inst.messages[k][2]


def test_bad_calls_return_errors_with_a_message():
    fmu, inst = _slave(name="bad")
    md = fmu.md
    messages = _Messages(inst)
    s = inst.instantiate().raw
    dll, c = s.dll, s.component
    vr_type = ctypes.c_uint32
    q, qd, der_q = _vr(md, "q"), _vr(md, "qd"), _vr(md, "der(q)")
    last = ctypes.c_double()
    flags = [ctypes.c_bool() for _ in range(3)]

    def do_step(t, h):
        return dll.fmi3DoStep(c, ctypes.c_double(t), ctypes.c_double(h), ctypes.c_bool(True),
                              *[ctypes.byref(b) for b in flags], ctypes.byref(last))

    def reset():
        assert dll.fmi3Reset(c) == 0
        assert dll.fmi3EnterInitializationMode(c, False, ctypes.c_double(0), ctypes.c_double(0), False,
                                               ctypes.c_double(0)) == 0
        assert dll.fmi3ExitInitializationMode(c) == 0

    # wrong state: a step before initialisation
    assert do_step(0.0, H) == 3 and "illegal call sequence" in messages[-1]
    reset()
    values = (ctypes.c_double * 8)()
    vrs = (vr_type * 2)(q, qd)
    # NULL array
    assert dll.fmi3GetFloat64(c, vrs, ctypes.c_size_t(2), None, ctypes.c_size_t(8)) == 3
    assert "values[] is NULL" in messages[-1]
    reset()
    # wrong size of the arrays: q and qd hold 8 values, not 7
    assert dll.fmi3GetFloat64(c, vrs, ctypes.c_size_t(2), values, ctypes.c_size_t(7)) == 3
    assert "nValues is 7, expected 8" in messages[-1]
    reset()
    # unknown value reference, a calculated variable set, a state set after initialisation, a NaN
    bad = (vr_type * 1)(10_000)
    assert dll.fmi3GetFloat64(c, bad, ctypes.c_size_t(1), values, ctypes.c_size_t(1)) == 3
    assert "unknown value reference 10000" in messages[-1]
    reset()
    one = (vr_type * 1)(der_q)
    assert dll.fmi3SetFloat64(c, one, ctypes.c_size_t(1), values, ctypes.c_size_t(4)) == 3
    assert "calculated" in messages[-1]
    reset()
    one = (vr_type * 1)(q)
    assert dll.fmi3SetFloat64(c, one, ctypes.c_size_t(1), values, ctypes.c_size_t(4)) == 3
    assert "continuous state" in messages[-1]
    reset()
    # a rejected call changes nothing; a step from a wrong communication point is refused
    assert do_step(0.5, H) == 3 and "differs from the FMU time" in messages[-1]
    reset()
    assert do_step(0.0, -1.0) == 3 and "must be positive" in messages[-1]
    # a NULL instance
    assert dll.fmi3DoStep(None, ctypes.c_double(0), ctypes.c_double(H), True, None, None, None, None) == 3
    inst.close()
    # instantiation refused: event mode in Co-Simulation (an option of FMPy's instantiate the adapter does not
    # take: FMPy's own class, on purpose), a wrong token (through the adapter: an FmuCallError with the FMU's word)
    from fmpy.fmi3 import FMU3Slave

    s2 = FMU3Slave(guid=md.guid, unzipDirectory=fmu.unzip_dir, modelIdentifier=md.coSimulation.modelIdentifier,
                   instanceName="refused")
    said: list[str] = []
    with pytest.raises(Exception, match="instantiate"):
        s2.instantiate(eventModeUsed=True, logMessage=lambda env, status, category, message: said.append(message.decode()))
    assert "hasEventMode" in said[-1]
    fmu.md.guid = "{00000000-0000-0000-0000-000000000000}"
    refused = fmu.instance("cs", "refused")
    with pytest.raises(FmuCallError, match="instantiat") as caught:
        refused.instantiate()
    assert "instantiationToken" in str(caught.value) and "instantiationToken" in refused.last_message()
    refused.close()
    fmu.close()


def test_cli_exports_and_validates_an_fmi3_fmu(tmp_path):
    import subprocess
    import sys

    manip = Path(sys.executable).with_name("manip")
    out = tmp_path / "scara3.fmu"
    # the host's binary only: the cross-platform FMI 3.0 export is tests/fmu/test_cross.py's (zig: minutes cold)
    proc = subprocess.run([str(manip), "export-fmu", "scara", "-o", str(out), "--fmi-version", "3", "--platforms", "host"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert _md(out).fmiVersion == "3.0"
    proc = subprocess.run([str(manip), "validate-fmu", str(out), "--horizon", "0.5", "--no-cosim"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "result: OK" in proc.stdout and "Model Exchange q" in proc.stdout
    proc = subprocess.run([str(manip), "export-fmu", "scara", "-o", str(out), "--fmi-version", "4"],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "--fmi-version" in proc.stderr


@pytest.mark.valgrind
@pytest.mark.needs("valgrind")
def test_fmi3_lifecycle_under_valgrind():
    """fmu/c/fmu3_driver.c runs 20 repetitions of a CS and an ME lifecycle of the SCARA FMU (about 10 s)."""
    import re
    import shutil
    import subprocess

    from fmu.build import build_driver

    driver = build_driver(build_root() / "fmu3_driver", fmi_version=3)
    path = fmu_of("scara", 3)
    fmu = open_fmu(path)
    md, unzip = fmu.md, Path(fmu.unzip_dir)
    lib = unzip / "binaries" / "x86_64-linux" / "scara.so"
    args = [str(driver), "soak", str(lib), md.guid, "8", "20",
            *[str(_vr(md, nm)) for nm in ("q", "qd", "tau_m", "der(q)")], "4"]
    proc = subprocess.run(args, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    proc = subprocess.run([shutil.which("valgrind"), "--leak-check=full", "--show-leak-kinds=definite,indirect,possible",
                           "--errors-for-leak-kinds=definite,indirect,possible", "--error-exitcode=1", *args],
                          capture_output=True, text=True, timeout=300)
    report = proc.stderr
    assert proc.returncode == 0, report[-3000:]
    assert "soak: 20 repetitions, 0 failures" in proc.stdout
    assert re.search(r"ERROR SUMMARY: 0 errors from 0 contexts", report)
    fmu.close()


def test_fmi3_pid_controller_fmu_ticks_its_integrator(tmp_path):
    """The sampled discrete states through the FMI 3.0 wrapper: the PID controller FMU validates, is
    Co-Simulation only, ticks once per period (two periods in one step = two steps of one), carries z in its
    serialised state and refuses a step that is no whole number of periods; its torques equal the Python
    PID controller's with the integrator carried (0 seen, bound 1e-12)."""
    from fmpy.fmi3 import FMU3Model
    from fmpy.validation import validate_fmu

    from closed_loop import controller_spec
    from control_design import design_robot
    from control_design.reference import Reference
    from fmu import build_fmu
    from model import load_robot

    robot = _quiet(load_robot, "scara")
    controller = design_robot(robot, "pid", analyse=False).controller(1000.0)
    path = build_fmu(controller_spec(controller, robot), tmp_path / "pid3.fmu", fmi_version=3)
    assert validate_fmu(str(path)) == []
    fmu = open_fmu(path)
    md, unzip = fmu.md, fmu.unzip_dir
    assert md.modelExchange is None and sorted(fmu.interfaces) == ["cs"]
    vr = {nm: _vr(md, nm) for nm in ("q_ref", "qd_ref", "q", "qd", "tau_m", "z")}
    instances = []

    def slave(name):
        inst = fmu.instance("cs", name).start(0.0)
        instances.append(inst)
        return inst.raw

    q_ref = np.array([0.1, 0.2, 0.05, 0.3])
    signals = [q_ref, np.zeros(4), q_ref - 1e-6 * np.arange(1, 5), np.zeros(4)]
    a, b = slave("a"), slave("b")
    for s in (a, b):
        s.setFloat64([vr["q_ref"], vr["qd_ref"], vr["q"], vr["qd"]], list(np.concatenate(signals)))
    a.doStep(0.0, 2e-3)
    b.doStep(0.0, 1e-3)
    b.doStep(1e-3, 1e-3)
    za = np.array(a.getFloat64([vr["z"]], 4))
    assert np.array_equal(za, np.array(b.getFloat64([vr["z"]], 4))) and np.all(za != 0)
    blob = a.serializeFMUState(a.getFMUState())
    a.doStep(2e-3, 1e-3)
    a.setFMUState(a.deserializeFMUState(blob))
    assert np.array_equal(np.array(a.getFloat64([vr["z"]], 4)), za)
    with pytest.raises(FmuCallError, match="fmi3DoStep .*whole number of sample periods"):
        instances[1].do_step(2e-3, 1.5e-3)
    # the torques against the Python controller over 50 periods of a moving reference
    controller.reset()
    c = slave("c")
    worst = 0.0
    for k in range(50):
        qr = q_ref + 0.01 * np.sin(0.1 * k)
        q, qd = qr - 1e-4 * np.cos(0.2 * k + np.arange(4)), 1e-3 * np.sin(0.3 * k + np.arange(4))
        c.setFloat64([vr["q_ref"], vr["qd_ref"], vr["q"], vr["qd"]], list(np.concatenate([qr, np.zeros(4), q, qd])))
        tau = np.array(c.getFloat64([vr["tau_m"]], 4))
        c.doStep(k * 1e-3, 1e-3)
        py = controller.update(k * 1e-3, q, qd, Reference(qr, np.zeros(4), np.zeros(4)))
        worst = max(worst, float(np.max(np.abs(tau - py) / (1 + np.abs(py)))))
    assert worst <= 1e-12
    for inst in instances:
        inst.close()
    # the C wrapper refuses Model Exchange (the adapter would not even try: no such interface): FMPy's class, on purpose
    me = FMU3Model(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                   instanceName="me")
    with pytest.raises(Exception, match="instantiate"):
        me.instantiate()
    fmu.close()


@pytest.mark.needs("cmake")
def test_fmi3_source_fmu_rebuilds_with_fmpy(tmp_path):
    """FMPy's CMake build of sources/ (buildDescription.xml) gives a binary that simulates identically."""
    import shutil

    from fmpy.build import build_platform_binary
    from fmpy.util import create_zip_archive

    from fmu.simulate import simulate_cs, step_input

    path = fmu_of("scara", 3)
    with open_fmu(path) as fmu:
        unzipped = Path(fmu.extract_to(tmp_path / "unzipped"))
    shutil.rmtree(unzipped / "binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(unzipped, build_dir=tmp_path / "cmake")
    assert (unzipped / "binaries" / "x86_64-linux" / "scara.so").is_file()
    rebuilt = tmp_path / "rebuilt.fmu"
    create_zip_archive(str(rebuilt), str(unzipped))
    names = ["q[1]", "q[2]", "qd[1]", "tool_position[1]"]
    table = step_input([f"tau_m[{i}]" for i in range(1, 5)], np.array([0.0]), np.array([[0.01, -0.02, 0.0, 0.0]]))
    a = simulate_cs(path, 0.2, 1e-3, inputs=table, outputs=names)
    b = simulate_cs(rebuilt, 0.2, 1e-3, inputs=table, outputs=names)
    assert np.max(np.abs(a.stack(names) - b.stack(names))) < 1e-12
    assert np.max(np.abs(a["q[1]"])) > 1e-4           # the torque did move the arm
