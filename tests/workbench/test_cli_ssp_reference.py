"""``manip export-ssp`` takes the reference options of ``manip track``: ``--waypoints FILE`` and ``--trajectory FILE.csv``.

On planar2r: a ``manip retime`` trajectory (2938 samples, so the controller FMU tabulates it at the control instants,
:func:`closed_loop.reference_controller.table_at`) and a TOML waypoint file are exported, copied into the SSP and
run by ``manip validate-ssp`` in libcosim and FMPy against the compiled loop (1e-9 rad). The table holds exactly
the numbers ``manip track`` runs on (its :class:`~closed_loop.schedule.Schedule`, compared bit for bit), and a bad
file gives the very line (exit 2) that ``manip track`` gives.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from closed_loop.reference_controller import MAX_SYMBOLIC_PIECES, table_at
from closed_loop.schedule import Schedule
from closed_loop.ssp_loop import NOTES, REFERENCE_FILE, LoopSpec, loop_reference
from control_design.reference import task_trajectory
from model.robot import load_robot
from model.trajectory_file import read_trajectory
from tests.support.cli import run_cli as _run


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("ssp_reference")
    status, _, err = _run(["retime", "planar2r", "--out", str(folder / "retime"), "--no-plots"])
    assert status == 0, err
    (folder / "ok.toml").write_text("waypoints = [[0, 0], [0.5, 0.3], [0.2, -0.4]]\nsegment_time = 0.4\n")
    return folder


def _export_and_validate(argv: list[str], path: Path) -> str:
    status, out, err = _run(["export-ssp", "planar2r", "--controller", "ct", *argv, "-o", str(path)])
    assert status == 0, err
    status, out, err = _run(["validate-ssp", str(path)])
    assert status == 0, out + err
    assert len([ln for ln in out.splitlines() if ln.rstrip().endswith(" ok")]) == 2  # nominal x 2 importers
    return out


def test_a_trajectory_file_is_exported_copied_and_reproduced(files):
    csv = files / "retime" / "trajectory.csv"
    ssp = files / "traj.ssp"
    out = _export_and_validate(["--trajectory", str(csv)], ssp)
    assert "all runs within 1e-09" in out
    with zipfile.ZipFile(ssp) as zf:
        assert zf.read(REFERENCE_FILE + ".csv") == csv.read_bytes()
        spec = LoopSpec.from_json(zf.read(NOTES).decode(), NOTES)
    assert spec.trajectory == REFERENCE_FILE + ".csv" and spec.task is None and spec.waypoints is None


def test_a_waypoint_file_is_exported_copied_and_reproduced(files):
    toml = files / "ok.toml"
    ssp = files / "waypoints.ssp"
    _export_and_validate(["--waypoints", str(toml)], ssp)
    with zipfile.ZipFile(ssp) as zf:
        assert zf.read(REFERENCE_FILE + ".toml") == toml.read_bytes()
    robot = load_robot("planar2r")
    ours = loop_reference(robot, LoopSpec(kind="ct", waypoints=str(toml)))
    track = task_trajectory(robot, None, str(toml), None)  # what manip track --waypoints reads
    np.testing.assert_array_equal(ours.path.batch(ours.t)[0], track.path.batch(track.t)[0])


def test_the_tabulated_reference_is_what_track_runs_on(files):
    """Bit for bit: the controller FMU's table at every control instant, the Schedule samples manip track's
    simulate_tracking feeds its controller; past the end the end position at rest."""
    robot = load_robot("planar2r")
    traj = read_trajectory(files / "retime" / "trajectory.csv", robot.description)  # manip track --trajectory
    assert traj.path.breaks.size - 1 > MAX_SYMBOLIC_PIECES  # the table, not the symbolic path
    dt = 1e-3
    sched = Schedule.build(robot, traj, dt)
    k = ca.SX.sym("k")
    f = ca.Function("f", [k], list(table_at(robot, traj, dt)(k)))
    for j in list(range(sched.steps + 1)) + [sched.steps + 1, sched.steps + 50]:
        got = [np.asarray(v).ravel() for v in f(float(j))]
        if j <= sched.steps:
            want = (sched.q_ref[j], sched.qd_ref[j], sched.qdd_ref[j])
        else:
            want = (traj.path.q[-1], np.zeros(2), np.zeros(2))
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
    # negative control: one period off is not the same numbers
    assert np.max(np.abs(np.asarray(f(10.0)[0]).ravel() - sched.q_ref[11])) > 0.0


@pytest.mark.parametrize("argv", [
    ["--trajectory", "bad_cols.csv"],
    ["--trajectory", "missing.csv"],
    ["--trajectory", "good.csv", "--segment-time", "1"],
    ["--waypoints", "far.toml"],
    ["--waypoints", "missing.toml"],
])
def test_a_bad_file_gives_the_line_track_gives(argv, files, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    good = (files / "retime" / "trajectory.csv").read_text().splitlines()
    (tmp_path / "good.csv").write_text("\n".join(good) + "\n")
    (tmp_path / "bad_cols.csv").write_text(good[0] + "\n" + ",".join(good[1].split(",")[:5]) + "\n")
    (tmp_path / "far.toml").write_text("waypoints = [[0, 0], [9, 0]]\nsegment_time = 0.5\n")
    track_status, _, track_err = _run(["track", "planar2r", *argv, "--out", "track_out"])
    status, _, err = _run(["export-ssp", "planar2r", "--controller", "ct", *argv, "-o", "loop.ssp"])
    assert track_status == status == 2
    assert len(err.splitlines()) == 1
    assert err.replace("manip export-ssp:", "manip track:") == track_err
    assert not (tmp_path / "loop.ssp").exists()
