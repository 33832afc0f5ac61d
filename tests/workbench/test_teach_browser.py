"""``manip teach`` in a real browser, and what it listens on.

The real ``manip teach`` runs in a subprocess; headless Chromium (Debian's
``chromium`` and ``chromium-driver``, driven by Selenium) opens the page, moves
joint sliders with the keyboard (as a user does: arrow keys on the slider
thumb, one step each), reads the slider values and the tool pose the page
displays, and the test compares that pose with ``fkine`` of those slider
values. psutil lists the server's sockets: every one is on a loopback address,
and none is left after Ctrl-C, SIGTERM or a kill (looked for among the command's own processes, marked
through their environment: :mod:`tests.support.process_tree`; other programs may reuse the port).

Cost: about 15 s on an idle 2-core machine (Chromium start ~1 s, page load ~4 s, each key
press a round trip through the server, each ``manip teach`` start ~2 s); under a load of 10
the browser test alone takes ~40 s.
"""

from __future__ import annotations

import ipaddress
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from model.description import rpy_matrix
from model.robot import load_robot

from tests.support.process_tree import alive, interruptible, listening_ports, marked_env
from tests.support.system_tools import require

REPO = Path(__file__).resolve().parents[2]
URL = re.compile(r"at (http://127\.0\.0\.1:(\d+)/)")

psutil = pytest.importorskip("psutil", reason="psutil is in the test extra")


def _start(*argv: str) -> tuple[subprocess.Popen, str, int, str]:
    """``manip teach ... --no-browser`` started with a mark (:func:`marked_env`); the process, URL, port, mark."""
    env, mark = marked_env()
    proc = subprocess.Popen([sys.executable, "-m", "workbench.cli", "teach", *argv, "--no-browser"], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=interruptible)
    line = proc.stdout.readline()  # the address line, printed once the server listens
    match = URL.search(line)
    if match is None:
        proc.kill()
        raise AssertionError(f"no address line from manip teach: {line!r} {proc.stderr.read()!r}")
    return proc, match.group(1), int(match.group(2)), mark


def _sockets(pid: int) -> list:
    return psutil.Process(pid).net_connections(kind="inet")


def _assert_loopback_only(pid: int, port: int) -> None:
    conns = _sockets(pid)
    listening = [c for c in conns if c.status == psutil.CONN_LISTEN]
    assert [c.laddr.port for c in listening] == [port], f"expected one listener on {port}, got {listening}"
    for c in conns:
        assert ipaddress.ip_address(c.laddr.ip).is_loopback, f"socket bound off loopback: {c}"
        if c.raddr:
            assert ipaddress.ip_address(c.raddr.ip).is_loopback, f"connection to a remote address: {c}"


def _communicate(proc: subprocess.Popen) -> tuple[str, str]:
    """Its output once it ends; one that does not end within 20 s is killed (no server left behind) and fails."""
    try:
        return proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise AssertionError("manip teach did not stop within 20 s of the signal; killed") from None


def _left_listening(mark: str) -> set[int]:
    """The ports the command's own processes still listen on, once they are given 20 s to end."""
    deadline = time.monotonic() + 20
    while alive(mark) and time.monotonic() < deadline:
        time.sleep(0.1)
    return listening_ports(mark)


def _browser(tmp_path: Path):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = require("chromium")
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1100,750",
                 f"--user-data-dir={tmp_path / 'chromium-profile'}"):
        opts.add_argument(flag)
    return webdriver.Chrome(service=Service(require("chromedriver")), options=opts)


