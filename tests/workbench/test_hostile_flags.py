"""Every ``manip`` command, every flag, hostile values: exit status 2 and one line on stderr, never a traceback.

The matrix is generated from the real argparse parsers (:func:`workbench.cli.build_parser`): each
value-taking argument of each sub-command gets the hostile values of its kind (a number: negative,
zero, NaN, infinity, 1e308, empty, not a number; a choice: empty, unknown; a file or folder: empty, a
NUL byte, the wrong kind of path, a missing or unreadable file; a name: empty, unknown). A new command
or flag is covered without editing this file, unless its kind is new (then :func:`_kind` fails,
naming it). Each case runs ``workbench.cli.main(argv)`` in-process on a cheap base command line
(planar2r, ``--no-plots``, short horizons), with Python's default warning filters, so that a
warning printed before the error counts as a second line, as it would for a user.

A value that is legitimately valid for a flag (:data:`VALID`, e.g. ``--payload=0``) may also
succeed (exit 0), but still never shows a traceback. Everything else must be refused in one line.
"""

from __future__ import annotations

import contextlib
import io
import types
import warnings
from pathlib import Path

import pytest

from workbench import cli

#: Values tried for each kind of argument. ``{dir}``, ``{file}``, ``{garbage}`` and ``{missing}`` are
#: filled per case: an existing folder, an existing text file, a file of random bytes, a missing path.
NUMBER = ("-1", "0", "nan", "inf", "-inf", "1e308", "", "abc")
CHOICE = ("", "abc", "0", "nan")
INPUT_PATH = ("", "\0", "0", "nan", "{dir}", "{garbage}", "{missing}")
OUT_DIR = ("", "\0", "{file}", "{file}/sub")
OUT_FILE = ("", "\0", "{dir}", "{file}/sub.x")
NAME = ("", "\0", "0", "nan", "abc")
ADDRESS = ("", "\0", "a b", "-1")

#: The kind of each text argument (by its ``dest``): which hostile values it gets.
TEXT_KINDS: dict[str, tuple[str, ...]] = {
    "robot": INPUT_PATH, "spec": INPUT_PATH, "fmu": INPUT_PATH, "waypoints": INPUT_PATH, "result": INPUT_PATH,
    "trajectory": INPUT_PATH, "data": INPUT_PATH, "ssp": INPUT_PATH,
    "velocity_limit": NUMBER, "acceleration_limit": NUMBER,  # one number, or one per joint with commas
    "out": OUT_DIR, "output": OUT_FILE, "toml": OUT_FILE,
    "controller": NAME, "task": NAME, "platforms": NAME, "variant": NAME,
    "host": ADDRESS, "listen": ADDRESS, "scheduler": ADDRESS,
}

#: (command, flag, value) that are valid requests: they may run (exit 0) or be refused in one line.
VALID: set[tuple[str, str, str]] = {
    ("track", "--payload", "0"),           # no payload: the exact plant
    ("track", "--friction-scale", "0"),    # a frictionless plant
    ("workspace", "--seed", "0"),
    ("export-fmu", "--step", "1e308"),
    ("retime", "--velocity-limit", "inf"),        # inf: no speed limit (documented)
    ("retime", "--acceleration-limit", "inf"),
    ("retime", "--velocity-limit", "1e308"),      # a limit no motion reaches
    ("retime", "--acceleration-limit", "1e308"),
    ("retime", "--velocity-scale", "1e308"),      # a factor on limits the robot states (planar2r states none)
    ("retime", "--acceleration-scale", "1e308"),
    ("retime", "--smooth", "0"),
    ("excite", "--seed", "0"),
    ("excite", "--velocity-limit", "1e308"),      # a limit no motion reaches: the position box bounds it
    ("excite", "--acceleration-limit", "1e308"),
    ("identify", "--holdout", "0"),               # no held-out part: every sample fits                  # 0: the exact time law, unaveraged (documented)     # an internal step longer than any communication step: one RK4 step each
}
#: Flags of the base command line that a flag under test cannot be combined with (dropped for its cases).
CONFLICTS: dict[tuple[str, str], tuple[str, ...]] = {
    ("sweep", "--scheduler"): ("--workers",),  # the scheduler's cluster has its own workers
}


