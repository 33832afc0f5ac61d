"""The teach page: drive a robot in a browser, as the Robotics Toolbox's ``drivebot``.

:func:`start_teach` serves a local page with viser (a 3-D scene and its GUI
controls in the browser, all logic in Python): one slider per joint within its
limits, the arm drawn from the model's ``fkine_all``, the tool pose and the
manipulability read live from the model, a mark when the arm is near a
singularity (the singularity report's named conditions), a target pose to drag
that the closed-form IK solves where the robot has one (every branch
selectable) and the numeric IK otherwise, and buttons that play a task's
trajectory or a saved tracking run. Every number the page shows is computed
here, by the model; the browser only draws.

The server binds ``127.0.0.1`` and a free port unless told otherwise
(:func:`start_teach`); :meth:`TeachPage.stop` closes it.
"""

from __future__ import annotations

import contextlib
import errno
import io
import ipaddress
import math
import socket
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np

from model.chain import joint_axes
from model.errors import InputError
from model.ik import WorkspaceError
from model.tasks import finite_limits

if TYPE_CHECKING:  # pragma: no cover
    import viser

    from model.robot import Robot

    from .replay import Replay

__all__ = [
    "NEAR_SINGULAR_TOL",
    "LOOPBACK",
    "DisplayUnits",
    "Readout",
    "PortError",
    "readout",
    "format_pose",
    "joint_frames",
    "is_loopback",
    "check_port_free",
    "TeachPage",
    "start_teach",
]

#: Tolerance of the "near a singularity" mark (:func:`readout`): a structure's named condition at this ``tol``
#: (e.g. |sin theta2| < 0.05, within 2.9 deg of the SCARA's stretched elbow), else a smallest singular value
#: of the task Jacobian at most 5 % of the largest.
NEAR_SINGULAR_TOL = 0.05
#: The address the page binds unless told otherwise.
LOOPBACK = "127.0.0.1"
#: Playback frames per second.
_FPS = 30.0


class PortError(InputError):
    """The requested port cannot be bound (in use, or not allowed); the message names the port."""


# --------------------------------------------------------------------------- numbers (no browser)


@dataclass(frozen=True)
class DisplayUnits:
    """How the page shows joint values and lengths: ``angle`` ``"deg"`` or ``"rad"``, ``length`` ``"mm"`` or ``"m"``."""

    angle: str = "deg"
    length: str = "mm"

    def __post_init__(self) -> None:
        if self.angle not in ("deg", "rad") or self.length not in ("mm", "m"):
            raise InputError(f"expected angle deg|rad and length mm|m, got {self.angle!r}, {self.length!r}",
                             parameter="units")

    def factor(self, revolute: bool) -> float:
        """Displayed value per SI unit (rad or m)."""
        if revolute:
            return 180.0 / math.pi if self.angle == "deg" else 1.0
        return 1000.0 if self.length == "mm" else 1.0

    def unit(self, revolute: bool) -> str:
        """The unit's name."""
        return self.angle if revolute else self.length

    def decimals(self, revolute: bool) -> int:
        """Decimals shown: 0.01 deg, 1e-4 rad, 0.01 mm, 1e-5 m."""
        return {"deg": 2, "rad": 4, "mm": 2, "m": 5}[self.unit(revolute)]

    def step(self, revolute: bool) -> float:
        """Slider step: 0.1 deg, 0.001 rad, 1 mm, 0.001 m."""
        return {"deg": 0.1, "rad": 1e-3, "mm": 1.0, "m": 1e-3}[self.unit(revolute)]


@dataclass(frozen=True, eq=False)
class Readout:
    """What the page shows of one configuration, all from the model.

    Attributes
    ----------
    q
        (n,) joint values, rad or m.
    T
        (4, 4) tool pose ``T_WE`` (``robot.fkine``), m.
    rpy
        (3,) roll, pitch, yaw of ``T_WE``, rad: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
    manipulability
        ``robot.manipulability(q)`` on the structure's task rows.
    task
        Names of those rows (``("x", "y", "z", "rz")`` for a SCARA).
    near
        Why the arm is near a singularity, empty when it is not (:func:`readout`).
    """

    q: np.ndarray
    T: np.ndarray
    rpy: np.ndarray
    manipulability: float
    task: tuple[str, ...]
    near: tuple[str, ...]

    @property
    def near_singular(self) -> bool:
        """Whether the arm is within :data:`NEAR_SINGULAR_TOL` of a singularity."""
        return bool(self.near)

    def singularity_text(self) -> str:
        """One line: ``"no singularity near"`` or the reasons."""
        return "; ".join(self.near) if self.near else "no singularity near"


