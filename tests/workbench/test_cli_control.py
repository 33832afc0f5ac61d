"""``manip design`` and ``manip track``: the files and JSON keys they write, and one-line errors with exit status 2."""

from __future__ import annotations

import json

import pytest

from workbench.cli import main

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
REPORT_KEYS = {"Kp_m", "Kd_m", "Ki_m", "crossover", "gain_margin", "phase_margin", "bandwidth", "rise_time", "overshoot",
               "settling_time", "dist_dc_gain_j", "coupling_error_static_j", "coupling_error_bound_j",
               "phase_margin_d", "gain_margin_d", "phase_margin_loss", "phase_margin_loss_zoh"}


def is_png(path) -> bool:
    return path.is_file() and path.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.parametrize("controller", ["pd", pytest.param("ct", marks=pytest.mark.slow)])
def test_design_writes_json_and_plots(tmp_path, capsys, controller):
    out = tmp_path / "design"
    assert main(["design", "scara", "--controller", controller, "--bandwidth", "40", "--rate", "1000", "--out", str(out)]) == 0
    data = json.loads((out / "design.json").read_text())
    assert data["robot"] == "scara" and data["controller"] == controller
    assert data["spec"]["bandwidth_rad_s"] == 40.0 and data["spec"]["rate_hz"] == 1000.0
    assert "rule" in data["torque_limit"] and len(data["torque_limit"]["tau_m_max"]) == 4
    assert [j["model"]["name"] for j in data["joints"]] == ["shoulder", "elbow", "quill", "wrist"]
    for joint in data["joints"]:
        assert REPORT_KEYS <= set(joint["design"])
        assert joint["design"]["bandwidth"] == pytest.approx(40.0, rel=1e-6)
        assert {"min", "mean", "max", "design", "rule"} <= set(joint["model"]["J_eff_m"])
        name = joint["model"]["name"]
        assert is_png(out / f"bode_{name}.png") and is_png(out / f"step_{name}.png")
    assert "shoulder" in capsys.readouterr().out


def test_track_pick_and_place_writes_metrics_and_plots(tmp_path, capsys):
    out = tmp_path / "track"
    assert main(["track", "scara", "--controller", "pd-ff", "--segment-time", "0.5", "--out", str(out)]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert {"controller", "joints", "rms_error", "max_error", "peak_motor_torque"} <= set(metrics)
    assert metrics["controller"] == "pd-ff" and metrics["joints"] == ["shoulder", "elbow", "quill", "wrist"]
    assert metrics["duration_s"] == pytest.approx(2.5)
    assert all(len(metrics[k]) == 4 for k in ("rms_error", "max_error", "peak_motor_torque"))
    for name in ("tracking_error.png", "torques.png", "joints.png"):
        assert is_png(out / name)
    err = capsys.readouterr().err
    assert "track:  50 %" in err and "track: 100 %" in err  # progress on stderr


def test_track_waypoint_file_with_unknown_payload(tmp_path):
    wp = tmp_path / "move.toml"
    wp.write_text("waypoints = [[0.0, 0.0, 1.0, 0.0], [0.5, -0.5, 2.0, 1.0]]\nsegment_time = 1.0\n")
    out = tmp_path / "track"
    assert main(["track", "scara", "--controller", "ct", "--waypoints", str(wp), "--payload", "2", "--out", str(out)]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["payload_kg"] == 2.0 and metrics["plant"] == "2 kg payload unknown to the controller"
    assert metrics["duration_s"] == pytest.approx(1.0)
    assert max(metrics["max_error"]) < 5e-3  # stable: a 2 kg payload costs ~1 mm (see test_tracking_regression)
    # Its effect: compared with the same controller on the exact plant, the quill error grows most.
    assert len(metrics["exact_plant"]["max_error"]) == 4
    assert metrics["max_error_ratio"][2] > 10.0


@pytest.fixture
def outside_limits(tmp_path):
    wp = tmp_path / "far.csv"
    wp.write_text("q1,q2,d3,q4\n0,0,1,0\n0,0,5.0,0\n")
    return wp


@pytest.mark.parametrize("argv, message", [
    (["design", "scara", "--controller", "lqr"], "manip design: error: --controller: expected one of pd, pd-g, pid, pd-ff, ct, got 'lqr'"),
    (["design", "scara", "--bandwidth=-5"], "manip design: error: --bandwidth: expected a positive number of rad/s, got -5.0"),
    (["design", "scara", "--bandwidth", "100", "--rate", "100"],
     "manip design: error: --rate: 100 Hz is too low for a bandwidth of 100 rad/s (15.9 Hz): expected >= 10 x bandwidth in Hz = 159.2 Hz"),
    (["track", "scara", "--rate", "50"], "manip track: error: --rate: 50 Hz is too low for a bandwidth of 50 rad/s"),
    (["track", "scara", "--controller", "pid", "--waypoints", "FAR"], "row 2, joint 3: 5 m outside qlim [0, 3.5]"),
    (["track", "scara", "--payload=-1"], "manip track: error: --payload: expected a mass >= 0 kg, got -1.0"),
    (["track", "nosuchrobot"], "manip track: error: robot 'nosuchrobot': expected a built-in name"),
    (["design", "scara", "--damping", "0"], "manip design: error: --damping: expected a damping ratio in [0.05, 5], got 0.0"),
])
def test_bad_input_is_one_line_and_exit_status_2(tmp_path, capsys, outside_limits, argv, message):
    argv = [str(outside_limits) if a == "FAR" else a for a in argv] + ["--out", str(tmp_path / "out")]
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"manip {argv[0]}: error: ")
    assert message in lines[0]
    assert not (tmp_path / "out" / "metrics.json").exists() and not (tmp_path / "out" / "design.json").exists()
