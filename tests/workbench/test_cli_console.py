"""The console of ``manip``: exact numbers in ``info``, tables sized to their content, torque limits with
their provenance, saturation said out loud, ``--no-plots``. Through the real ``manip`` command."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from closed_loop.result import _longest_run
from workbench.formatting import format_column, format_table

REPO = Path(__file__).resolve().parents[2]
LONG = "a_wrist_joint_with_a_very_long_name"

#: A two-link arm whose numbers a 4-decimal table would round away, one motor rated in the file.
ROBOT = f"""
name = "awkward"
gravity = [0.0, 0.0, -9.81]
[[links]]
name = "shoulder"
joint = "revolute"
a = 0.30000000000000004
alpha = -1.5707963267948966
d = 0.3333333333333333
theta = 1.0000000000000002e-05
mass = 2.0
com = [0.1, 0.0, 0.0]
inertia = [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]
motor_inertia = 1e-4
gear_ratio = 50.0
torque_limit = 0.123456789
[[links]]
name = "{LONG}"
joint = "revolute"
a = 0.25
alpha = 0.0
d = 0.0
theta = 0.0
mass = 1.0
com = [0.1, 0.0, 0.0]
inertia = [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]
motor_inertia = 1e-4
gear_ratio = 50.0
"""


def _manip(*argv: str, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "workbench.cli", *argv], cwd=REPO, capture_output=True, text=True,
                          env=dict(os.environ), timeout=timeout)


@pytest.fixture()
def awkward(tmp_path) -> Path:
    path = tmp_path / "awkward.toml"
    path.write_text(ROBOT)
    return path


def _table(lines: list[str], heading: str) -> list[str]:
    """The header line containing ``heading`` and the rows below it, up to the next blank line."""
    k = next(i for i, line in enumerate(lines) if heading in line)
    rows = []
    for line in lines[k:]:
        if not line.strip():
            break
        rows.append(line)
    return rows


def test_info_prints_the_file_numbers_exactly_with_link_names_and_limit_sources(awkward):
    res = _manip("info", str(awkward))
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    links = tomllib.loads(ROBOT)["links"]  # the reference: the TOML as tomllib reads it
    dh = _table(lines, "alpha [rad]")
    header = dh[0]
    for row, link in zip(dh[1:], links):
        cells = row.split()
        assert cells[1] == link["name"]
        a, alpha, d, theta = (float(cells[k]) for k in (3, 4, 6, 7))
        assert (a, alpha, d, theta) == (link["a"], link["alpha"], link["d"], link["theta"])  # bit for bit
    # The values really need the full repr: 4 decimals (the old table) would not read back.
    assert float(f"{links[0]['a']:.4f}") != links[0]["a"] and float(f"{links[0]['d']:.4f}") != links[0]["d"]
    # The long name widens its column: every row's "type" cell starts where the header's does.
    col = header.index("type")
    assert all(row[col:].startswith("revolute") for row in dh[1:]), dh
    limits = _table(lines, "tau_max [N m]")
    assert float(limits[1].split()[2]) == 0.123456789 and "robot file (awkward.toml: torque_limit)" in limits[1]
    assert LONG in limits[2] and "default rule" in limits[2] and "robot file" not in limits[2]


def test_design_states_each_limit_and_its_source_and_no_plots_writes_no_png(awkward, tmp_path):
    out = tmp_path / "design"
    res = _manip("design", str(awkward), "--bandwidth", "20", "--out", str(out), "--no-plots")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in out.iterdir()) == ["design.json"]
    data = json.loads((out / "design.json").read_text())
    lim = data["torque_limit"]
    assert lim["source"] == ["robot file", "default rule"] and lim["tau_m_max"][0] == 0.123456789
    assert [j["tau_m_max_source"] for j in data["joints"]] == ["robot file", "default rule"]
    rows = _table(res.stdout.splitlines(), "limit from")
    assert "robot file awkward.toml" in rows[1] and "default rule (2x headroom" in rows[2]


def test_a_saturating_run_says_which_motor_how_long_and_where_its_limit_comes_from(tmp_path):
    """Computed torque on the pick-and-place at 0.5 s a segment asks far more than the default limits."""
    out = tmp_path / "track"
    res = _manip("track", "scara", "--controller", "ct", "--segment-time", "0.5", "--out", str(out), "--no-plots")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in out.iterdir()) == ["metrics.json", "tracking.csv", "tracking.npz"]  # --no-plots: no PNG; the replay and the CSV stay
    met = json.loads((out / "metrics.json").read_text())
    warnings = [line for line in res.stderr.splitlines() if line.startswith("manip track: warning: motor")]
    saturated = [j for j, f in enumerate(met["saturated_fraction"]) if f > 0]
    assert saturated and len(warnings) == len(saturated)  # one line per saturated motor, none for the others
    for line, j in zip(warnings, saturated):
        assert f"motor {j + 1} ({met['joints'][j]}) at its torque limit {met['tau_m_max'][j]:.4g} N m" in line
        assert f"{100 * met['saturated_fraction'][j]:.1f} % of the run" in line
        assert f"longest {met['saturated_longest_s'][j]:.3g} s" in line and "limit from the default rule" in line
        # The longest stretch lies within the run and is no longer than the saturated time.
        assert 0 < met["saturated_longest_s"][j] <= met["saturated_fraction"][j] * met["duration_s"] + 1e-3 + 1e-12
    for j in set(range(4)) - set(saturated):
        assert met["saturated_longest_s"][j] == 0.0 and met["saturated_longest_start_s"][j] is None


def test_an_unsaturated_run_prints_no_saturation_warning(tmp_path):
    """Negative control of the test above: the same command on the seed's timing (3 s a segment) is silent."""
    res = _manip("track", "scara", "--controller", "ct", "--out", str(tmp_path / "t"), "--no-plots")
    assert res.returncode == 0, res.stderr
    assert "warning: motor" not in res.stderr