def _base(command: str, tmp: Path, fmu_file: Path, spec_file: Path, data_file: Path) -> list[str]:
    """A cheap valid command line of ``command`` (a flag under test replaces or is appended to it)."""
    return {
        "robots": ["robots"],
        "info": ["info", "planar2r"],
        "build": ["build", "planar2r"],
        "export-urdf": ["export-urdf", "planar2r", "-o", str(tmp / "out" / "arm.urdf")],
        "design": ["design", "planar2r", "--out", str(tmp / "out"), "--no-plots"],
        "track": ["track", "planar2r", "--out", str(tmp / "out"), "--no-plots", "--segment-time=0.2"],
        "export-fmu": ["export-fmu", "planar2r", "-o", str(tmp / "out" / "p.fmu"), "--platforms=host"],
        "validate-fmu": ["validate-fmu", str(fmu_file), "--horizon=0.05", "--no-cosim"],
        "export-ssp": ["export-ssp", "planar2r", "-o", str(tmp / "out" / "loop.ssp"), "--segment-time=0.2"],
        "validate-ssp": ["validate-ssp", str(fmu_file)],  # every value of its one argument is hostile
        "teach": ["teach", "planar2r", "--no-browser"],
        "workspace": ["workspace", "planar2r", "-o", str(tmp / "out" / "ws.png"), "--samples=100"],
        "sweep": ["sweep", str(spec_file), "--out", str(tmp / "out"), "--workers=1", "--no-plots"],
        "retime": ["retime", "planar2r", "--out", str(tmp / "out"), "--grid=50"],
        "excite": ["excite", "planar2r", "-o", str(tmp / "out" / "e.csv"), "--period=2", "--harmonics=1",
                   "--max-iter=3", "--rate=100"],
        "identify": ["identify", "planar2r", str(data_file), "--out", str(tmp / "out"), "--no-plots"],
        "demo": ["demo", "--robot", "planar2r", "--out", str(tmp / "out"), "--no-plots", "--no-gif"],
    }[command]


def _subparsers(parser=None) -> dict:
    parser = parser or cli.build_parser()
    [action] = parser._subparsers._group_actions
    return action.choices


def _kind(command: str, action) -> tuple[str, ...]:
    if action.dest in TEXT_KINDS:  # text, whatever its argparse type checks (a host, an address)
        return TEXT_KINDS[action.dest]
    if action.choices is not None:
        return CHOICE
    assert action.type is not None, f"manip {command}: argument {action.dest!r} has no hostile values: add its kind"
    return NUMBER


def _cases() -> list[tuple[str, str | None, str, str]]:
    """(command, flag or None for a positional, dest, value) for every value-taking argument."""
    cases = []
    for command, sub in _subparsers().items():
        for action in sub._actions:
            if action.nargs == 0 or action.dest == "help":  # store_true, --help, --version
                continue
            flag = max(action.option_strings, key=len) if action.option_strings else None
            for value in _kind(command, action):
                cases.append((command, flag, action.dest, value))
    return cases


CASES = _cases()


def _argv(base: list[str], command: str, flag: str | None, dest: str, value: str) -> list[str]:
    parser = _subparsers()[command]
    argv = list(base)
    if flag is None:  # positional: the first positional of the base is replaced
        positionals = [a.dest for a in parser._actions if not a.option_strings]
        index = 1 + positionals.index(dest)  # base[0] is the command; positionals follow it
        argv[index] = value
        return argv
    action = next(a for a in parser._actions if flag in a.option_strings)
    # drop the base's setting of this flag (and of a flag exclusive with it)
    exclusive = {flag, *CONFLICTS.get((command, flag), ())}
    for group in parser._mutually_exclusive_groups:
        if action in group._group_actions:
            exclusive |= {s for a in group._group_actions for s in a.option_strings}
    keep, skip = [], False
    for i, arg in enumerate(argv):
        if skip:
            skip = False
            continue
        name = arg.split("=", 1)[0]
        owner = next((a for a in parser._actions if name in a.option_strings), None)
        if owner is not None and (set(owner.option_strings) & exclusive):
            skip = "=" not in arg and owner.nargs != 0
            continue
        keep.append(arg)
    return keep + [f"{flag}={value}"]


@pytest.fixture(scope="module")
def fmu_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("fmu") / "planar2r.fmu"
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        assert cli.main(["export-fmu", "planar2r", "-o", str(path), "--platforms=host"]) == 0
    return path


@pytest.fixture(scope="module")
def spec_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("spec") / "spec.toml"
    path.write_text('robot = "planar2r"\ncontroller = "pd"\nsamples = 2\nseed = 1\nsegment_time = 0.2\n'
                    "[vary]\npayload_mass = [0.0, 1.0]\n")
    return path


