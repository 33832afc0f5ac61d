"""The demo's report as a reader sees it: headless Chromium renders report.html to a PNG that is not blank,
and the page carries none of the defects users reported (raw backticks, the build machine's absolute paths,
clipped blocks, images that do not load, empty folders left behind).

Cost: one ``manip demo --no-gif`` (about 15 s: FMU export and validation) and two Chromium screenshots (~2 s).
"""

from __future__ import annotations

import html.parser
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.support.system_tools import require

REPO = Path(__file__).resolve().parents[2]
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--hide-scrollbars"]


def screenshot(page: Path, png: Path, size: str = "1280,4000") -> Image.Image:
    """Render ``page`` with headless Chromium into ``png`` (the flags of the project's brief)."""
    res = subprocess.run([require("chromium"), *FLAGS, f"--screenshot={png}", f"--window-size={size}", page.resolve().as_uri()],
                         capture_output=True, text=True, timeout=120)
    assert png.is_file(), res.stderr[-2000:]
    return Image.open(png).convert("RGB")


def ink(image: Image.Image) -> float:
    """Fraction of pixels that are not (near) white."""
    a = np.asarray(image.convert("L"))
    return float(np.mean(a < 240))


class _Page(html.parser.HTMLParser):
    """The text outside <pre> and <code>, and every image source."""

    def __init__(self) -> None:
        super().__init__()
        self.text: list[str] = []
        self.images: list[str] = []
        self._raw = 0

    def handle_starttag(self, tag, attrs):
        if tag in ("pre", "code"):
            self._raw += 1
        if tag == "img":
            self.images.append(dict(attrs)["src"])

    def handle_endtag(self, tag):
        if tag in ("pre", "code"):
            self._raw -= 1

    def handle_data(self, data):
        if not self._raw:
            self.text.append(data)


@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "out"
    res = subprocess.run([sys.executable, "-m", "workbench.cli", "demo", "--out", str(out), "--no-gif"], cwd=REPO,
                         capture_output=True, text=True, timeout=900, env=dict(os.environ))
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    return out


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.needs("chromium")
def test_report_renders_to_a_page_that_is_not_blank(demo, tmp_path):
    shot = screenshot(demo / "report.html", tmp_path / "report.png")
    assert shot.size == (1280, 4000)
    assert ink(shot) > 0.05  # text, tables and the first figures
    colours = len(np.unique(np.asarray(shot.resize((320, 1000))).reshape(-1, 3), axis=0))
    assert colours > 50  # plots in colour, not one grey box
    # Negative control: an empty page is caught as blank.
    empty = tmp_path / "empty.html"
    empty.write_text("<!DOCTYPE html><html><body></body></html>")
    assert ink(screenshot(empty, tmp_path / "empty.png", "400,300")) < 0.001


@pytest.mark.slow
def test_report_html_has_none_of_the_reported_defects(demo):
    page = (demo / "report.html").read_text()
    parsed = _Page()
    parsed.feed(page)
    text = "".join(parsed.text)
    assert "`" not in text and "`" not in page  # inline code is <code>, not raw backticks
    assert "<code>manip demo --robot scara</code>" in page
    machine = {str(demo.resolve()), str(demo), str(REPO), str(Path.home()), tempfile.gettempdir() + "/",
               os.environ["MANIP_CACHE_DIR"]}
    for path in sorted(machine):
        assert path not in page, f"absolute path {path!r} in report.html"
        assert path not in (demo / "report.md").read_text()
        assert path not in (demo / "fmu_validation.txt").read_text()
    assert parsed.images and all(not Path(src).is_absolute() and (demo / src).is_file() for src in parsed.images)
    assert "pre.wrap{white-space:pre-wrap" in page and '<pre class="wrap">FMU scara.fmu' in page  # the log wraps
    assert "<table>" in page and '<td class="num">' in page and '<td class="text">' in page
    empty = [p for p in demo.rglob("*") if p.is_dir() and not any(p.iterdir())]
    assert empty == [], f"empty folders left: {empty}"
    assert not (demo / "cosim").exists()


@pytest.mark.slow
def test_report_retime_section_is_faster_and_never_saturates(demo):
    md = (demo / "report.md").read_text().splitlines()
    k = md.index("## Retimed within the limits")
    head = next(i for i in range(k, len(md)) if md[i].startswith("| path | duration [s]"))
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in md[head + 2:head + 4]]
    assert [r[0] for r in rows] == ["straight segments, stopping at each waypoint", "C2 spline, not stopping"]
    for _path, duration, faster, used, _err, peak, saturated in rows:
        assert 3.0 < float(duration) < 4.5 and float(faster) == pytest.approx(15.0 / float(duration), rel=1e-3)
        assert float(used) == pytest.approx(90.0, abs=1e-6)  # the retime uses the margin it was given, exactly
        assert 90.0 < float(peak) < 100.0 and float(saturated) == 0.0  # the feedback fits in the 10 % left


@pytest.mark.slow
def test_report_tables_give_each_number_column_one_format(demo):
    """RMS errors from 1e-7 to 4e-3 in one column: all in scientific notation, not half fixed-point."""
    md = (demo / "report.md").read_text().splitlines()
    k = md.index(next(line for line in md if line.startswith("| joint | unit | RMS error")))
    rows = [line.strip("|").split("|") for line in md[k + 2:k + 6]]
    for col in (2, 3):
        cells = [r[col].strip() for r in rows]
        assert all("e" in c for c in cells) or not any("e" in c for c in cells), cells


def test_inline_code_tables_and_details_render_in_both_formats():
    """The Report blocks on their own (no demo): backticks become <code>, text is escaped, columns align."""
    from workbench.report import Report, inline_html

    assert inline_html("run `manip info <robot>` & see") == "run <code>manip info &lt;robot&gt;</code> &amp; see"
    assert inline_html("no code") == "no code" and inline_html("`a` and `b`") == "<code>a</code> and <code>b</code>"
    rep = Report("t")
    rep.text("see `x`")
    rep.table(["joint", "error"], [["shoulder", 1.5e-4], ["elbow", 0.0031]])
    rep.details("log", "a very long line " * 40)
    page, md = rep.to_html(), rep.to_markdown()
    assert "<p>see <code>x</code></p>" in page and "see `x`" in md  # Markdown keeps the backticks
    assert '<td class="text">shoulder</td><td class="num">1.500e-04</td>' in page
    assert "|:---|---:|" in md  # text column left, number column right
    assert '<details><summary>log</summary><pre class="wrap">' in page
