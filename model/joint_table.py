"""Time series with per-joint columns as CSV: trajectories, tracking logs, identification data.

One file format, written and read once for every command that exchanges joint-space
samples with the user (``manip excite`` and ``manip retime`` write trajectories that
``manip track --trajectory`` reads; ``manip track`` writes its run; ``manip identify``
reads measured data)::

    time,q_shoulder,q_elbow,qd_shoulder,qd_elbow,qdd_shoulder,qdd_elbow
    0,0,0,0,0,0,0
    0.001,1.2e-07,...

* comma-separated, ``.`` as the decimal point, one header line, then one row per sample;
  lines starting with ``#`` are comments;
* the first column is ``time`` (s), strictly increasing;
* then groups of n columns ``<group>_<joint>`` (a group is a quantity: ``q``, ``qd``,
  ``qdd``, ``tau``, ...; the joints are :attr:`model.RobotDescription.joint_names`, in
  chain order), every value finite, SI units (rad, m, rad/s, N m, ...).

The header is the contract: a reader names the groups it needs and the ones it accepts,
and a file with an unknown, missing, misspelt or misplaced column is refused in one line
naming the file and the column, never guessed at.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from .errors import InputError, did_you_mean
from .files import write_atomic
from .limits import MAX_SAMPLES, read_bounded

__all__ = ["MAX_TABLE_BYTES", "JointTable", "JointTableError", "read_joint_table", "write_joint_table",
           "joint_table_text"]

Array = npt.NDArray[np.float64]

#: Largest joint-table file, bytes (256 MiB: a 7-joint log of q, qd and tau at 1 kHz for 20 minutes).
MAX_TABLE_BYTES = 256 * 1024 * 1024


class JointTableError(InputError):
    """A joint-table CSV is malformed; the message names the file, the line or column and what was expected."""


@dataclass(frozen=True, eq=False)
class JointTable:
    """Samples read from (or to write to) a joint-table CSV.

    Attributes
    ----------
    t
        (N,) sample times, s, strictly increasing.
    groups
        Quantity name -> (N, n) samples, in file order (e.g. ``{"q": ..., "qd": ...}``).
    joint_names
        (n,) the joints, in chain order.
    path
        The file it was read from ("" when built in memory).
    """

    t: Array
    groups: Mapping[str, Array]
    joint_names: tuple[str, ...]
    path: str = ""

    def __getitem__(self, group: str) -> Array:
        """The (N, n) samples of ``group``."""
        return self.groups[group]

    def __contains__(self, group: object) -> bool:
        return group in self.groups


def _header(groups: Sequence[str], joint_names: Sequence[str]) -> list[str]:
    return ["time"] + [f"{g}_{name}" for g in groups for name in joint_names]


def joint_table_text(t: npt.ArrayLike, groups: Mapping[str, npt.ArrayLike], joint_names: Sequence[str]) -> str:
    """The CSV text of samples ``t`` (N,) and ``groups`` (each (N, n)); values printed with ``repr`` (exact)."""
    tt = np.asarray(t, dtype=float)
    names = list(joint_names)
    blocks = []
    for g, values in groups.items():
        arr = np.asarray(values, dtype=float)
        if arr.shape != (tt.size, len(names)):
            raise InputError(f"expected shape {(tt.size, len(names))}, got {arr.shape}", parameter=f"group {g!r}")
        blocks.append(arr)
    data = np.column_stack([tt] + blocks) if blocks else tt[:, None]
    out = io.StringIO()
    out.write(",".join(_header(list(groups), names)) + "\n")
    for row in data.tolist():
        out.write(",".join(repr(v) for v in row) + "\n")
    return out.getvalue()


def write_joint_table(path: str | Path, t: npt.ArrayLike, groups: Mapping[str, npt.ArrayLike],
                      joint_names: Sequence[str]) -> Path:
    """Write a joint-table CSV atomically (complete or not at all); returns the path."""
    return write_atomic(path, joint_table_text(t, groups, joint_names))


def _fail(path: Path, where: str, message: str) -> JointTableError:
    return JointTableError(f"{path}{where}: {message}")


def read_joint_table(path: str | Path, joint_names: Sequence[str], required: Sequence[str],
                     optional: Sequence[str] = (), *, what: str = "joint table") -> JointTable:
    """Read a joint-table CSV whose header is ``time`` then groups of ``<group>_<joint>`` columns.

    Parameters
    ----------
    path
        The CSV file.
    joint_names
        The robot's joint names (:attr:`model.RobotDescription.joint_names`), in chain order.
    required
        Groups that must be present (e.g. ``("q", "qd", "qdd")``).
    optional
        Groups that may be present as well; any other column is refused.
    what
        What the file is, for messages (``"trajectory file"``, ``"identification data"``).

    Returns
    -------
    JointTable
        Its groups in file order.

    Raises
    ------
    JointTableError
        Naming the file and the column, line or value: a missing, unknown or misplaced column, a non-comma
        separator, a non-numeric or non-finite value, a ragged row, times not strictly increasing, fewer
        than two rows, more than :data:`model.limits.MAX_SAMPLES` rows, a file over :data:`MAX_TABLE_BYTES`.
    """
    p = Path(path)
    raw = read_bounded(p, what, JointTableError, MAX_TABLE_BYTES)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _fail(p, "", f"not UTF-8 text (byte {exc.start}): expected a comma-separated {what}") from None
    lines = [(k, ln) for k, ln in enumerate(text.splitlines(), 1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise _fail(p, "", "empty: expected a header line 'time,...' and rows of numbers")
    head_no, head_line = lines[0]
    for sep, name in ((";", "semicolons"), ("\t", "tabs")):
        if sep in head_line:
            raise _fail(p, f" line {head_no}", f"columns separated by {name}: expected comma-separated values")
    header = [c.strip() for c in next(csv.reader([head_line]))]
    names = list(joint_names)
    allowed = list(required) + [g for g in optional if g not in required]
    expected_cols = {f"{g}_{j}": g for g in allowed for j in names}
    if not header or header[0] != "time":
        raise _fail(p, f" line {head_no}", f"first column {header[0] if header else ''!r}: expected 'time'")
    seen: dict[str, int] = {}
    for col_no, col in enumerate(header[1:], 2):
        if col in seen:
            raise _fail(p, f" line {head_no}", f"column {col!r} appears twice (columns {seen[col]} and {col_no})")
        seen[col] = col_no
        if col not in expected_cols:
            hint = did_you_mean(col, [c for c in expected_cols if c not in header])
            raise _fail(p, f" line {head_no}", f"unknown column {col!r} (column {col_no}): expected 'time' then "
                        f"<group>_<joint> with groups {', '.join(allowed)} and joints {', '.join(names)}{hint}")
    present = [g for g in dict.fromkeys(expected_cols[c] for c in header[1:])]
    for g in required:
        if g not in present:
            raise _fail(p, f" line {head_no}", f"missing columns {g}_{names[0]} .. {g}_{names[-1]}: "
                        f"this {what} needs groups {', '.join(required)}")
    for g in present:
        missing = [f"{g}_{j}" for j in names if f"{g}_{j}" not in seen]
        if missing:
            raise _fail(p, f" line {head_no}", f"missing column {missing[0]!r}: a group has one column per joint")
    if header[1:] != _header(present, names)[1:]:
        raise _fail(p, f" line {head_no}", "columns out of order: expected 'time', then each group's columns "
                    f"together in joint order: {','.join(_header(present, names))}")
    body = lines[1:]
    if len(body) > MAX_SAMPLES:
        raise _fail(p, "", f"{len(body)} rows: more than the sample limit of {MAX_SAMPLES}")
    if len(body) < 2:
        raise _fail(p, "", f"{len(body)} data row(s): expected at least 2")
    width = len(header)
    data = np.empty((len(body), width))
    for r, (line_no, line) in enumerate(body):
        cells = line.split(",")
        if len(cells) != width:
            raise _fail(p, f" line {line_no}", f"{len(cells)} values: expected {width}, one per column of the header")
        for c, cell in enumerate(cells):
            try:
                v = float(cell)
            except ValueError:
                raise _fail(p, f" line {line_no}", f"column {header[c]!r} = {cell.strip()!r}: expected a number"
                            ) from None
            if not math.isfinite(v):
                raise _fail(p, f" line {line_no}", f"column {header[c]!r} = {cell.strip()!r}: expected a finite "
                            "number")
            data[r, c] = v
    t = data[:, 0]
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise _fail(p, f" line {body[k + 1][0]}", f"time {float(t[k + 1])!r} after {float(t[k])!r}: expected strictly "
                    "increasing times")
    n = len(names)
    groups = {g: data[:, 1 + k * n: 1 + (k + 1) * n].copy() for k, g in enumerate(present)}
    for arr in groups.values():
        arr.setflags(write=False)
    t = t.copy()
    t.setflags(write=False)
    return JointTable(t=t, groups=groups, joint_names=tuple(names), path=str(p))
