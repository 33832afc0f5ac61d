"""Without a task, ``manip track`` and ``manip sweep`` follow the robot's reference task and say which.

One rule (``control_design.reference.reference_task_name``, which the design and ``manip demo`` use
too): the robot file's first ``[[tasks]]`` entry, else the generic ``tour``. Today's bug it fixes:
``manip track ur10.toml`` exited 2 asking for a ``pick-and-place`` the file never named.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

from workbench import cli

def _link(a: float, mass: float) -> str:
    return (f'[[links]]\njoint = "revolute"\na = {a}\nalpha = 0.0\nd = 0.0\ntheta = 0.0\nmass = {mass}\n'
            f'com = [{-a / 2}, 0.0, 0.0]\nqlim = [-2.0, 2.0]\n')


ARM = ('name = "two tasks"\n' + _link(0.5, 2.0) + _link(0.4, 1.0)
       + '[[tasks]]\nname = "first"\nsegment_time = 0.2\nwaypoints = [[0.0, 0.0], [0.5, -0.5]]\n'
       + '[[tasks]]\nname = "second"\nwaypoints = [[0.0, 0.0], [-0.5, 0.5], [0.0, 0.0]]\n')


def _track(robot: str, out: Path, *extra: str) -> tuple[int, str, dict]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = cli.main(["track", robot, "--out", str(out), "--no-plots", *extra])
    metrics = json.loads((out / "metrics.json").read_text()) if status == 0 else {}
    return status, err.getvalue(), metrics


def test_a_robot_without_tasks_is_tracked_on_the_tour_and_says_so(tmp_path):
    status, err, metrics = _track("planar2r", tmp_path / "out", "--segment-time", "0.2")
    assert status == 0, err
    assert "manip track: no --task: following 'tour' (the robot file has no [[tasks]]" in err
    assert metrics["task"] == "tour" and abs(metrics["duration_s"] - 0.2 * 3) < 1e-12  # the tour's three segments


def test_a_robot_with_tasks_is_tracked_on_its_first_and_an_explicit_task_says_nothing(tmp_path):
    arm = tmp_path / "arm.toml"
    arm.write_text(ARM)
    status, err, metrics = _track(str(arm), tmp_path / "a")
    assert status == 0, err
    assert "following 'first' (the first [[tasks]] entry of the robot file)" in err
    assert metrics["task"] == "first" and abs(metrics["duration_s"] - 0.2) < 1e-12
    status, err, metrics = _track(str(arm), tmp_path / "b", "--task", "second", "--segment-time", "0.1")
    assert status == 0 and "no --task" not in err and metrics["task"] == "second"


def test_a_sweep_spec_without_a_task_follows_the_same_rule_and_says_so(tmp_path):
    from closed_loop.sweep import run_sweep
    from closed_loop.sweep_spec import spec_from_dict

    arm = tmp_path / "arm.toml"
    arm.write_text(ARM)
    stream = io.StringIO()
    spec = spec_from_dict({"robot": str(arm), "controller": "pd", "samples": 2, "seed": 1,
                           "vary": {"payload_mass": [0.0, 1.0]}})
    result = run_sweep(spec, workers=1, plots=False, stream=stream)
    assert "sweep: no task in the spec: following 'first' (the first [[tasks]] entry" in stream.getvalue()
    assert len(result.table) == 2
