"""The teach page's logic without a browser: every robot, the IK target, playback, the replay file.

A real viser server is started on 127.0.0.1 and a free port for each page (no
client connects); the page's state is driven through its Python methods and
the numbers it would show are compared with the model's own ``fkine`` and IK
and with an independent construction of roll-pitch-yaw. Cost: ~6 s (a server
start is ~0.3 s; the panda's and ur5's kinematics take the rest), plus one
``manip track`` of the planar2r (its dynamics compiled: ~15 s idle, 33 s under load).
"""

from __future__ import annotations


import numpy as np
import pytest

from model.description import BUILTIN_ROBOTS, rpy_matrix
from model.robot import load_robot
from workbench.replay import Replay, ReplayError, load_replay, save_replay
from workbench.teach import (
    DisplayUnits,
    NEAR_SINGULAR_TOL,
    format_pose,
    is_loopback,
    joint_frames,
    readout,
    start_teach,
)

pytest.importorskip("viser")


@pytest.fixture
def page_of():
    pages = []

    def make(name, **kw):
        page = start_teach(load_robot(name), **kw)
        pages.append(page)
        return page

    yield make
    for page in pages:
        page.stop()


def _table(md: str) -> np.ndarray:
    rows = [line for line in md.splitlines() if line.startswith("| position") or line.startswith("| rpy")]
    return np.array([[float(c) for c in row.strip("|").split("|")[1:]] for row in rows])


@pytest.mark.parametrize("name", BUILTIN_ROBOTS)
def test_every_builtin_page_shows_fkine_of_its_joint_values(name, page_of):
    page = page_of(name)
    robot = page.robot
    rng = np.random.default_rng(7)
    q = page.limits[0] + rng.random(robot.n) * (page.limits[1] - page.limits[0])
    r = page.set_q(q)
    T = robot.fkine(q)
    assert np.array_equal(r.T, T)
    # roll-pitch-yaw rebuilt with the description's own R = Rz(yaw) Ry(pitch) Rx(roll): 1e-12 is round-off
    assert np.abs(rpy_matrix(r.rpy) - T[:3, :3]).max() < 1e-12
    shown = _table(page._pose_md.content)
    assert np.abs(shown[0] - T[:3, 3] * 1000).max() <= 0.005 + 1e-9  # mm, 2 decimals
    assert np.abs(shown[1] - np.degrees(r.rpy)).max() <= 0.005 + 1e-9  # deg, 2 decimals
    # the sliders hold the same values in display units, to their step
    for h, lk, v in zip(page._sliders, robot.description.links, q):
        f = page.units.factor(lk.is_revolute)
        assert abs(h.value - v * f) <= 1e-9 * max(1.0, abs(v * f))


def test_a_urdf_file_gets_a_page(tmp_path):
    from model.loading import load_description
    from model.urdf_export import export_urdf

    export_urdf(load_description("arm4"), tmp_path / "arm.urdf")
    robot = load_robot(tmp_path / "arm.urdf")
    assert robot.description.convention == "urdf"
    page = start_teach(robot)
    try:
        q = np.array([0.1, -0.4, 0.3, 0.2])
        assert np.array_equal(page.set_q(q).T, robot.fkine(q))
        # the URDF's frames put the joint markers on jacob0's axes too
        J = robot.jacob0(q)
        for i, (_, axis) in enumerate(joint_frames(robot, robot.fkine_all(q))):
            assert np.allclose(axis, J[3:, i], atol=1e-12)
    finally:
        page.stop()


def test_joint_markers_sit_on_the_joint_axes():
    """Standard DH: joint i turns about z of frame i-1 at its origin (fkine_all), as joint_frames draws it."""
    robot = load_robot("puma560")
    q = np.array([0.3, -0.7, 0.4, 1.1, -0.5, 0.9])
    T = robot.fkine_all(q)
    for i, (o, axis) in enumerate(joint_frames(robot, T)):
        assert np.allclose(o, T[i][:3, 3], atol=1e-12) and np.allclose(axis, T[i][:3, 2], atol=1e-12)
    # and the revolute axes are jacob0's angular columns (an independent construction of the same axes)
    J = robot.jacob0(q)
    for i, (_, axis) in enumerate(joint_frames(robot, T)):
        assert np.allclose(axis, J[3:, i], atol=1e-12)


def test_near_singularity_is_named():
    robot = load_robot("scara")
    near = readout(robot, [0.2, np.radians(2.0), 1.0, 0.0])  # |sin 2 deg| = 0.035 < 0.05
    assert near.near_singular and "elbow stretched" in near.singularity_text()
    far = readout(robot, [0.2, np.radians(4.0), 1.0, 0.0])  # |sin 4 deg| = 0.070 > 0.05
    assert not far.near_singular and far.singularity_text() == "no singularity near"
    assert NEAR_SINGULAR_TOL == 0.05