def _wait(predicate, timeout: float, what: str):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value is not None and value is not False and (not isinstance(value, list) or value):
            return value
        time.sleep(0.1)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def _shown_pose(driver) -> np.ndarray | None:
    """(6,) the displayed x y z (mm) and roll pitch yaw (deg), read from the page's pose table."""
    from selenium.webdriver.common.by import By

    cells = [td.text for td in driver.find_elements(By.CSS_SELECTOR, "td")]
    try:
        i, j = cells.index("position [mm]"), cells.index("rpy [deg]")
        return np.array([float(v) for v in cells[i + 1:i + 4] + cells[j + 1:j + 4]])
    except (ValueError, IndexError):
        return None


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.needs("chromium", "chromedriver")
def test_slider_moves_the_pose_the_page_shows_equals_fkine(tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    pytest.importorskip("selenium", reason="selenium is in the test extra")
    robot = load_robot("scara")
    proc, url, port, mark = _start("scara")
    driver = None
    try:
        _assert_loopback_only(proc.pid, port)
        driver = _browser(tmp_path)
        driver.get(url)
        sliders = _wait(lambda: driver.find_elements(By.CSS_SELECTOR, "[role=slider]"), 30, "the joint sliders")
        assert len(sliders) == robot.n
        # As a user does, with the keyboard on each slider thumb (Home/End: to a limit; an arrow: one step of
        # 0.1 deg or 1 mm): shoulder 179.8 deg, elbow -179.8 deg (folded back: near a singularity), quill 3500 mm.
        # Few keys: each is a render of the 3-D view in software, seconds on a loaded machine.
        for slider, keys in ((sliders[0], Keys.END + Keys.ARROW_LEFT), (sliders[1], Keys.HOME + Keys.ARROW_RIGHT),
                             (sliders[2], Keys.END)):
            slider.send_keys(keys)
        values = lambda: [float(s.get_attribute("aria-valuenow")) for s in sliders]  # noqa: E731
        _wait(lambda: bool(np.allclose(values(), [179.8, -179.8, 3500.0, 0.0], atol=1e-9)), 60, "the sliders to move")
        q = np.radians(values())
        q[2] = values()[2] / 1000.0
        pos_mm = robot.fkine(q)[:3, 3] * 1000.0
        # The page shows 0.01 mm and 0.01 deg: equal to fkine within half a last digit (plus round-off).
        def matches():
            p = _shown_pose(driver)
            return p if p is not None and np.abs(p[:3] - pos_mm).max() <= 0.005 + 1e-9 else None

        shown = _wait(matches, 60, f"the page to show the position {pos_mm}")
        R_shown = rpy_matrix(np.radians(shown[3:]))
        R_model = robot.fkine(q)[:3, :3]
        # Rotation from angles rounded to 0.01 deg: each entry within 3 x (0.005 deg in rad) of the model's.
        assert np.abs(R_shown - R_model).max() <= 3 * np.radians(0.005)
        # Negative control: fkine of the slider values before the move is far from what is shown.
        assert np.abs(robot.fkine(robot.q_rest)[:3, 3] * 1000.0 - shown[:3]).max() > 1000.0
        # |sin(-179.8 deg)| = 0.0035 < 0.05: the page names the singularity
        mark = driver.find_elements(By.XPATH, "//*[contains(text(), 'near a singularity')]/..")
        assert mark and "elbow folded (theta2 = pi)" in mark[0].text
        _assert_loopback_only(proc.pid, port)  # the browser's websocket included
        shot = tmp_path / "teach.png"
        driver.save_screenshot(str(shot))
        _assert_not_blank(shot)
    finally:
        if driver is not None:
            driver.quit()
        proc.send_signal(signal.SIGINT)
        out, err = _communicate(proc)
    assert proc.returncode == 0, err
    assert "stopped" in err
    assert _left_listening(mark) == set()


def _assert_not_blank(png: Path) -> None:
    from matplotlib.image import imread

    img = imread(png)[..., :3]
    assert img.shape[0] >= 500 and img.shape[1] >= 1000
    scene = img[:, : img.shape[1] * 2 // 3]  # the 3-D view, left of the control panel
    colours = np.unique((scene.reshape(-1, 3) * 255).astype(np.uint8), axis=0)
    # a drawn arm, grid and frames give hundreds of colours; a blank or one-colour page a handful
    assert len(colours) > 200, f"the 3-D view looks blank ({len(colours)} colours)"


@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
def test_nothing_listens_after_the_command_ends(how):
    proc, _, port, mark = _start("planar2r")
    _assert_loopback_only(proc.pid, port)
    assert listening_ports(mark) == {port}  # negative control: the mark finds the server's listener
    proc.send_signal(getattr(signal, how))
    _communicate(proc)
    assert proc.returncode == (0 if how == "SIGTERM" else -signal.SIGKILL)
    assert _left_listening(mark) == set()


def _manip(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "workbench.cli", *argv], cwd=REPO, capture_output=True, text=True,
                          timeout=120)


def test_busy_port_and_unloadable_robot_are_one_line_errors(tmp_path):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        res = _manip("teach", "scara", "--port", str(port), "--no-browser")
    assert res.returncode == 2
    assert res.stderr.strip() == (f"manip teach: error: --port: {port} on 127.0.0.1 is in use; "
                                  "choose another or leave --port out for a free one")
    # binding off loopback is explicit and warned about (192.0.2.1, TEST-NET-1, is on no interface: refused too)
    res = _manip("teach", "scara", "--host", "192.0.2.1", "--no-browser")
    assert res.returncode == 2
    assert res.stderr.splitlines() == [
        "manip: warning: --host 192.0.2.1: the teach page (no authentication) is reachable from other machines",
        "manip teach: error: --host 192.0.2.1 --port 0: cannot bind (Cannot assign requested address)"]
    res = _manip("teach", str(tmp_path / "missing.toml"), "--no-browser")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "missing.toml" in res.stderr
    res = _manip("teach", "scara", "--result", str(tmp_path), "--no-browser")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "--result" in res.stderr and "tracking.npz" in res.stderr
