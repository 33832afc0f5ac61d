"""``manip teach``: drive a robot in the browser (the Robotics Toolbox's ``drivebot``), from the command line.

``manip teach ROBOT [--port N] [--host ADDR] [--no-browser] [--result DIR] [--units deg-mm|rad-m]`` serves
the teach page (:mod:`workbench.teach`) on 127.0.0.1 and a free port, prints
its address, opens it in the default browser, and serves until Ctrl-C (or
SIGTERM); then the server is stopped and nothing listens. A robot that cannot
be loaded, a busy ``--port`` or an unreadable ``--result`` is refused in one
line before anything listens. ``--host`` other than a loopback address makes
the page reachable from other machines and is warned about.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import warnings
from typing import Any

from .args import bounded_int, host_address

__all__ = ["register", "run_teach"]


def _replays(robot: Any, result: str | None) -> dict:
    from model.tasks import robot_tasks, tour

    from .replay import load_replay, task_replay

    out = {}
    for name, task in robot_tasks(robot.description).items():
        out[f"task {name}"] = lambda task=task: task_replay(task)
    out["task tour (every joint's range)"] = lambda: task_replay(tour(robot.description))
    if result is not None:
        replay = load_replay(result, robot.name, robot.n)  # checked now: a bad --result is refused before serving
        out["last tracking result"] = lambda: replay
    return out


def run_teach(args: argparse.Namespace) -> int:
    """``manip teach``: serve the teach page until interrupted."""
    from model.robot import load_robot

    from .teach import DisplayUnits, is_loopback, start_teach

    if not is_loopback(args.host):
        warnings.warn(f"--host {args.host}: the teach page (no authentication) is reachable from other machines")
    robot = load_robot(args.robot)
    replays = _replays(robot, args.result)
    units = DisplayUnits("deg", "mm") if args.units == "deg-mm" else DisplayUnits("rad", "m")
    page = start_teach(robot, host=args.host, port=args.port or 0, replays=replays, units=units)
    stop = threading.Event()
    previous = signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        host = f"[{args.host}]" if ":" in args.host else args.host
        url = f"http://{host}:{page.server.get_port()}/"
        print(f"manip teach: {robot.name} at {url} (Ctrl-C to stop)", flush=True)
        if not args.no_browser:
            import webbrowser

            if not webbrowser.open(url):
                print("manip teach: no browser found; open the address above", file=sys.stderr)
        try:
            while not stop.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
    finally:
        page.stop()
        signal.signal(signal.SIGTERM, previous)
    print("manip teach: stopped", file=sys.stderr)
    return 0


def register(subparsers: Any) -> None:
    """Add the ``teach`` sub-command to ``manip``'s sub-parsers."""
    p = subparsers.add_parser("teach", help="drive the arm in a browser: joint sliders, tool pose, IK target, playback")
    p.add_argument("robot", help="built-in name, TOML or URDF file")
    p.add_argument("--port", type=bounded_int(1, 65535, "a port number"), default=None, metavar="N", help="port to serve on (default: a free one)")
    p.add_argument("--host", type=host_address, default="127.0.0.1", metavar="ADDR",
                   help="address to bind (default 127.0.0.1; anything else is reachable from other machines)")
    p.add_argument("--no-browser", action="store_true", help="print the address only, do not open a browser")
    p.add_argument("--result", default=None, metavar="DIR",
                   help="a `manip track --out DIR` folder (or its tracking.npz): adds a button that plays that run")
    p.add_argument("--units", choices=("deg-mm", "rad-m"), default="deg-mm", help="initial display units (default deg-mm)")
    p.set_defaults(func=run_teach)

