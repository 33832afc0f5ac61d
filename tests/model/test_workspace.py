"""The reachable workspace against the SCARA's closed form: r = |a1 + a2 e^(i theta2)|, z = -(d3 + d4).

The tool point's distance from the base axis is ``sqrt(a1^2 + a2^2 + 2 a1 a2 cos theta2)``:
``a1 + a2`` at theta2 = 0 and, when the limits let theta2 reach +-pi, ``|a1 - a2|``; with
``|theta2| <= L < pi`` the inner radius is ``sqrt(a1^2 + a2^2 + 2 a1 a2 cos L)``. The height is
``-d3`` over the quill's range. Cost: ~4 s (three SCARAs of 200,000 samples, one CLI run).
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull, Delaunay

from model.robot import load_robot
from model.workspace import reachable_workspace

REPO = Path(__file__).resolve().parents[2]


def _scara(tmp_path: Path, a2: float, theta2_limit: float) -> object:
    text = (REPO / "model/robots/scara.toml").read_text()
    text = text.replace('name = "scara"', 'name = "scara_test"', 1)
    elbow = text.index('name = "elbow"')
    head, tail = text[:elbow], text[elbow:]
    tail = tail.replace("a = 2.0", f"a = {a2!r}", 1).replace("qlim = [-3.14159, 3.14159]",
                                                              f"qlim = [{-theta2_limit!r}, {theta2_limit!r}]", 1)
    path = tmp_path / f"scara_{a2}_{theta2_limit}.toml"
    path.write_text(head + tail)
    return load_robot(path)


def _radii(ws) -> np.ndarray:
    b = ws.top.boundary()
    return np.hypot(b[:, 0] - ws.base[0], b[:, 1] - ws.base[1])


@pytest.mark.parametrize("a2, limit", [(1.2, math.pi), (2.0, 2.5), (1.2, 2.0)])
def test_scara_annulus_radii_match_the_closed_form(tmp_path, a2, limit):
    a1 = 2.0
    robot = _scara(tmp_path, a2, limit)
    ws = reachable_workspace(robot, samples=200_000)
    r_out = a1 + a2
    r_in = math.sqrt(a1 ** 2 + a2 ** 2 + 2 * a1 * a2 * math.cos(limit))
    lo, hi = ws.radius_range
    # Samples never leave the closed-form annulus (round-off 1e-12) and come close to both radii:
    # 200,000 uniform samples put theta2 within ~2e-4 rad of 0 and of the limit, i.e. r within 1e-4 m.
    assert r_in - 1e-12 <= lo <= r_in + 1e-4
    assert r_out - 1e-4 <= hi <= r_out + 1e-12
    # The envelope: every boundary cell centre lies on one of the two circles, within 1.5 cell diagonals
    # (half a cell from the edge to the centre of the cell it crosses, one more where that partly
    # covered cell drew no sample).
    radii = _radii(ws)
    c = 1.5 * ws.top.cell
    on_circle = (np.abs(radii - r_in) <= c) | (np.abs(radii - r_out) <= c)
    assert on_circle.all(), f"boundary cells off both circles: {np.sort(radii[~on_circle])[:5]} (cell {c:.3g} m)"
    assert (np.abs(radii - r_in) <= c).sum() > 50 and (np.abs(radii - r_out) <= c).sum() > 50  # both drawn
    # The hole is there; a convex hull of the same samples (the wrong method) would fill it.
    assert not ws.top.contains(0.0, 0.0) and ws.top.contains(0.5 * (r_in + r_out), 0.0)
    hull = ConvexHull(ws.top.points)
    assert Delaunay(ws.top.points[hull.vertices]).find_simplex([0.0, 0.0]) >= 0
    # Side view: the rectangle r in [r_in, r_out], z in [-3.5, 0] (quill 0..3.5 m), to one cell.
    b = ws.side.boundary()
    cs = 1.5 * ws.side.cell
    edge = (np.minimum(np.abs(b[:, 0] - r_in), np.abs(b[:, 0] - r_out)) <= cs) | \
        (np.minimum(np.abs(b[:, 1] + 3.5), np.abs(b[:, 1])) <= cs)
    assert edge.all()
    assert ws.axisymmetric


def test_builtin_scara_is_a_disc(tmp_path):
    """The seed's SCARA has a1 = a2 = 2 m and |theta2| <= 3.14159: inner radius 4 cos(3.14159 / 2) = 5.3e-6 m."""
    ws = reachable_workspace(load_robot("scara"), samples=200_000)
    assert ws.radius_range[1] == pytest.approx(4.0, abs=1e-4)
    assert ws.top.contains(0.0, 0.0)
    assert ws.height_range[0] == pytest.approx(-3.5, abs=1e-3) and ws.height_range[1] <= 1e-12


def test_negative_control_wrong_link_length_fails(tmp_path):
    """The radius check catches a wrong geometry: a2 = 1.4 m is not the 1.2 m annulus (0.8 to 3.2 m)."""
    ws = reachable_workspace(_scara(tmp_path, 1.4, math.pi), samples=50_000)
    c = 1.5 * ws.top.cell
    radii = _radii(ws)
    assert not ((np.abs(radii - 0.8) <= c) | (np.abs(radii - 3.2) <= c)).all()


def test_manip_workspace_writes_the_figure(tmp_path):
    out = tmp_path / "ws.png"
    res = subprocess.run([sys.executable, "-m", "workbench.cli", "workspace", "planar2r", "-o", str(out),
                          "--samples", "20000"], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert out.stat().st_size > 20_000 and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "distance from the base z axis" in res.stdout
    assert not list(tmp_path.glob(".*.tmp*"))
    bad = subprocess.run([sys.executable, "-m", "workbench.cli", "workspace", "planar2r", "-o", str(tmp_path),
                          "--samples", "20000"], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--output" in bad.stderr
