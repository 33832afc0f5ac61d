"""Everything the README shows is run here, so it cannot rot.

* every ```python block is executed (in a temporary working directory);
* every ``$ manip ...`` line of a ```console block is run through the real
  entry point; lines in a block introduced by "exit status 2" must fail with
  status 2 and a one-line error, all others must succeed; the tour's
  ``manip demo`` line is the end-to-end demo (what ``make demo`` runs), and
  its outputs are checked below;
* every local file the README links to exists.
"""

from __future__ import annotations

import os
import re
import shlex
from pathlib import Path

import pytest

from workbench.cli import main

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text()
BLOCK = re.compile(r"```(\w*)\n(.*?)```", re.S)


def blocks(lang: str) -> list[tuple[str, str]]:
    """(code, the 300 characters of text before it) of every fenced block in ``lang``."""
    return [(m.group(2), README[max(0, m.start() - 300):m.start()]) for m in BLOCK.finditer(README) if m.group(1) == lang]


def console_commands() -> list[tuple[list[str], int]]:
    cmds = []
    for code, before in blocks("console"):
        expected = 2 if "exit status 2" in before else 0
        for line in code.splitlines():
            if line.startswith("$ manip "):
                cmds.append((shlex.split(line[len("$ manip "):]), expected))
    return cmds


def test_readme_gives_the_two_fresh_clone_commands():
    plain = "".join(code for code, _ in blocks(""))
    assert "make demo" in plain and "make test" in plain


@pytest.fixture(scope="module")
def tour(tmp_path_factory):
    """Run every README command once, in order, in one scratch folder; keep (argv, expected, status, stderr)."""
    folder = tmp_path_factory.mktemp("readme")
    cwd = os.getcwd()
    os.chdir(folder)
    results = []
    try:
        for argv, expected in console_commands():
            import contextlib
            import io

            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                status = main(argv)
            results.append((argv, expected, status, err.getvalue()))
    finally:
        os.chdir(cwd)
    return folder, results


def test_console_commands_are_there():
    names = {argv[0] for argv, _ in console_commands()}
    assert {"robots", "info", "design", "track", "export-fmu", "validate-fmu", "demo"} <= names
    assert any(expected == 2 for _, expected in console_commands())


@pytest.mark.slow
def test_every_console_command_exits_as_the_readme_says(tour):
    _, results = tour
    for argv, expected, status, err in results:
        assert status == expected, f"manip {' '.join(argv)}: status {status}, expected {expected}; stderr: {err[-500:]}"
        if expected == 2:
            lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("manip: warning")]
            assert len(lines) == 1 and lines[0].startswith(f"manip {argv[0]}: error: "), err


@pytest.mark.slow
def test_demo_writes_the_report_with_every_section(tour):
    folder, _ = tour
    out = folder / "out"
    html = (out / "report.html").read_text()
    md = (out / "report.md").read_text()
    for section in ("Robot", "Control design", "FMU", "Closed-loop tracking through the FMU", "Retimed within the limits",
                    "Robustness sweep", "Motion"):
        assert f"## {section}" in md
    assert "a [m]" in md and "-62.6111" in md  # the DH table and the motor data
    assert "result: OK" in md  # the FMU validation summary
    images = re.findall(r'<img src="([^"]+)"', html)
    assert any(p.endswith(".gif") for p in images)
    assert any("bode_" in p for p in images) and any("step_" in p for p in images)
    assert any("tracking_error" in p for p in images)
    assert "sweep/heatmap_max_error.png" in images and (out / "sweep" / "results.csv").is_file()
    assert {"retime/straight.png", "retime/blend.png"} <= set(images) and (out / "retime" / "straight.csv").is_file()
    for rel in images:
        assert (out / rel).is_file() and (out / rel).stat().st_size > 1000, rel
    assert (out / "scara.fmu").is_file() and (out / "metrics.json").is_file()


@pytest.mark.slow
def test_design_and_track_tour_outputs(tour):
    folder, _ = tour
    import json

    design = json.loads((folder / "out/design/design.json").read_text())
    assert design["controller"] == "pd" and len(design["joints"]) == 4
    metrics = json.loads((folder / "out/track/metrics.json").read_text())
    assert metrics["controller"] == "ct" and metrics["payload_kg"] == 2.0
    assert len(metrics["max_error"]) == 4


@pytest.mark.slow
def test_python_blocks_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    codes = [code for code, _ in blocks("python")]
    assert codes
    for code in codes:
        exec(compile(code, "README.md", "exec"), {"__name__": "__readme__"})
    assert (tmp_path / "scara.fmu").is_file()


def test_linked_files_exist():
    for link in re.findall(r"\]\(([^)#]+)\)", README):
        if "://" not in link:
            assert (ROOT / link).exists(), link