def test_target_closed_form_every_branch(page_of):
    page = page_of("scara")
    robot = page.robot
    q_goal = np.array([0.4, 1.1, 1.5, -0.3])
    T = robot.fkine(q_goal)
    page._target.position = T[:3, 3]
    from workbench.teach import _quat_wxyz

    page._target.wxyz = _quat_wxyz(T[:3, :3])
    assert np.allclose(page.target_pose(), T, atol=1e-12)
    page._solve_target()
    labels = tuple(page._branch.options)
    assert len(labels) == 2
    reached = []
    for label in labels:
        page._branch.value = label
        page._solve_target()
        assert np.allclose(robot.fkine(page.q), T, atol=1e-9)  # every branch reaches the target
        reached.append(page.q.copy())
    assert not np.allclose(reached[0], reached[1])  # and they are different arms
    assert any(np.allclose(qq, q_goal, atol=1e-9) for qq in reached)


def test_target_out_of_reach_leaves_the_arm(page_of):
    page = page_of("scara")
    before = page.q.copy()
    page._target.position = (9.0, 0.0, -1.0)
    page._solve_target()
    assert np.array_equal(page.q, before)
    assert "out of reach" in page._ik_md.content


def test_target_numeric_ik_for_a_urdf_robot(page_of):
    page = page_of("ur5")
    assert not page.closed_form and page.robot.description.convention == "urdf"
    q_goal = np.array([0.3, -1.2, 1.4, -0.8, 1.2, 0.5])
    T = page.robot.fkine(q_goal)
    from workbench.teach import _quat_wxyz

    page._target.position, page._target.wxyz = T[:3, 3], _quat_wxyz(T[:3, :3])
    page._solve_target()
    assert "solved" in page._ik_md.content
    assert np.allclose(page.robot.fkine(page.q), T, atol=1e-6)  # ikine's default tolerance reaches this


def test_units_toggle_keeps_si_underneath(page_of):
    page = page_of("scara")
    q = np.array([0.5, -0.25, 2.0, 1.0])
    page.set_q(q)
    page._set_units("rad, m")
    assert [h.value for h in page._sliders] == pytest.approx(q, abs=1e-12)
    shown = _table(page._pose_md.content)
    assert np.abs(shown[0] - page.robot.fkine(q)[:3, 3]).max() <= 5e-6 + 1e-12  # m, 5 decimals
    assert DisplayUnits("rad", "m").factor(True) == 1.0 and DisplayUnits().factor(False) == 1000.0


def test_playback_reaches_the_task_end(page_of):
    t = np.linspace(0.0, 0.3, 31)
    q = np.outer(t / 0.3, [0.5, 0.5, 1.0, 0.2]) + np.array([0.0, 0.0, 1.0, 0.0])
    page = page_of("scara", replays={"ramp": lambda: Replay("ramp", t, q)})
    page.play("ramp")
    page._player.join(timeout=5)
    assert np.allclose(page.q, q[-1])
    assert "t = 0.30 / 0.30 s" in page._play_md.content


def test_replay_round_trip_and_refusals(tmp_path):
    from types import SimpleNamespace

    t = np.arange(5) * 0.01
    q = np.tile([0.1, 0.2, 1.0, 0.0], (5, 1))
    result = SimpleNamespace(t=t, q=q, q_ref=q, robot="scara", controller="ct")
    save_replay(result, tmp_path / "tracking.npz")
    replay = load_replay(tmp_path, "scara", 4)
    assert np.array_equal(replay.t, t) and np.array_equal(replay.q, q) and "ct" in replay.name
    with pytest.raises(ReplayError, match="saved for robot 'scara', not 'planar2r'"):
        load_replay(tmp_path, "planar2r", 4)
    with pytest.raises(ReplayError, match=r"'q': expected float shape \(5, 2\)"):
        load_replay(tmp_path, "scara", 2)
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "tracking.npz").write_bytes(b"not a zip")
    with pytest.raises(ReplayError, match="not a NumPy .npz archive"):
        load_replay(tmp_path / "bad", "scara", 4)
    with pytest.raises(ReplayError, match="no such file"):
        load_replay(tmp_path / "none", "scara", 4)


def test_loopback_rule():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost") and is_loopback("127.3.2.1")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.2") and not is_loopback("example.org")


def test_format_pose_rounds_to_its_digits():
    robot = load_robot("planar2r")
    r = readout(robot, [0.3, 0.4])
    text = format_pose(r, DisplayUnits())
    assert f"{r.T[0, 3] * 1000:.2f}" in text and f"{np.degrees(r.rpy[2]):.2f}" in text


def test_track_saves_the_run_the_page_plays(tmp_path):
    """``manip track --out DIR`` writes DIR/tracking.npz; ``load_replay`` reads back its t and q (the teach button)."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    out = tmp_path / "track"
    res = subprocess.run([sys.executable, "-m", "workbench.cli", "track", "planar2r", "--controller", "pd",
                          "--task", "tour", "--segment-time", "0.3", "--out", str(out)],
                         cwd=Path(__file__).resolve().parents[2], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    replay = load_replay(out, "planar2r", 2)
    metrics = json.loads((out / "metrics.json").read_text())
    assert replay.duration == pytest.approx(metrics["duration_s"], abs=1e-12)
    assert replay.q.shape == (replay.t.size, 2) and np.all(np.isfinite(replay.q))
    assert np.allclose(replay.at(replay.duration), replay.q[-1])
