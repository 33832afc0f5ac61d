"""``manip export-ssp`` and ``manip validate-ssp`` end to end on planar2r (short task), with a tampered file as the
negative control: validate-ssp must see a parameter set that is not the one its notes say (exit 1)."""

from __future__ import annotations

import re
import zipfile

import pytest

from tests.support.cli import run_cli as _run


@pytest.fixture(scope="module")
def ssp(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli_ssp") / "loop.ssp"
    status, out, err = _run(["export-ssp", "planar2r", "--controller", "ct", "--segment-time", "0.3",
                             "--variant", "payload_mass=1", "--variant", "payload_mass=0.5,viscous_friction[1]=0.01",
                             "-o", str(path)])
    assert status == 0, err
    assert "parameter sets: nominal, payload_mass=1, payload_mass=0.5_viscous_friction_1_=0.01" in out
    return path


def test_validate_ssp_runs_every_set_in_both_importers(ssp):
    status, out, err = _run(["validate-ssp", str(ssp)])
    assert status == 0, out + err
    rows = [ln for ln in out.splitlines() if ln.rstrip().endswith(" ok")]
    assert len(rows) == 6  # 3 sets x 2 importers
    assert "all runs within 1e-09" in out


def test_a_tampered_parameter_set_fails_validation(ssp, tmp_path):
    bad = tmp_path / "bad.ssp"
    with zipfile.ZipFile(ssp) as src, zipfile.ZipFile(bad, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "resources/plant.nominal.ssv":  # the nominal set now carries a payload
                data = re.sub(rb'(name="payload_mass"><ssv:Real value=")[^"]*', rb"\g<1>0.3", data)
            dst.writestr(item, data)
    status, out, _ = _run(["validate-ssp", str(bad)])
    assert status == 1 and "FAIL" in out


@pytest.mark.parametrize(("argv", "needle"), [
    (["--variant", "payload=2"], "no plant parameter 'payload'"),
    (["--variant", "payload_mass"], "expected NAME=VALUE"),
    (["--variant", "payload_mass=-1"], "payload"),
    (["--controller", "lqr"], "expected one of"),
    (["-o", "loop.zip"], "ending in .ssp"),
])
def test_bad_input_is_one_line_exit_2(argv, needle, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    base = ["export-ssp", "planar2r", "--controller", "ct", "--segment-time", "0.3", "-o", "loop.ssp"]
    status, _, err = _run(base + argv)
    lines = err.splitlines()
    assert status == 2 and len(lines) == 1 and needle in lines[0], err
    assert not (tmp_path / "loop.ssp").exists()
