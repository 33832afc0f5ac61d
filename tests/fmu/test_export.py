"""FMU export: the variable table, modelDescription.xml, the binary, the shipped sources, the CLI."""

from __future__ import annotations

import re
import shutil
import subprocess
import warnings
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

import fmu
from fmu.build import C_DIR, FMI_HEADERS, STAMP, build_fmu
from fmu.robot_resource import fmu_robot
from fmu.validate import binary_problems, model_description_problems
from fmu.variables import build_table, derivative_unit, parse_unit, spec_from_plant, trivial_spec
from model import InertiaConsistencyWarning, load_robot
from model.plant import build_plant
from model.version import __version__

from tests.support.fmu_support import build_root, heavy_scara_fmu, planar2r_full_fmu, scara_fmu, trivial_fmu


@pytest.fixture(scope="module")
def scara_table():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot("scara")
    return build_table(spec_from_plant(build_plant(robot), 1e-3))


def _md(path: Path) -> ET.Element:
    with zipfile.ZipFile(path) as zf:
        return ET.fromstring(zf.read("modelDescription.xml"))


# ------------------------------------------------------------------ the table

def test_table_layout_value_references_are_rows(scara_table):
    names = [v.name for v in scara_table.variables]
    assert [v.vr for v in scara_table.variables] == list(range(len(names)))
    assert names[:8] == ["q[1]", "q[2]", "q[3]", "q[4]", "qd[1]", "qd[2]", "qd[3]", "qd[4]"]
    assert names[8:16] == [f"der({n})" for n in names[:8]]
    assert names[16:20] == ["tau_m[1]", "tau_m[2]", "tau_m[3]", "tau_m[4]"]
    # the last parameter, then one event indicator per friction mode (local variables)
    assert names[-5:] == ["internal_step"] + [f"friction_indicator[{i}]" for i in range(1, 5)]
    assert scara_table.vr("tau_m[1]") == 16
    with pytest.raises(KeyError, match="no FMU variable named 'tau'"):
        scara_table.vr("tau")


def test_table_causality_variability_and_units(scara_table):
    by = {v.name: v for v in scara_table.variables}
    assert (by["q[1]"].causality, by["q[1]"].initial, by["q[1]"].start) == ("output", "exact", 0.0)
    assert by["q[3]"].start == 1.0 and by["q[3]"].unit == "m"           # rest configuration, prismatic quill
    assert by["der(qd[1])"].unit == "rad/s2" and by["der(q[3])"].unit == "m/s"
    assert by["der(q[2])"].derivative_of == by["q[2]"].vr
    assert (by["tau_m[2]"].causality, by["tau_m[2]"].unit) == ("input", "N.m")
    assert by["payload_mass"].variability == "tunable" and by["payload_mass"].min == 0.0
    assert by["viscous_friction[1]"].variability == "tunable"
    assert by["coulomb_friction_neg[1]"].max == 0.0
    assert by["gravity[3]"].variability == "fixed" and by["gravity[3]"].start == -9.81
    assert by["internal_step"].variability == "fixed" and by["internal_step"].start == 1e-3
    for name in ("qm[1]", "tool_position[3]", "tool_rpy[2]"):
        assert (by[name].causality, by[name].initial) == ("output", "calculated")


def test_model_structure_from_jacobian_sparsity(scara_table):
    by_vr = {v.vr: v for v in scara_table.variables}
    index = {v.name: v.xml_index for v in scara_table.variables}
    ders = {by_vr[u.vr].name: u.dependencies for u in scara_table.derivatives}
    assert ders["der(q[1])"] == (index["qd[1]"],)                      # qdot = qd, exactly
    assert index["tau_m[1]"] in ders["der(qd[1])"]
    outs = {by_vr[u.vr].name: u.dependencies for u in scara_table.outputs}
    assert outs["q[2]"] == (index["q[2]"],)                            # an output that is the state itself
    assert outs["qm[2]"] == (index["q[2]"],)                            # G q
    initial = {by_vr[u.vr].name: u.dependencies for u in scara_table.initial_unknowns}
    assert index["payload_mass"] in initial["der(qd[1])"]
    assert index["internal_step"] not in initial["der(qd[1])"]


