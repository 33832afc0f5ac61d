"""Limits on what a user's file may ask of the workbench, stated once, and the readers that apply them.

Robot files, URDFs, waypoint files and FMUs come from strangers. Each is read
without executing anything and refused, with a one-line error naming the file
and the limit, before it can cost minutes or gigabytes:

* :data:`MAX_FILE_BYTES`: a robot TOML, a URDF or a waypoint file;
* :data:`MAX_JOINTS`: moving joints of a robot (TOML ``[[links]]``, the moving
  joints of a URDF's chain). The build grows like n^2 in generated operations (coriolis: 106,000
  at n = 25, see ``docs/model-equations.md``) and gcc's time and memory with it;
  ``benchmarks/bench_build.py`` builds up to 25 joints, a 50-link file took
  7.9 GB, so 32 leaves room above the largest chain measured and refuses the
  files that would not finish;
* :data:`MAX_WAYPOINTS`: rows of a waypoint file or of a ``[[tasks]]`` entry;
* :data:`MAX_SAMPLES`: samples of one time grid (a sampled trajectory, the control
  instants of a closed-loop run), so that a long duration (``--segment-time 1e9``)
  is refused before it allocates arrays of that length;
* ``MAX_FMU_*``: an FMU archive (:mod:`fmu.archive` checks them before anything
  is extracted);
* :data:`MAX_SPEC_BYTES`, :data:`MAX_SWEEP_CASES`: a sweep spec (:mod:`closed_loop.sweep`) and the
  number of cases it asks for (a grid's is the product of its axes, checked before any work).

The readers turn what the parser cannot bound itself (nesting so deep that it
exhausts the recursion limit, bytes that are not UTF-8) into the same one-line
errors.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_JOINTS",
    "MAX_WAYPOINTS",
    "MAX_SAMPLES",
    "MAX_SPEC_BYTES",
    "MAX_SWEEP_CASES",
    "MAX_FMU_MEMBERS",
    "MAX_FMU_MEMBER_BYTES",
    "MAX_FMU_TOTAL_BYTES",
    "MAX_FMU_RATIO",
    "FMU_RATIO_FLOOR_BYTES",
    "check_file",
    "read_bounded",
    "load_toml",
]

#: Largest robot TOML, URDF or waypoint file, bytes (10 MiB; the built-in robots are below 10 kB).
MAX_FILE_BYTES = 10 * 1024 * 1024
#: Most moving joints of a robot (see the module docstring for the measurement behind it).
MAX_JOINTS = 32
#: Most waypoints of a waypoint file or a ``[[tasks]]`` entry.
MAX_WAYPOINTS = 100_000
#: Most samples of one time grid: 5 million instants are 83 min at 1 kHz; a closed-loop run keeps about
#: six (n,) float arrays per instant (q, qd, tau and the reference), 1.7 GB for 7 joints at this limit.
MAX_SAMPLES = 5_000_000
#: Largest sweep spec, bytes (64 KiB: a spec is a dozen lines).
MAX_SPEC_BYTES = 64 * 1024
#: Most cases of one sweep: at ~5 ms a case (the compiled loop, 15 s at 1 kHz) 10^6 cases are ~1.4 core-hours,
#: and the table ~1 GB; a grid beyond it is a typo (samples per axis, not in total).
MAX_SWEEP_CASES = 1_000_000
#: Most members (files and folders) of an FMU archive (an exported FMU has about 15).
MAX_FMU_MEMBERS = 1000
#: Largest uncompressed member of an FMU archive, bytes (256 MiB).
MAX_FMU_MEMBER_BYTES = 256 * 1024 * 1024
#: Largest uncompressed total of an FMU archive, bytes (512 MiB).
MAX_FMU_TOTAL_BYTES = 512 * 1024 * 1024
#: Highest compression ratio (uncompressed / compressed) of a member above :data:`FMU_RATIO_FLOOR_BYTES`:
#: exported members compress 2.5 to 8 times (C sources, binaries, XML); a zip bomb 1000 times.
MAX_FMU_RATIO = 100
#: Members at most this large (1 MiB) are not held to :data:`MAX_FMU_RATIO`: they cannot hurt.
FMU_RATIO_FLOOR_BYTES = 1024 * 1024


def check_file(path: str | Path, what: str, error: type[ValueError]) -> Path:
    """``path`` if it is a file; else ``error`` saying it does not exist or is a directory, naming it.

    Raises
    ------
    error
        ``"<path>: no such <what>"`` or ``"<path>: is a directory: expected a <what>"``.
    """
    path = Path(path)
    if path.is_dir():
        raise error(f"{path}: is a directory: expected a {what}")
    if not path.exists():
        raise error(f"{path}: no such {what}")
    return path


def read_bounded(path: str | Path, what: str, error: type[ValueError], limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of a user's file, refused beyond ``limit`` bytes before they are read.

    Parameters
    ----------
    path
        The file.
    what
        What the file is, for the message (``"robot file"``, ``"URDF"``, ``"waypoint file"``).
    error
        The ValueError subclass to raise (e.g. ``RobotDescriptionError``).
    limit
        Largest size, bytes.

    Raises
    ------
    error
        ``"<path>: <size> bytes: larger than the <what> size limit of <limit> bytes"``, the file is missing or a
        directory (:func:`check_file`), or it cannot be read.
    """
    path = check_file(path, what, error)
    try:
        size = path.stat().st_size
        if size > limit:
            raise error(f"{path}: {size} bytes: larger than the {what} size limit of {limit} bytes")
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)  # the file may grow between stat and read
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} ({exc.strerror})") from None
    if len(data) > limit:
        raise error(f"{path}: larger than the {what} size limit of {limit} bytes")
    return data


def load_toml(path: str | Path, what: str, error: type[ValueError], limit: int = MAX_FILE_BYTES) -> dict[str, Any]:
    """Parse a user's TOML file within ``limit`` bytes (default :data:`MAX_FILE_BYTES`).

    Raises
    ------
    error
        Naming the file: too large, not UTF-8, not valid TOML, or nested too deeply to parse.
    """
    data = read_bounded(path, what, error, limit)
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text (byte {exc.start}): a TOML file is UTF-8") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise error(f"{path}: arrays or tables nested too deeply to parse") from None