@pytest.fixture(scope="module")
def data_file(tmp_path_factory) -> Path:
    """A short identification log of planar2r: a two-sine motion and its inverse dynamics."""
    import numpy as np

    from model import load_robot
    from model.joint_table import write_joint_table

    robot = load_robot("planar2r")
    t = np.arange(400) * 5e-3
    w = np.array([[1.3], [2.1]])
    Q, QD, QDD = (np.sin(w * t).T * 0.5, (w * np.cos(w * t)).T * 0.5, (-w * w * np.sin(w * t)).T * 0.5)
    tau = np.array([robot.rne(q, qd, qdd) for q, qd, qdd in zip(Q, QD, QDD)])
    path = tmp_path_factory.mktemp("data") / "log.csv"
    return write_joint_table(path, t, {"q": Q, "tau": tau}, robot.description.joint_names)


def _fill(value: str, tmp: Path) -> str:
    (tmp / "a_dir").mkdir(exist_ok=True)
    (tmp / "a_file.txt").write_text("not what was asked for\n")
    (tmp / "garbage.bin").write_bytes(bytes(range(256)) * 4)
    return value.format(dir=tmp / "a_dir", file=tmp / "a_file.txt", garbage=tmp / "garbage.bin",
                        missing=tmp / "missing" / "nothing.toml")


class _Served(Exception):
    """Raised by the patched teach server once the page is up: everything before serving passed."""


def run_cli(argv: list[str], monkeypatch) -> tuple[int, str]:
    """``main(argv)`` in-process with Python's default warning filters; (exit status, stderr)."""
    # teach serves until stopped: an event that is already set lets it start, serve and stop at once
    monkeypatch.setattr("workbench.cmd_teach.threading", types.SimpleNamespace(Event=_SetEvent))
    err, out = io.StringIO(), io.StringIO()
    with warnings.catch_warnings():
        warnings.resetwarnings()  # the interpreter's defaults, as for a user (pytest's own are replaced)
        warnings.simplefilter("default")
        for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
            warnings.simplefilter("ignore", category)
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            try:
                status = cli.main(argv)
            except SystemExit as exc:  # argparse's own exit
                status = exc.code if isinstance(exc.code, int) else 1
    return status, err.getvalue()


class _SetEvent:
    def wait(self, timeout: float | None = None) -> bool:
        return True

    def set(self) -> None:
        pass


@pytest.mark.parametrize(("command", "flag", "dest", "value"), CASES,
                         ids=[f"{c} {f or d}={v!r}" for c, f, d, v in CASES])
def test_a_hostile_value_is_refused_in_one_line(command, flag, dest, value, tmp_path, fmu_file, spec_file,
                                                data_file, monkeypatch):
    monkeypatch.chdir(tmp_path)
    value = _fill(value, tmp_path)
    argv = _argv(_base(command, tmp_path, fmu_file, spec_file, data_file), command, flag, dest, value)
    status, err = run_cli(argv, monkeypatch)
    assert "Traceback" not in err, err
    lines = err.splitlines()
    if (command, flag, value) in VALID and status == 0:
        return
    assert status == 2 and len(lines) == 1, f"manip {' '.join(map(repr, argv))}: exit {status}, stderr:\n{err}"
    assert lines[0].startswith(f"manip {command}: error: "), lines[0]


def test_the_matrix_covers_every_command_and_argument():
    """Negative control of the generator: every sub-command has a base command line and its arguments cases."""
    commands = set(_subparsers())
    assert {"robots", "info", "track", "sweep", "demo", "teach", "validate-fmu"} <= commands
    for command in commands:
        _base(command, Path("/tmp"), Path("x.fmu"), Path("s.toml"), Path("d.csv"))  # KeyError: a command without one
    covered = {(c, f or d) for c, f, d, _ in CASES}
    for flag in ("--bandwidth", "--payload", "--mass-scale", "--segment-time", "--out", "robot"):
        assert ("track", flag) in covered
    assert ("validate-fmu", "--horizon") in covered and ("workspace", "--seed") in covered
    assert len(CASES) > 300


def test_a_base_command_line_succeeds(tmp_path, fmu_file, spec_file, data_file, monkeypatch):
    """Negative control: the cheap base command lines themselves run (so a refusal above is the value's)."""
    monkeypatch.chdir(tmp_path)
    for command in ("info", "track", "validate-fmu", "workspace", "teach", "retime", "excite", "identify",
                    "export-ssp"):
        status, err = run_cli(_base(command, tmp_path, fmu_file, spec_file, data_file), monkeypatch)
        assert status == 0 and "Traceback" not in err, (command, err)