@pytest.mark.parametrize("seed", range(5))
def test_longest_run_matches_a_plain_loop(seed):
    mask = np.random.default_rng(seed).random(200) < 0.6
    best = (0, 0)
    k = 0
    while k < mask.size:  # reference: walk the runs one sample at a time
        if mask[k]:
            start = k
            while k < mask.size and mask[k]:
                k += 1
            if k - start > best[0]:
                best = (k - start, start)
        k += 1
    assert _longest_run(mask) == best
    assert _longest_run(np.zeros(5, dtype=bool)) == (0, 0) and _longest_run(np.ones(5, dtype=bool)) == (5, 0)


def test_one_number_format_per_column():
    assert format_column([1.68e-4, 3.678e-4, 0.003656, 7.7e-7]) == ["1.680e-04", "3.678e-04", "3.656e-03", "7.700e-07"]
    assert format_column([76.35, 74.7, 75.94]) == ["76.35", "74.70", "75.94"]
    assert format_column([0.0, 3.0, 15.0]) == ["0", "3", "15"]
    assert format_column([0.0, 1.5707963, 1.0]) == ["0.000", "1.571", "1.000"]
    assert format_column([171.0, 0.08108]) == ["1.710e+02", "8.108e-02"]  # more than two decades apart
    assert format_column(["inf", 29.2, float("nan")]) == ["inf", "29.20", "nan"]


def test_console_tables_size_their_columns_to_the_content():
    text = format_table(["joint", "RMS error"], [["shoulder", 1e-3], [LONG, 2.5e-2]])
    lines = text.splitlines()
    assert len({len(line) for line in lines}) == 1  # right-aligned last column: every line as wide
    assert lines[2].startswith(LONG + "  ") and lines[1].split() == ["shoulder", "0.001000"]


def test_a_run_past_its_limits_without_clipping_says_so(tmp_path):
    """--no-saturation: nothing is clipped, so nothing "saturates"; the motors asked for more are still named."""
    out = tmp_path / "t"
    res = _manip("track", "scara", "--controller", "ct", "--segment-time", "0.5", "--no-saturation", "--no-plots",
                 "--out", str(out))
    assert res.returncode == 0, res.stderr
    met = json.loads((out / "metrics.json").read_text())
    limit = met["torque_limit"]["tau_m_max"]
    over = [j for j in range(4) if met["peak_motor_torque"][j] > limit[j]]
    lines = [line for line in res.stderr.splitlines() if "warning: motor" in line]
    assert over and len(lines) == len(over)
    for line, j in zip(lines, over):
        assert f"motor {j + 1} ({met['joints'][j]}) peaks at {met['peak_motor_torque'][j]:.4g} N m" in line
        assert "(not clipped)" in line and "default rule" in line
