"""The FMI-LS-REF experiment every plant FMU carries: layout after the standard, replayed by two importers.

The layout is checked against FMI-LS-REF 1.0.0-beta.1 (modelica/fmi-ls-ref, docs/index.adoc
and schema/fmi3LayeredStandardReferenceManifest.xsd: root ``fmiReferences`` with the three
``fmi-ls`` attributes, ``<Related source role type>``, the role pattern of the schema, the
files in ``extra/org.fmi-standard.fmi-ls-ref``) and the MA-HS-Experiments format it names
(``<Experiments><Experiment startTime stopTime stepSize><Stimuli source/><References source/>``).

The replays are FMPy's own ``simulate_fmu`` on FMPy's own ``read_csv`` of the extracted
files (nothing of ours between the archive and the importer) and libcosim (FMI 2.0).
The reference is the workbench's plant rule, not the FMU: both importers must meet it
within the stated tolerance (1e-9 of max(1, |column|): the same arithmetic, seen at
~1e-17). Negative controls: a payload of 1 g, set at start, breaks the tolerance
(the experiment detects a changed model), and a tampered reference fails ``validate-fmu``'s
check naming the column.
"""

from __future__ import annotations

import re
import zipfile
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from fmu.ls_ref import (LS_REF_DIR, LS_REF_NAME, LS_REF_VERSION, REF_RTOL, compare_with_reference, parse_csv,
                        read_experiment, replay_problems)
from model.errors import InputError

from tests.support.fmu_support import _quiet, build_root, scara_fmu

NS = "{http://fmi-standard.org/fmi-ls-manifest}"
#: The role pattern of fmi3LayeredStandardReferenceManifest.xsd (v1.0.0-beta.1).
ROLE = re.compile(r"(document|requirement|specification|model|parameter|system|testcase|"
                  r"experiment(/(smoke-test|validation|uncertainty-analysis))?|result|method|rationale|report|request|"
                  r"delivery|configuration|signature|serialized-state(/.*)?|meta-data|other)")


@lru_cache(maxsize=None)
def scara3_fmu() -> Path:
    from fmu import export_fmu

    return _quiet(export_fmu, "scara", build_root() / "scara_lsref_fmi3.fmu", fmi_version=3)


def _extract(fmu_path: Path, tmp_path: Path) -> Path:
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(tmp_path / "x")
    return tmp_path / "x" / LS_REF_DIR


@pytest.mark.parametrize("version", [2, pytest.param(3, marks=pytest.mark.fmi3)])
def test_the_layout_follows_fmi_ls_ref(version, tmp_path):
    import xml.etree.ElementTree as ET

    folder = _extract(scara_fmu() if version == 2 else scara3_fmu(), tmp_path)
    manifest = ET.parse(folder / "fmi-ls-manifest.xml").getroot()
    assert manifest.tag == "fmiReferences"
    assert manifest.get(f"{NS}fmi-ls-name") == LS_REF_NAME == "org.fmi-standard.fmi-ls-ref"
    assert manifest.get(f"{NS}fmi-ls-version") == LS_REF_VERSION
    assert manifest.get(f"{NS}fmi-ls-description") == ("Layered Standard providing information on related files "
                                                       "included in an FMU.")   # fixed by the schema
    related = manifest.findall("Related")
    assert related and all(ROLE.fullmatch(r.get("role")) for r in related)
    for r in related:
        assert (folder / r.get("source")).is_file(), r.get("source")   # relative to the manifest
    exp_rel = [r for r in related if r.get("role").startswith("experiment")]
    assert [r.get("type") for r in exp_rel] == ["application/x-ma-hs-experiments"]
    root = ET.parse(folder / exp_rel[0].get("source")).getroot()
    assert root.tag == "Experiments" and root.get("name")
    (exp,) = root.findall("Experiment")
    assert float(exp.get("startTime")) == 0.0 and float(exp.get("stopTime")) == 0.5
    assert float(exp.get("stepSize")) == 1e-3
    for tag in ("Stimuli", "References"):
        assert (folder / exp.find(tag).get("source")).is_file()
    with zipfile.ZipFile(scara_fmu() if version == 2 else scara3_fmu()) as zf:
        assert "documentation/fmi-ls-ref.txt" in zf.namelist()   # recommended by the standard


def _fmpy_replay(fmu_path: Path, folder: Path, **kwargs) -> tuple[float, list[str]]:
    from fmpy import simulate_fmu
    from fmpy.util import read_csv

    exp = read_experiment(fmu_path)
    inputs = read_csv(folder / "tracking_in.csv")
    ref_names = list(read_csv(folder / "tracking_ref.csv").dtype.names[1:])
    result = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", stop_time=exp.stop_time,
                          output_interval=exp.step_size, input=inputs, output=ref_names, **kwargs)
    return compare_with_reference(result, exp)


