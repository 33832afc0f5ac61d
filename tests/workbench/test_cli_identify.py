"""``manip excite`` and ``manip identify`` as a user runs them (subprocesses of ``python -m workbench.cli``).

* ``manip excite puma560`` with its defaults: a CSV the shared joint-table reader takes, within every limit,
  starting and ending at rest; stderr says which default limits were used.
* ``manip identify`` on a log made from that excitation with the model's ``rne`` and 1 % torque noise: the
  outputs the issue names, ``identification.json`` with its keys, and an ``identified.toml`` that every command
  takes: info, build, design, track and export-fmu (and, for a URDF robot, ``identified.urdf`` beside it).
* Bad input: one line naming the file, column or flag, exit status 2, nothing written.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from model.identification.excitation import DEFAULT_QD_MAX, DEFAULT_QDD_MAX, POSITION_MARGIN
from model.joint_table import read_joint_table, write_joint_table
from model.robot import load_robot
from model.tasks import finite_limits
from tests.support.identification import excitation, inverse_dynamics_log, robot

REPO = Path(__file__).resolve().parents[2]
JSON_KEYS = {"n_base", "condition_number", "relative_error", "rms_holdout", "relative_error_holdout",
             "base_parameters", "fit"}


def _manip(*argv: str, timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "workbench.cli", *map(str, argv)], cwd=REPO, capture_output=True,
                          text=True, env=dict(os.environ), timeout=timeout)


def test_excite_puma_writes_a_trajectory_within_its_limits(tmp_path):
    out = tmp_path / "excite.csv"
    run = _manip("excite", "puma560", "-o", out)
    assert run.returncode == 0, run.stderr
    assert "states no joint speed limit for " in run.stderr and "using 1 rad/s" in run.stderr
    assert "condition number of the base regressor" in run.stdout
    desc = load_robot("puma560").description
    table = read_joint_table(out, desc.joint_names, ("q", "qd", "qdd"), what="trajectory file")
    lim = finite_limits(desc)
    span = lim[1] - lim[0]
    assert np.all(table["q"] >= lim[0] + POSITION_MARGIN * span - 1e-12)
    assert np.all(table["q"] <= lim[1] - POSITION_MARGIN * span + 1e-12)
    assert np.abs(table["qd"]).max() <= DEFAULT_QD_MAX[0] + 1e-12
    assert np.abs(table["qdd"]).max() <= DEFAULT_QDD_MAX[0] + 1e-12
    for k in (0, -1):
        assert np.abs(table["qd"][k]).max() < 1e-12 and np.abs(table["qdd"][k]).max() < 1e-12
    np.testing.assert_allclose(table["q"][-1], table["q"][0], atol=1e-12)
    assert table.t[-1] == pytest.approx(10.0) and table.t.size == 10001
    assert (tmp_path / "excite.png").is_file()
    # the arm can run it: manip track follows the file (computed torque, motor limits on) without saturating
    track = _manip("track", "puma560", "--controller", "ct", "--trajectory", out, "--no-plots", "--out",
                   tmp_path / "track")
    assert track.returncode == 0, track.stderr
    metrics = json.loads((tmp_path / "track" / "metrics.json").read_text())
    assert max(metrics["saturated_fraction"]) == 0.0
    assert 0.0 < max(metrics["max_error"]) < 1e-2  # rad: tracked, and the motion is really there


@pytest.fixture(scope="module")
def puma_identified(tmp_path_factory):
    """``manip identify puma560`` on a simulated 1 kHz log (q and tau only, 1 % torque noise)."""
    folder = tmp_path_factory.mktemp("identify")
    rob = robot("puma560")
    _, t, q, qd, qdd = excitation("puma560", 2, 1000.0)
    tau, _ = inverse_dynamics_log(rob, q, qd, qdd, noise=0.01, seed=1)
    log = write_joint_table(folder / "log.csv", t, {"q": q, "tau": tau}, rob.description.joint_names)
    run = _manip("identify", "puma560", log, "--out", folder / "id")
    return folder, run


def test_identify_writes_what_the_issue_names(puma_identified):
    folder, run = puma_identified
    assert run.returncode == 0, run.stderr
    out = folder / "id"
    for name in ("identified.toml", "identification.json", "holdout_torques.png", "residual_spectrum.png"):
        assert (out / name).is_file(), name
    data = json.loads((out / "identification.json").read_text())
    assert JSON_KEYS <= set(data)
    assert data["fit"] == "consistent" and data["n_base"] == 58
    assert len(data["rms_holdout"]) == 6 and len(data["base_parameters"]) == 58
    assert {"name", "expression", "value", "std"} <= set(data["base_parameters"][0])
    assert data["relative_error"] < 0.02 and data["relative_error_holdout"] < 0.02
    assert data["preprocessing"]["cutoff_source"] == "spectrum"
    # the console says what was done
    for words in ("cut-off", "from the position spectrum", "to fit and", "held out", "condition number",
                  "rel. error held out", "consistent fit: IPOPT"):
        assert words in run.stdout, words


def test_identified_robot_file_is_taken_by_every_command(puma_identified, tmp_path):
    folder, run = puma_identified
    assert run.returncode == 0, run.stderr
    toml = folder / "id" / "identified.toml"
    identified = load_robot(toml)
    assert identified.n == 6 and identified.description.links[1].mass > 10.0
    for argv in (("info", toml), ("build", toml), ("design", toml, "--out", tmp_path / "design", "--no-plots"),
                 ("track", toml, "--task", "tour", "--out", tmp_path / "track", "--no-plots"),
                 ("export-fmu", toml, "-o", tmp_path / "p.fmu", "--platforms", "host")):
        step = _manip(*argv)
        assert step.returncode == 0, f"{argv[0]}: {step.stderr}"
    assert (tmp_path / "p.fmu").is_file() and (tmp_path / "track" / "metrics.json").is_file()


def test_identified_urdf_robot_loads_with_its_urdf(tmp_path):
    rob = robot("ur5")
    _, t, q, qd, qdd = excitation("ur5", 1, 1000.0)
    tau, _ = inverse_dynamics_log(rob, q, qd, qdd, noise=0.001, seed=2)
    log = write_joint_table(tmp_path / "log.csv", t, {"q": q, "tau": tau}, rob.description.joint_names)
    run = _manip("identify", "ur5", log, "--out", tmp_path / "id", "--no-plots")
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "id" / "identified.urdf").is_file()
    identified = load_robot(tmp_path / "id" / "identified.toml")
    # the identified arm's torques along the log are the log's, to its noise (0.1 % of the peaks)
    got = identified.rne_batch(q[::50], qd[::50], qdd[::50])
    true = rob.rne_batch(q[::50], qd[::50], qdd[::50])
    assert np.linalg.norm(got - true) / np.linalg.norm(true) < 0.01


@pytest.mark.parametrize("argv, words", [
    (("identify", "puma560", "{bad}", "--out", "{out}"), "unknown column 'qdd_joint1'"),
    (("identify", "puma560", "{missing}", "--out", "{out}"), "no such identification data"),
    (("identify", "puma560", "{log}", "--out", "{out}", "--holdout", "1.5"), "--holdout: expected a share"),
    (("identify", "puma560", "{log}", "--out", "{out}", "--cutoff", "900"), "--cutoff: 900.0 Hz is not below"),
    (("identify", "puma560", "{log}", "--out", "{log}"), "--out: expected a directory"),
    (("identify", "ur5", "{log}", "--out", "{out}"), "unknown column 'q_joint1'"),
    (("excite", "puma560", "-o", "{csv}", "--velocity-limit", "-1"), "--velocity-limit: expected limits > 0"),
    (("excite", "puma560", "-o", "{csv}", "--velocity-limit", "inf"), "expected a finite speed limit"),
    (("excite", "puma560", "-o", "{csv}", "--harmonics", "0"), "--harmonics: expected a whole number"),
    (("excite", "puma560", "-o", "{csv}", "--acceleration-limit", "1,2"), "--acceleration-limit: expected 1 or 6 values"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, argv, words):
    names = load_robot("puma560").description.joint_names
    t = np.arange(50) * 1e-3
    log = write_joint_table(tmp_path / "log.csv", t, {"q": np.zeros((50, 6)), "tau": np.zeros((50, 6))}, names)
    bad = write_joint_table(tmp_path / "bad.csv", t, {"q": np.zeros((50, 6)), "qdd": np.zeros((50, 6)),
                                                      "tau": np.zeros((50, 6))}, names)
    paths = {"bad": bad, "log": log, "missing": tmp_path / "none.csv", "out": tmp_path / "out", "csv": tmp_path / "e.csv"}
    run = _manip(*(a.format(**paths) for a in argv))
    assert run.returncode == 2, run.stderr
    lines = [ln for ln in run.stderr.splitlines() if ": error: " in ln]
    assert len(lines) == 1 and words in lines[0], run.stderr
    assert "Traceback" not in run.stderr
    assert not (tmp_path / "out").exists() and not (tmp_path / "e.csv").exists()
