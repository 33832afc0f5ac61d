"""``manip track`` writes tracking.csv for any robot; ``--controller cascade`` on the r3 reproduces Dymola's result;
``manip demo --robot manutec_r3`` overlays it and shows the elastic loop's Bode plot (issue 23)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from tests.support import robotr3 as R3
from workbench.cli import main
from workbench.demo import run_demo


def _read(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


def test_track_writes_tracking_csv_beside_metrics(tmp_path):
    out = tmp_path / "track"
    assert main(["track", "scara", "--controller", "pd", "--segment-time", "0.5", "--out", str(out), "--no-plots"]) == 0
    header, data = _read(out / "tracking.csv")
    joints = ["shoulder", "elbow", "quill", "wrist"]
    assert header == ["time"] + [f"{k}_{j}" for k in ("q", "qd", "q_ref", "tau_m") for j in joints]
    replay = np.load(out / "tracking.npz")
    np.testing.assert_array_equal(data[:, 1:5], replay["q"])  # 17 digits: the float64 back exactly
    np.testing.assert_array_equal(data[:, 0], replay["t"])
    assert (out / "metrics.json").is_file()


def test_track_cascade_reproduces_dymolas_fullrobot(tmp_path):
    out = tmp_path / "r3"
    assert main(["track", "manutec_r3", "--controller", "cascade", "--task", "ptp", "--out", str(out),
                 "--no-plots"]) == 0
    header, data = _read(out / "tracking.csv")
    qd = data[:, [header.index(f"qd_axis{i}") for i in range(1, 7)]]
    cmp = R3.compare(data[:, 0], qd)
    assert np.all(cmp.worst < 0.01) and np.all(np.abs(cmp.breakaway[3:]) < 5e-4), (cmp.worst, cmp.breakaway)


def test_cascade_needs_the_cascade_table(tmp_path, capsys):
    assert main(["track", "planar2r", "--controller", "cascade", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "[cascade]" in err[0]


@pytest.mark.slow
def test_demo_of_the_r3_overlays_the_reference_and_shows_the_bode_plot(tmp_path):
    result = run_demo("manutec_r3", tmp_path, gif=False)
    names = {p.name for p in result.files}
    assert {"cascade_bode.png", "cascade_speeds.png", "report.html"} <= names
    text = result.report_md.read_text()
    assert "Largest difference from the reference result" in text and "cascade_bode.png" in text
    assert max(result.max_error["cascade"]) < 0.02  # the MSL loop's own lag along the PTP motion, rad