@pytest.mark.parametrize("text, expected", [
    ("N.m.s/rad", {"kg": 1, "m": 2, "s": -1, "rad": -1}),
    ("kg.m2", {"kg": 1, "m": 2}),
    ("m/s^2", {"m": 1, "s": -2}),
    ("kg m^2", {"kg": 1, "m": 2}),
    ("1/s", {"s": -1}),
    ("", {}),
    ("furlong", None),
])
def test_parse_unit(text, expected):
    got = parse_unit(text)
    if expected is None:
        assert got is None
    else:
        assert {k: e for k, e in got.items() if e} == expected


def test_derivative_unit():
    assert [derivative_unit(u) for u in ("rad", "m/s", "m/s2", "")] == ["rad/s", "m/s2", "m/s3", "1/s"]


def test_spec_rejects_bad_input():
    with pytest.raises(ValueError, match="step: expected a positive internal step in s, got 0.0"):
        trivial_spec(0.0)
    with pytest.raises(ValueError, match="n_inputs: expected at least 1 input, got 0"):
        trivial_spec(1e-3, n_inputs=0)


def test_spec_rejects_a_step_below_the_minimum_declared_in_the_xml():
    from fmu.variables import MIN_STEP

    with pytest.raises(ValueError, match=r"step: expected an internal step of at least 1e-06 s "
                                         r"\(the min of internal_step\), got 1e-07"):
        trivial_spec(1e-7)
    table = build_table(trivial_spec(MIN_STEP))
    step = next(v for v in table.variables if v.name == "internal_step")
    assert step.min == MIN_STEP == 1e-6 and step.start == MIN_STEP
    root = ET.fromstring(table.model_description("{guid}", [], "0"))
    xml = next(v for v in root.find("ModelVariables") if v.get("name") == "internal_step")
    assert float(xml.find("Real").get("min")) == MIN_STEP


def test_the_fmi3_description_names_no_fmi2_function(scara_table):
    """One table renders both versions: its words must hold for both (internal_step said "per fmi2DoStep")."""
    text = scara_table.model_description_fmi3("{guid}", [], "0")
    assert "internal_step" in text and "per DoStep call" in text  # negative control: the description is there
    assert "fmi2" not in text.lower()


# ------------------------------------------------------ description and binary

def test_fmpy_validation_has_zero_problems():
    assert model_description_problems(scara_fmu()) == []
    assert model_description_problems(trivial_fmu()) == []
    assert model_description_problems(planar2r_full_fmu()) == []


def test_model_description_capabilities_and_experiment():
    root = _md(scara_fmu())
    for tag in ("ModelExchange", "CoSimulation"):
        node = root.find(tag)
        assert node.get("modelIdentifier") == "scara"
        assert node.get("canGetAndSetFMUstate") == "true" and node.get("canSerializeFMUstate") == "true"
        assert node.get("providesDirectionalDerivative") == "true"
        files = [f.get("name") for f in node.find("SourceFiles")]
        # the wrapper, the plant's fixed-step rule (model/dynamics/c/plant_step.c), the generated model
        assert files == ["fmi2_functions.c", "instance.c", "plant_step.c", "model_data.c", "scara_casadi.c"]
    assert root.find("CoSimulation").get("canHandleVariableCommunicationStepSize") == "true"
    assert root.find("DefaultExperiment").get("stepSize") == "0.001"
    assert root.get("variableNamingConvention") == "structured"
    assert root.get("generationTool") == f"manipulator-workbench {__version__}"  # the one version
    assert {u.get("name") for u in root.find("UnitDefinitions")} >= {"rad", "m", "N.m", "kg.m2", "rad/s2"}
    assert fmu_robot(scara_fmu()) == ("scara", "reflected")
    assert fmu_robot(trivial_fmu()) is None


