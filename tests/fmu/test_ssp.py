"""The closed loop as an SSP 1.0 file: libcosim and FMPy run it and reproduce the compiled closed loop.

The SCARA pick-and-place (15 s, 1 kHz) under computed torque, and under PID (its integrator a sampled state on the
reference's clock, :mod:`closed_loop.reference_controller`), exported with a 2 kg payload variant
(:func:`closed_loop.ssp_loop.export_loop_ssp`), is run unchanged by libcosim
(``CosimExecution.from_ssp_file``, one ``.ssd`` per parameter set) and FMPy
(``fmpy.ssp.simulation.simulate_ssp``, the set passed as read from its ``.ssv``), and compared at every control
instant with the compiled closed loop on the schedule each importer runs (both Jacobi; libcosim moves the
connected values at its initialisation, FMPy starts every connector at 0.0): the compiled kernel with its
one-period delay, and the compiled plant under :class:`~closed_loop.ssp_loop.FmpyStart`. Tolerance
:data:`~closed_loop.ssp_loop.SSP_TOLERANCE` = 1e-9 rad (issue 25): both sides are the same RK4 and the same
law in compiled C, so only rounding separates them (measured ~4e-15).

Negative controls: the 2 kg set differs from the nominal one by far more than the tolerance (and matches the plant
of ``manip track --payload 2``); the compiled loop on the *other* importer's start schedule misses by far more than
the tolerance, so the comparison sees the schedule; the reference inside the controller FMU is the trajectory's;
under PID the compiled loop without the integrator (Ki = 0) misses by far more than the tolerance (and the integrator
of the next period in tau_m instead of this one's, tried by hand, misses by 3e-5 rad), so the FMU's integrator is
the controller's, tick for tick.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from closed_loop.reference_controller import path_at
from closed_loop.simulate import simulate_tracking
from closed_loop.ssp_loop import (NOTES, SSP_TOLERANCE, LoopSpec, LoopVariant, compiled_reference, export_loop_ssp,
                                  loop_parts, validate_loop_ssp, variant_plant)
from control_design.computed_torque import ModelMismatch, plant_with_mismatch
from control_design.controllers import DecentralisedController
from fmu.ssp import NOMINAL, SspComponent, SspConnection, read_parameter_set, run_fmpy, run_libcosim, ssp_variants, \
    write_ssp
from model import InertiaConsistencyWarning, load_robot
from model.errors import InputError

PAYLOAD = LoopVariant("payload_mass=2", {"payload_mass": 2.0})
SPECS = {kind: LoopSpec(kind=kind, task="pick-and-place", variants=(PAYLOAD,)) for kind in ("ct", "pid")}
SPEC = SPECS["ct"]
Q = [f"plant.q[{i + 1}]" for i in range(4)]


@pytest.fixture(scope="module")
def robot():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot("scara")


@pytest.fixture(scope="module")
def loops(robot, tmp_path_factory):
    """kind -> (controller, trajectory, SSP) of :data:`SPECS`, each built once, when first asked for."""
    built: dict[str, tuple] = {}

    def loop(kind: str) -> tuple:
        if kind not in built:
            spec = SPECS[kind]
            controller, trajectory = loop_parts(robot, spec)
            path = tmp_path_factory.mktemp(f"ssp_{kind}") / "loop.ssp"
            built[kind] = (controller, trajectory,
                           export_loop_ssp(robot, controller, trajectory, path, variants=spec.variants, notes=spec))
        return built[kind]

    return loop


@pytest.fixture(scope="module")
def parts(loops):
    return loops("ct")[:2]


@pytest.fixture(scope="module")
def ssp(loops):
    return loops("ct")[2]


def test_the_archive_is_ssp_1_0_with_one_ssd_per_parameter_set(ssp):
    names = zipfile.ZipFile(ssp).namelist()
    assert {"SystemStructure.ssd", "payload_mass=2.ssd", "resources/plant.fmu", "resources/controller.fmu",
            "resources/plant.nominal.ssv", "resources/plant.payload_mass=2.ssv", NOTES} <= set(names)
    assert ssp_variants(ssp) == [NOMINAL, "payload_mass=2"]
    ssd = ET.fromstring(zipfile.ZipFile(ssp).read("SystemStructure.ssd"))
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription"}
    assert ssd.get("version") == "1.0"
    connections = ssd.findall("ssd:System/ssd:Connections/ssd:Connection", ns)
    assert len(connections) == 12  # q, qd (8) to the controller, tau_m (4) to the plant
    # FMPy's reader validates the .ssd and the .ssv against the SSP 1.0 schemas
    from fmpy.ssp.ssd import read_ssd
    read_ssd(str(ssp), validate=True)
    sets = {v: read_parameter_set(ssp, v) for v in ssp_variants(ssp)}
    assert sets[NOMINAL]["plant.payload_mass"] == 0.0 and sets["payload_mass=2"]["plant.payload_mass"] == 2.0
    assert {k for k, v in sets[NOMINAL].items() if sets["payload_mass=2"][k] != v} <= {"plant.payload_mass",
                                                                                        "plant.internal_step"}


@pytest.mark.parametrize("importer", ["libcosim", "fmpy"])
@pytest.mark.parametrize("variant", [NOMINAL, "payload_mass=2"])
@pytest.mark.parametrize("kind", ["ct", "pid"])
def test_each_importer_reproduces_the_compiled_loop(kind, importer, variant, robot, loops):
    controller, trajectory, ssp = loops(kind)
    plant = variant_plant(robot, {} if variant == NOMINAL else PAYLOAD.values)
    ref = compiled_reference(robot, plant, controller, trajectory, importer)
    assert ref.t.size == 15001
    if importer == "fmpy":
        q = run_fmpy(ssp, variant, Q, start=0.0, stop=15.0, step=controller.dt)
    else:
        q = run_libcosim(ssp, variant, Q, steps=15000)
    assert q.shape == (15000, 4)
    assert np.max(np.abs(q - ref.q[1:])) <= SSP_TOLERANCE
    other = compiled_reference(robot, plant, controller, trajectory, "fmpy" if importer == "libcosim" else "libcosim")
    assert np.max(np.abs(q - other.q[1:])) > 1e3 * SSP_TOLERANCE  # negative control: the start schedule matters
    if kind == "pid":  # negative control: the FMU integrates (the same PID with Ki = 0 is far off)
        c = controller
        no_integral = DecentralisedController("pid", c.Kp, c.Kd, np.zeros(4), c.G, c.rate_hz, c.tau_m_max)
        plain = compiled_reference(robot, plant, no_integral, trajectory, importer)
        assert np.max(np.abs(q - plain.q[1:])) > 1e3 * SSP_TOLERANCE


def test_the_payload_set_is_its_own_run_on_the_plant_of_track_payload(robot, parts, ssp):
    controller, trajectory = parts
    track_plant = plant_with_mismatch(robot, ModelMismatch(payload_mass=2.0))  # what manip track --payload 2 runs
    np.testing.assert_array_equal(variant_plant(robot, PAYLOAD.values).parameters.vector,
                                  track_plant.parameters.vector)
    nominal = run_libcosim(ssp, NOMINAL, Q, steps=15000)
    loaded = run_libcosim(ssp, "payload_mass=2", Q, steps=15000)
    assert np.max(np.abs(loaded - nominal)) > 1e-4  # 1.3 mm / mrad: far above the tolerance
    ref = compiled_reference(robot, track_plant, controller, trajectory, "libcosim")
    assert np.max(np.abs(loaded - ref.q[1:])) <= SSP_TOLERANCE
    # manip track --payload 2 itself (no co-simulation delay): the SSP's 2 kg run is within the one-period delay's
    # effect of it (measured 2.7e-5 m on the quill), the nominal run is not (1.3e-3 m away)
    track = simulate_tracking(track_plant, controller, trajectory)
    assert np.max(np.abs(loaded - track.q[1:])) < 1e-4 < np.max(np.abs(nominal - track.q[1:]))


@pytest.mark.parametrize("kind", ["ct", "pid"])
def test_validate_loop_ssp_reports_every_run(kind, loops):
    checks = validate_loop_ssp(loops(kind)[2])
    assert [(c.variant, c.importer) for c in checks] == [(v, i) for v in (NOMINAL, "payload_mass=2")
                                                         for i in ("libcosim", "fmpy")]
    assert all(c.ok and c.samples == 15000 for c in checks)
    assert all(c.from_nominal > 1e-4 for c in checks if c.variant != NOMINAL)


def test_the_controller_reference_is_the_trajectory(parts):
    """The symbolic path (generated into the controller FMU) against JointPath.batch at the schedule's instants,
    the breaks, before the start and after the end (independent: the trajectory's own numeric evaluation)."""
    import casadi as ca

    _, trajectory = parts
    path = trajectory.path
    t = ca.SX.sym("t")
    f = ca.Function("f", [t], list(path_at(path, t)))
    times = np.concatenate([np.arange(0, 15001, 7) * 1e-3, path.breaks, [-1.0, 16.0]])
    want = path.batch(times)
    got = [np.array([np.asarray(f(tt)[j]).ravel() for tt in times]) for j in range(3)]
    for g, w in zip(got, want):
        assert np.max(np.abs(g - w)) <= 1e-12  # the same arithmetic; rounding of the generated expression only


def test_bad_input_is_refused_naming_it(robot, parts, tmp_path):
    controller, trajectory = parts
    with pytest.raises(InputError, match="no plant parameter 'payload'"):
        variant_plant(robot, {"payload": 2.0})
    with pytest.raises(InputError, match="payload mass|payload_mass|>= 0"):
        variant_plant(robot, {"payload_mass": -1.0})
    with pytest.raises(InputError, match="distinct variant names"):
        export_loop_ssp(robot, controller, trajectory, tmp_path / "x.ssp", variants=(LoopVariant(NOMINAL, {}),))
    with pytest.raises(InputError, match=".ssp"):
        write_ssp(tmp_path / "x.zip", "x", [], [], start=0.0, stop=1.0, step=0.1)
    comp = SspComponent("a", tmp_path / "a.fmu", ("u",), ("y",), {})
    with pytest.raises(InputError, match="no such output"):
        write_ssp(tmp_path / "x.ssp", "x", [comp], [SspConnection("a", "u", "a", "y")], start=0.0, stop=1.0, step=0.1)
    (tmp_path / "not.ssp").write_text("no zip")
    with pytest.raises(InputError, match="expected an SSP file"):
        validate_loop_ssp(tmp_path / "not.ssp")