def readout(robot: "Robot", q: Sequence[float]) -> Readout:
    """The page's numbers at ``q`` (n,), rad or m: ``fkine``, its roll-pitch-yaw, manipulability, singularity.

    Near a singularity means: for a recognised structure (:mod:`model.closed_form`), one
    of its named singular conditions holds at ``tol = NEAR_SINGULAR_TOL`` (e.g. the SCARA's
    elbow stretched, ``|sin theta2| < 0.05``); otherwise the singularity report at that
    ``tol`` (smallest singular value of the task Jacobian at most 5 % of the largest).
    """
    from model.closed_form import closed_form_for, joint_values
    from model.description import tr2rpy

    q = np.asarray(q, dtype=float)
    T = robot.fkine(q)
    report = robot.singularities(q, tol=NEAR_SINGULAR_TOL)
    form = closed_form_for(robot.description)
    if form is not None:
        near = tuple(form.singular_conditions(joint_values(robot.description, q), NEAR_SINGULAR_TOL))
    else:
        near = tuple(report.reasons[:1])
    return Readout(q=q, T=T, rpy=tr2rpy(T), manipulability=robot.manipulability(q),
                   task=report.task, near=near)


def format_pose(r: Readout, units: DisplayUnits) -> str:
    """The tool pose as a Markdown table: position in ``units.length``, roll-pitch-yaw in ``units.angle``."""
    fl, fa = units.factor(False), units.factor(True)
    dl, da = units.decimals(False), units.decimals(True)
    pos = " | ".join(f"{v * fl:.{dl}f}" for v in r.T[:3, 3])
    rpy = " | ".join(f"{v * fa:.{da}f}" for v in r.rpy)
    return (f"| tool | x / roll | y / pitch | z / yaw |\n|---|---|---|---|\n"
            f"| position [{units.length}] | {pos} |\n| rpy [{units.angle}] | {rpy} |")