def test_binary_exports_only_fmi2_and_needs_only_libc_and_libm():
    problems, facts = binary_problems(scara_fmu())
    assert problems == []
    assert facts["exports"] == 44                      # every FMI 2.0 function for ME and CS, nothing else
    assert set(facts["needed"]) <= {"libc.so.6", "libm.so.6"}


def test_generated_files_are_stamped_and_the_standard_headers_are_shipped():
    with zipfile.ZipFile(scara_fmu()) as zf:
        names = set(zf.namelist())
        for generated in ("sources/model_data.c", "sources/model_data.h", "sources/mw_limits.h", "sources/scara_casadi.c",
                          "sources/scara_casadi.h", "modelDescription.xml"):
            assert STAMP in zf.read(generated).decode()[:400], generated
        header = zf.read("sources/model_data.h").decode()
    assert {f"sources/{h}" for h in FMI_HEADERS[2]} <= names
    assert "binaries/linux64/scara.so" in names
    # the standard headers, which honour FMI2_FUNCTION_PREFIX (FMPy's copies drop the prefix), licence kept
    with zipfile.ZipFile(scara_fmu()) as zf:
        functions_h = zf.read("sources/fmi2Functions.h").decode()
    assert "#define fmi2FullName(name) fmi2PasteB(FMI2_FUNCTION_PREFIX, name)" in functions_h
    assert "2-Clause BSD License" in functions_h
    assert "#define MW_VR_tau_m_1 16u /* tau_m[1] */" in header


def test_value_references_agree_between_header_and_xml():
    root = _md(scara_fmu())
    with zipfile.ZipFile(scara_fmu()) as zf:
        header = zf.read("sources/model_data.h").decode()
    macros = {m.group(3): int(m.group(2)) for m in re.finditer(r"#define MW_VR_(\w+) (\d+)u /\* (.+?) \*/", header)}
    xml = {v.get("name"): int(v.get("valueReference")) for v in root.find("ModelVariables")}
    assert macros == xml