@pytest.mark.parametrize("version", [2, pytest.param(3, marks=pytest.mark.fmi3)])
def test_fmpy_replays_the_experiment_from_the_extracted_files(version, tmp_path):
    path = scara_fmu() if version == 2 else scara3_fmu()
    folder = _extract(path, tmp_path)
    worst, problems = _fmpy_replay(path, folder)
    assert problems == [] and worst <= 1.0
    # negative control: 1 g of payload is a different model, and the experiment says so
    worst, problems = _fmpy_replay(path, folder, start_values={"payload_mass": 1e-3})
    assert problems and worst > 1.0


def test_libcosim_replays_the_experiment(tmp_path):
    from fmu.cosim import libcosim_unavailable, run_libcosim

    reason = libcosim_unavailable()
    if reason is not None:
        pytest.skip(reason)
    path = scara_fmu()
    exp = read_experiment(path)
    names = list(exp.reference.dtype.names[1:])
    tau_names = list(exp.inputs.dtype.names[1:])
    t_in = exp.inputs["time"]
    U = np.column_stack([exp.inputs[n] for n in tau_names])

    def inputs(t: float) -> np.ndarray:
        # the row in force on [t, t + h): the last row at or before t (a switch's second row wins)
        return U[int(np.searchsorted(t_in, t + 1e-9 * exp.step_size, side="right")) - 1]

    res = run_libcosim(path, stop_time=exp.stop_time, step=exp.step_size, inputs=inputs, input_names=tau_names,
                       output_names=names, instances=("replay",))
    rows = res.values["replay"]
    x0 = np.array([exp.reference[n][0] for n in names])     # libcosim samples after each step; t = 0 is the start
    table = np.zeros(len(res.t) + 1, dtype=[("time", float)] + [(n, float) for n in names])
    table["time"] = np.concatenate([[0.0], res.t])
    for j, n in enumerate(names):
        table[n] = np.concatenate([[x0[j]], rows[:, j]])
    worst, problems = compare_with_reference(table, exp)
    assert problems == [] and worst <= 1.0
    assert np.max(np.abs(exp.reference["q[1]"])) > 1e-2        # the arm moved: the comparison means something


def test_the_tolerance_is_the_stated_share_of_each_column():
    exp = read_experiment(scara_fmu())
    for name in exp.reference.dtype.names[1:]:
        assert exp.tolerances[name] == REF_RTOL * max(1.0, float(np.max(np.abs(exp.reference[name]))))


def _tampered(tmp_path: Path, member: str, edit) -> Path:
    src = scara_fmu()
    out = tmp_path / "tampered.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            zout.writestr(item, edit(data.decode()).encode() if item.filename == member else data)
    return out


def test_validate_fmu_check_fails_on_a_tampered_reference(tmp_path):
    from fmu.validate import ValidationReport, _ls_ref_check

    def shift_last_q2(text: str) -> str:
        lines = text.splitlines()
        cells = lines[-1].split(",")
        cells[2] = repr(float(cells[2]) + 1e-6)
        return "\n".join(lines[:-1] + [",".join(cells)]) + "\n"

    good = ValidationReport(str(scara_fmu()), [], [], {})
    _ls_ref_check(good, str(scara_fmu()), None)
    (check,) = good.checks
    assert check.name == "FMI-LS-REF replay" and check.passed
    bad_path = _tampered(tmp_path, f"{LS_REF_DIR}/tracking_ref.csv", shift_last_q2)
    bad = ValidationReport(str(bad_path), [], [], {})
    _ls_ref_check(bad, str(bad_path), None)
    (check,) = bad.checks
    assert not check.passed and "q[2]: max |replay - reference| = 1.000e-06" in check.what


def test_a_malformed_experiment_is_one_failed_check(tmp_path):
    from fmu.validate import ValidationReport, _ls_ref_check

    path = _tampered(tmp_path, f"{LS_REF_DIR}/tracking_in.csv", lambda text: text.replace("0.01,", "0.01,x", 1))
    report = ValidationReport(str(path), [], [], {})
    _ls_ref_check(report, str(path), None)
    (check,) = report.checks
    assert not check.passed and "tracking_in.csv: line 3 is not 5 finite numbers" in check.what


def test_parse_csv_refuses_bad_tables():
    with pytest.raises(InputError, match="expected a first column"):
        parse_csv('"t","x"\n0,1\n', "f.csv")
    with pytest.raises(InputError, match="time goes back"):
        parse_csv('"time","x"\n1,1\n0,1\n', "f.csv")
    with pytest.raises(InputError, match="line 2 is not 2 finite numbers"):
        parse_csv('"time","x"\n0,nan\n', "f.csv")


def test_replay_problems_via_the_module_passes():
    worst, problems = replay_problems(scara_fmu())
    assert problems == [] and worst <= 1.0


def test_an_internal_step_longer_than_1ms_is_sampled_at_1ms(tmp_path):
    """internal_step 10 ms: the experiment steps 1 ms (the FMU takes one RK4 step of 1 ms per call, the rule too)."""
    from fmu import export_fmu

    path = _quiet(export_fmu, "planar2r", tmp_path / "coarse.fmu", step=1e-2)
    exp = read_experiment(path)
    assert exp.step_size == 1e-3 and exp.reference.shape == (501,)
    worst, problems = replay_problems(path, exp)
    assert problems == [] and worst <= 1.0