def joint_frames(robot: "Robot", T_links: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """World origin and unit axis of every joint, from the model's link frames ``T_links = fkine_all(q)``."""
    from model.chain import build_chain

    return joint_axes(build_chain(robot.description), T_links)


def is_loopback(host: str) -> bool:
    """Whether ``host`` is a loopback address (127.0.0.0/8, ::1) or ``localhost``."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_port_free(host: str, port: int) -> None:
    """Refuse ``port`` on ``host`` when it cannot be bound now (in use, not permitted, no such address).

    Port 0 checks the address alone (the system picks a free port).
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as asyncio's server does: TIME_WAIT is no conflict
        try:
            probe.bind((host, port))
        except OSError as exc:
            if port and exc.errno == errno.EADDRINUSE:
                raise PortError(f"--port: {port} on {host} is in use; choose another or leave --port out for a free one") from None
            raise PortError(f"--host {host} --port {port}: cannot bind ({exc.strerror or exc})") from None


# --------------------------------------------------------------------------- the page


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return np.array([w, x, y, z])


def _rotation_wxyz(wxyz: Sequence[float]) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    w, x, y, z = (float(v) for v in wxyz)
    return Rotation.from_quat([x, y, z, w]).as_matrix()


def _z_to(axis: np.ndarray) -> np.ndarray:
    """(3, 3) a rotation taking z onto the unit ``axis`` (viser's cylinders stand on z)."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, axis), float(z @ axis)
    if 1.0 + c < 1e-9:  # axis = -z (to round-off): half a turn about x
        return np.diag([1.0, -1.0, -1.0])
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


class TeachPage:
    """The teach page of one robot on a running viser server.

    Parameters
    ----------
    robot
        The robot to drive.
    server
        A started ``viser.ViserServer``.
    replays
        Motions the page can play, by button label (a task's trajectory, a tracking run); computed on demand.
    units
        Initial display units.

    Notes
    -----
    The joint values live here, in SI units (:attr:`q`); the sliders show them in
    the chosen units. A change from the browser calls :meth:`set_q`, which redraws
    the arm and the readouts from ``fkine_all``, ``fkine``, ``manipulability`` and
    ``singularities``. Playback runs on one background thread, stopped by
    :meth:`stop_playback` or any slider move.
    """

    def __init__(self, robot: "Robot", server: "viser.ViserServer",
                 replays: dict[str, Callable[[], "Replay"]] | None = None,
                 units: DisplayUnits = DisplayUnits()) -> None:
        self.robot = robot
        self.server = server
        self.units = units
        self.limits = finite_limits(robot.description)
        # the rest (within qlim); the clip binds only for a joint without limits resting beyond its slider's +-pi
        self.q = np.clip(robot.q_rest, self.limits[0], self.limits[1]).astype(float)
        self._lock = threading.RLock()
        self._pending_lock = threading.Lock()
        self._solving = False
        self._pending = False
        self._play_stop = threading.Event()
        self._player: threading.Thread | None = None
        self._replays = dict(replays or {})
        self._revolute = [lk.is_revolute for lk in robot.description.links]
        self._names = [lk.name or f"q{j + 1}" for j, lk in enumerate(robot.description.links)]
        from model.chain import build_chain
        from model.closed_form import closed_form_for

        self.closed_form = closed_form_for(robot.description) is not None
        self._chain = build_chain(robot.description)  # the joint axes of every frame drawn
        self._scale = self._length_scale()
        self._build_scene()
        self._build_gui()
        self.set_q(self.q)
        self._target_to_tool()

    # -------------------------------------------------------------- scene
    def _length_scale(self) -> float:
        pts = [self.robot.fkine_all(q)[:, :3, 3] for q in (self.q, self.limits[0], self.limits[1])]
        spread = max(float(np.ptp(np.vstack(pts), axis=0).max()), 0.1)
        return spread

    def _build_scene(self) -> None:
        s, scene = self._scale, self.server.scene
        scene.set_up_direction("+z")
        scene.add_grid("/grid", width=2.5 * s, height=2.5 * s, cell_size=s / 4, section_size=s)
        scene.add_frame("/world", axes_length=0.3 * s, axes_radius=0.01 * s)
        self._links = scene.add_line_segments("/arm/links", np.zeros((self.robot.n + 1, 2, 3)), (90, 90, 110),
                                              thickness=0.025 * s)
        self._frames = [scene.add_frame(f"/arm/frame{i}", axes_length=0.12 * s, axes_radius=0.006 * s)
                        for i in range(self.robot.n + 1)]
        self._joints = []
        for j, rev in enumerate(self._revolute):
            color = (230, 140, 40) if rev else (60, 140, 230)
            self._joints.append(scene.add_cylinder(f"/arm/joint{j}", radius=0.04 * s, height=0.12 * s, color=color))
        self._tool = scene.add_frame("/arm/tool", axes_length=0.22 * s, axes_radius=0.012 * s,
                                     origin_color=(200, 30, 30))
        self._target = scene.add_transform_controls("/target", scale=0.35 * s)
        self._target.on_update(lambda _event: self._solve_target())
        cam = self.server.initial_camera
        centre = self.robot.fkine_all(self.q)[:, :3, 3].mean(axis=0)
        cam.look_at = tuple(float(v) for v in centre)
        cam.position = tuple(float(v) for v in centre + np.array([0.45, -0.6, 0.45]) * s)

    def _draw(self, T_links: np.ndarray, T_tool: np.ndarray) -> None:
        origins = np.vstack([T_links[:, :3, 3], T_tool[None, :3, 3]])
        self._links.points = np.stack([origins[:-1], origins[1:]], axis=1)
        for handle, T in zip(self._frames, T_links):
            handle.position, handle.wxyz = T[:3, 3], _quat_wxyz(T[:3, :3])
        for handle, (o, axis) in zip(self._joints, joint_axes(self._chain, T_links)):
            handle.position, handle.wxyz = o, _quat_wxyz(_z_to(axis))
        self._tool.position, self._tool.wxyz = T_tool[:3, 3], _quat_wxyz(T_tool[:3, :3])

    # ---------------------------------------------------------------- GUI
    def _build_gui(self) -> None:
        gui = self.server.gui
        gui.add_markdown(f"**{self.robot.name}**: {self.robot.description.description or ''}")
        self._units = gui.add_dropdown("units", ("deg, mm", "rad, m"),
                                       initial_value="deg, mm" if self.units.angle == "deg" else "rad, m")
        self._units.on_update(lambda event: self._set_units(event.target.value))
        self._slider_folder = gui.add_folder("joints")
        self._sliders: list = []
        self._make_sliders()
        with gui.add_folder("tool pose (fkine)"):
            self._pose_md = gui.add_markdown("")
            self._manip_md = gui.add_markdown("")
            self._sing_md = gui.add_markdown("")
        with gui.add_folder("target (drag the gizmo)"):
            method = "closed-form IK" if self.closed_form else "numeric IK (Levenberg-Marquardt from the current q)"
            gui.add_markdown(f"Solved by {method}.")
            self._branch = gui.add_dropdown("IK branch", ("(drag the target)",), visible=self.closed_form)
            self._branch.on_update(lambda event: self._solve_target() if event.client is not None else None)
            self._ik_md = gui.add_markdown("")
            gui.add_button("target to the tool").on_click(lambda _event: self._target_to_tool())
        with gui.add_folder("play"):
            for label in self._replays:
                gui.add_button(f"play {label}").on_click(lambda _event, label=label: self.play(label))
            if not self._replays:
                gui.add_markdown("nothing to play")
            gui.add_button("stop").on_click(lambda _event: self.stop_playback())
            self._play_md = gui.add_markdown("")

    def _make_sliders(self) -> None:
        for handle in self._sliders:
            handle.remove()
        self._sliders = []
        with self._slider_folder:
            for j, rev in enumerate(self._revolute):
                f, step = self.units.factor(rev), self.units.step(rev)
                lo = math.ceil(self.limits[0, j] * f / step - 1e-9) * step
                hi = math.floor(self.limits[1, j] * f / step + 1e-9) * step
                value = float(np.clip(round(self.q[j] * f / step) * step, lo, hi))
                handle = self.server.gui.add_slider(f"{self._names[j]} [{self.units.unit(rev)}]", min=lo, max=hi,
                                                    step=step, initial_value=value)
                handle.on_update(self._on_slider)
                self._sliders.append(handle)

    def _set_units(self, choice: str) -> None:
        with self._lock:
            self.units = DisplayUnits("deg", "mm") if choice.startswith("deg") else DisplayUnits("rad", "m")
            self._make_sliders()
            self._show(readout(self.robot, self.q))

    def _on_slider(self, event) -> None:
        if event.client is None:  # set from here (set_q, playback): already drawn
            return
        self.stop_playback()
        q = np.array([h.value / self.units.factor(rev) for h, rev in zip(self._sliders, self._revolute)])
        self.set_q(q, move_sliders=False)

    # --------------------------------------------------------------- state
    def set_q(self, q: Sequence[float], move_sliders: bool = True) -> Readout:
        """Show the arm at ``q`` (n,), rad or m: sliders, drawing and readouts; returns the readout."""
        with self._lock:
            self.q = np.asarray(q, dtype=float).copy()
            r = readout(self.robot, self.q)
            self._draw(self.robot.fkine_all(self.q), r.T)
            if move_sliders:
                for h, rev, v in zip(self._sliders, self._revolute, self.q):
                    h.value = float(v * self.units.factor(rev))
            self._show(r)
            return r

    def _show(self, r: Readout) -> None:
        self._pose_md.content = format_pose(r, self.units)
        self._manip_md.content = f"manipulability ({' '.join(r.task)}): **{r.manipulability:.4g}**"
        if r.near_singular:
            self._sing_md.content = f"**⚠ near a singularity**: {r.singularity_text()}"
        else:
            self._sing_md.content = "no singularity near"

    # -------------------------------------------------------------- target
    def _target_to_tool(self) -> None:
        T = self.robot.fkine(self.q)
        self._target.position, self._target.wxyz = T[:3, 3], _quat_wxyz(T[:3, :3])

    def target_pose(self) -> np.ndarray:
        """(4, 4) pose of the drag target in the world frame, m."""
        T = np.eye(4)
        T[:3, :3] = _rotation_wxyz(self._target.wxyz)
        T[:3, 3] = np.asarray(self._target.position, dtype=float)
        return T

    def _solve_target(self) -> None:
        """Solve for the target's latest pose; drags that arrive meanwhile are folded into one more solve."""
        self.stop_playback()
        with self._pending_lock:
            if self._solving:
                self._pending = True
                return
            self._solving = True
        try:
            while True:
                self._pending = False
                T = self.target_pose()
                with self._lock:
                    if self.closed_form:
                        self._solve_closed_form(T)
                    else:
                        self._solve_numeric(T)
                with self._pending_lock:
                    if not self._pending:
                        self._solving = False
                        return
        except BaseException:
            with self._pending_lock:
                self._solving = False
            raise

    def _solve_closed_form(self, T: np.ndarray) -> None:
        try:
            sols = self.robot.ikine_a(T)
        except WorkspaceError as exc:
            self._ik_md.content = f"**out of reach**: {exc}"
            return
        labels = tuple(s.branch for s in sols)
        wanted = self._branch.value
        if tuple(self._branch.options) != labels:
            self._branch.options = labels
        if wanted not in labels:
            wanted = next((s.branch for s in sols if s.within_limits), labels[0])
        self._branch.value = wanted
        sol = sols[labels.index(wanted)]
        notes = [f"{len(sols)} branches"]
        if not sol.reproduces_pose:
            notes.append("this structure cannot reach the target's full orientation; solved for the components it controls")
        if not sol.within_limits:
            self._ik_md.content = f"branch **{wanted}** is outside the joint limits; arm not moved ({'; '.join(notes)})"
            return
        self._ik_md.content = f"branch **{wanted}** ({'; '.join(notes)})"
        self.set_q(sol.q)

    def _solve_numeric(self, T: np.ndarray) -> None:
        res = self.robot.ikine(T, q0=self.q)
        if not res.success:
            self._ik_md.content = f"**not solved**: {res.reason} (residual {res.residual:.3g}); arm not moved"
            return
        self._ik_md.content = f"solved in {res.iterations} iterations (residual {res.residual:.2g})"
        self.set_q(np.clip(res.q, self.limits[0], self.limits[1]))

    # ------------------------------------------------------------ playback
    def play(self, label: str) -> None:
        """Play the motion ``label`` (a key of ``replays``) in real time on a background thread."""
        self.stop_playback()
        replay = self._replays[label]()
        self._play_stop.clear()
        self._player = threading.Thread(target=self._run_playback, args=(replay,), name="teach-playback", daemon=True)
        self._player.start()

    def _run_playback(self, replay: "Replay") -> None:
        start = time.monotonic()
        while not self._play_stop.is_set():
            elapsed = time.monotonic() - start
            self.set_q(np.clip(replay.at(elapsed), self.limits[0], self.limits[1]))
            self._play_md.content = f"{replay.name}: t = {min(elapsed, replay.duration):.2f} / {replay.duration:.2f} s"
            if elapsed >= replay.duration:
                return
            self._play_stop.wait(1.0 / _FPS)

    def stop_playback(self) -> None:
        """Stop a running playback (and wait for its thread); nothing happens when none runs."""
        self._play_stop.set()
        player = self._player
        if player is not None and player is not threading.current_thread():
            player.join(timeout=2.0)
        self._player = None

    def stop(self) -> None:
        """Stop the playback and the server: nothing listens afterwards."""
        self.stop_playback()
        with contextlib.redirect_stdout(io.StringIO()):  # viser's "Server stopped" line; the command prints its own
            self.server.stop()


def _no_share_tunnel(server: "viser.ViserServer") -> None:
    """Hide viser's share button and drop its request handler: nothing on the page opens a connection off this machine."""
    from viser import _messages

    server.gui.configure_theme(control_width="large", show_share_button=False)
    server._websock_server.unregister_handler(_messages.ShareUrlRequest)


def start_teach(robot: "Robot", *, host: str = LOOPBACK, port: int = 0,
                replays: dict[str, Callable[[], "Replay"]] | None = None,
                units: DisplayUnits = DisplayUnits()) -> TeachPage:
    """Start the teach page of ``robot`` on ``host:port`` (port 0: a free one) and return it.

    Raises
    ------
    PortError
        ``port`` is in use or cannot be bound on ``host`` (checked before the server
        starts and again after: viser would otherwise move to the next free port).
    """
    import viser

    check_port_free(host, port)  # port 0: checks that the address can be bound at all
    with contextlib.redirect_stdout(io.StringIO()):  # viser's banner: the command prints its own address line
        server = viser.ViserServer(host=host, port=port, label=f"manip teach {robot.name}", verbose=False)
    _no_share_tunnel(server)
    if port and server.get_port() != port:
        server.stop()
        raise PortError(f"--port: {port} on {host} is in use; choose another or leave --port out for a free one")
    try:
        return TeachPage(robot, server, replays=replays, units=units)
    except BaseException:
        server.stop()
        raise