@pytest.mark.needs("cmake")
def test_rebuild_from_sources_with_fmpy_gives_the_same_results(tmp_path):
    """FMPy's `compile` path (CMake on sources/) rebuilds a binary that simulates identically."""
    from fmpy.build import build_platform_binary
    from fmpy.util import create_zip_archive

    from fmu.simulate import simulate_cs

    from fmu.opened import open_fmu

    with open_fmu(scara_fmu()) as opened:
        unzipped = Path(opened.extract_to(tmp_path / "unzipped"))
    shutil.rmtree(unzipped / "binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(unzipped, build_dir=tmp_path / "cmake")
    rebuilt = tmp_path / "rebuilt.fmu"
    create_zip_archive(str(rebuilt), str(unzipped))
    names = ["q[1]", "q[2]", "qd[1]", "tool_position[1]"]
    start = {"tau_m[1]": 0.01, "tau_m[2]": -0.02}
    a = simulate_cs(scara_fmu(), 0.2, 1e-3, outputs=names, start_values=start)
    b = simulate_cs(rebuilt, 0.2, 1e-3, outputs=names, start_values=start)
    assert np.max(np.abs(a.stack(names) - b.stack(names))) < 1e-12
    assert np.max(np.abs(a["q[1]"])) > 1e-4           # the torque did move the arm


def test_deterministic_guid_and_bad_path():
    first = fmu.export_trivial_fmu(build_root() / "again" / "trivial.fmu")
    assert _md(first).get("guid") == _md(trivial_fmu()).get("guid")
    with pytest.raises(ValueError, match=r"path: expected a file name ending in \.fmu, got '.*trivial\.zip'"):
        build_fmu(trivial_spec(), build_root() / "trivial.zip")


def test_second_robot_full_motor_model_and_step():
    root = _md(planar2r_full_fmu())
    step = next(v for v in root.find("ModelVariables") if v.get("name") == "internal_step")
    assert step.find("Real").get("start") == "0.0005"
    assert fmu_robot(planar2r_full_fmu()) == ("planar2r", "full")
    assert len(root.find("ModelStructure").find("Derivatives")) == 4


def test_cli_export_fmu(tmp_path, capsys):
    from workbench.cli import main

    out = tmp_path / "cli" / "planar2r.fmu"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        status = main(["export-fmu", "planar2r", "-o", str(out), "--step", "2e-3", "--platforms", "host"])
    printed = capsys.readouterr()
    assert status == 0 and out.is_file()
    assert "generating C with casadi.CodeGenerator" in printed.err and f"wrote {out}" in printed.out
    assert "x86_64-linux: planar2r.so built in" in printed.err and "windows" not in printed.err  # the default: test_fmu_cross
    assert model_description_problems(out) == []


def test_cli_export_fmu_rejects_a_bad_step(capsys):
    from workbench.cli import main

    assert main(["export-fmu", "scara", "-o", "x.fmu", "--step", "-1"]) == 2  # argparse's refusal, in one line
    [line] = capsys.readouterr().err.splitlines()
    assert line.startswith("manip export-fmu: error: argument --step: expected a positive finite step in s, got '-1'")
    assert main(["export-fmu", "scara", "-o", "x.fmu", "--step", "1e-7"]) == 2
    assert "expected an internal step of at least 1e-06 s, got '1e-7'" in capsys.readouterr().err


def test_export_leaves_the_working_directory_alone(tmp_path, monkeypatch):
    """os.chdir is process-wide: two exports in two threads must not move each other's cwd."""
    import os

    def no_chdir(path):
        raise AssertionError(f"os.chdir({path!r}) during an export")

    cwd = os.getcwd()
    monkeypatch.setattr(os, "chdir", no_chdir)
    path = fmu.export_trivial_fmu(tmp_path / "trivial.fmu")
    assert os.getcwd() == cwd
    with zipfile.ZipFile(path) as zf:
        assert {"sources/trivial_casadi.c", "sources/trivial_casadi.h"} <= set(zf.namelist())


@pytest.mark.parametrize("system", ["Darwin", "Windows"])
def test_export_outside_linux_is_refused_with_a_clear_error(system, tmp_path, monkeypatch):
    import platform

    from fmu.build import FmuBuildError, binary_platform

    monkeypatch.setattr(platform, "system", lambda: system)
    message = rf"FMU export is supported on Linux \(linux64\) only; got {system}\b.*sources/"
    with pytest.raises(FmuBuildError, match=message):
        binary_platform()
    with pytest.raises(FmuBuildError, match=message):
        fmu.export_trivial_fmu(tmp_path / "trivial.fmu")
    with pytest.raises(FmuBuildError, match=message):
        fmu.export_fmu("planar2r", tmp_path / "planar2r.fmu")
    assert not any(tmp_path.iterdir())


def test_the_description_digest_is_recorded_and_a_modified_robot_is_reloaded_from_the_fmu(tmp_path):
    """The mass-scaled SCARA keeps the name scara: its FMU's own description is reloaded (digest checked); an
    FMU without the embedded description (an older export) falls back on the built-in name and is refused."""
    from fmu.robot_resource import fmu_robot_digest, reload_fmu_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        scara = load_robot("scara")
        assert fmu_robot_digest(scara_fmu()) == scara.description.digest()
        assert reload_fmu_robot(scara_fmu()).description.digest() == scara.description.digest()
        digest = fmu_robot_digest(heavy_scara_fmu())
        assert digest is not None and digest != scara.description.digest()
        assert reload_fmu_robot(heavy_scara_fmu()).description.digest() == digest
        stripped = tmp_path / "no_resource.fmu"
        with zipfile.ZipFile(heavy_scara_fmu()) as src, zipfile.ZipFile(stripped, "w") as dst:
            for item in src.infolist():
                if item.filename != "resources/robot.json":
                    dst.writestr(item, src.read(item.filename))
        with pytest.raises(ValueError, match=rf"the FMU was built from a modified description \(digest {digest[:12]}"):
            reload_fmu_robot(stripped)
    assert fmu_robot_digest(trivial_fmu()) is None


def test_wrapper_compiles_cleanly_with_pedantic_warnings(tmp_path):
    """The hand-written wrapper and the plant's fixed-step rule it calls also compile with -Wpedantic -Wshadow
    -Wstrict-prototypes."""
    from fmu.build import fmi_headers_dir
    from model.codegen import C_DIR as MODEL_C_DIR

    from fmu.limits import write_limits_h

    write_limits_h(tmp_path)  # the generated MW_MAX_SUBSTEPS, MW_SUBSTEP_RTOL
    for source in (C_DIR / "fmi2_functions.c", C_DIR / "instance.c", MODEL_C_DIR / "plant_step.c"):
        proc = subprocess.run(["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Wshadow",
                               "-Wstrict-prototypes", "-Werror", f"-I{C_DIR}", f"-I{MODEL_C_DIR}", f"-I{tmp_path}",
                               f"-I{fmi_headers_dir()}", "-c", str(source), "-o", str(tmp_path / "x.o")],
                              capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr


# ------------------------------------------------------- refused at export time

def _planar2r_with_link2(tmp_path, **link2) -> Path:
    """planar2r.toml with link 2's fields replaced (written to a file, so errors name it)."""
    from model.description import BUILTIN_DIR

    text = (BUILTIN_DIR / "planar2r.toml").read_text()
    head, first, second = text.split("[[links]]")
    for key, value in link2.items():
        second = re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", second)
    path = tmp_path / "planar2r_mod.toml"
    path.write_text(head + "[[links]]" + first + "[[links]]" + second)
    return path


@pytest.mark.parametrize("link2", [
    # massless link 2 without motor inertia: B's row and column 2 are zero
    {"mass": 0.0, "inertia": "[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]", "motor_inertia": 0.0, "rotor_mass": 0.0},
    # mass on the joint 2 axis, no inertia about it, no motor: joint 2 moves nothing
    {"com": "[-1.0, 0.0, 0.0]", "inertia": "[0.1, 10.0, 0.0, 0.0, 0.0, 0.0]", "motor_inertia": 0.0},
])
def test_a_robot_with_a_singular_inertia_matrix_is_refused_at_export(tmp_path, link2):
    """A singular B(q) would make the FMU's derivatives non-finite: refused, one line naming the joint."""
    from fmu.export_checks import SingularInertiaError, check_inertia

    path = _planar2r_with_link2(tmp_path, **link2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot(str(path))
        # the reference: B(q) itself is singular, and joint 2's diagonal entry is (numerically) zero
        B = robot.inertia(robot.q_rest)
        assert abs(B[1, 1]) < 1e-12 * np.abs(B).max()
        message = rf"^{re.escape(str(path))}, link 2: the inertia matrix B\(q\) is singular .*joint 2 moves no mass"
        with pytest.raises(SingularInertiaError, match=message):
            check_inertia(robot)
        with pytest.raises(SingularInertiaError, match=message):
            fmu.export_fmu(robot, tmp_path / "singular.fmu")
    assert not (tmp_path / "singular.fmu").exists()
    assert isinstance(SingularInertiaError("x"), ValueError)


def test_cli_export_of_a_singular_robot_exits_2_with_one_line(tmp_path, capsys):
    from workbench.cli import main

    path = _planar2r_with_link2(tmp_path, mass=0.0, inertia="[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]", motor_inertia=0.0,
                                rotor_mass=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        status = main(["export-fmu", str(path), "-o", str(tmp_path / "x.fmu")])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert len(err) == 1 and "link 2: the inertia matrix B(q) is singular" in err[0]


def test_the_real_robots_pass_the_inertia_check():
    from fmu.export_checks import check_inertia

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        for name in ("scara", "planar2r", "planar3r", "arm4", "spherical", "puma560"):
            check_inertia(load_robot(name))
