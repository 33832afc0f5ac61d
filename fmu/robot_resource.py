"""The robot description carried inside an FMU (``resources/robot.json``).

Validation and the closed-loop tools rebuild the Python model of an FMU from
the FMU alone: the exporter writes the whole :class:`model.RobotDescription`
(every link field, gravity, rest, base and tool, whatever the description
holds) as JSON into ``resources/``, without the path of the file it came from,
so the FMU names nothing of the build machine.
"""

from __future__ import annotations

import dataclasses
import json
import zipfile
from pathlib import Path
from typing import Any
from model.errors import InputError

__all__ = ["ROBOT_RESOURCE", "description_to_json", "description_from_json", "read_robot_resource"]

#: Where the description lives inside the FMU.
ROBOT_RESOURCE = "resources/robot.json"
_FORMAT = "manipulator-workbench robot description 1"


def _plain(value: Any) -> Any:
    """JSON-ready: tuples and mappings to lists and dicts, numpy scalars to floats."""
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict) or hasattr(value, "items"):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (str, bool, int)) or value is None:
        return value
    return float(value)


def _tuples(value: Any) -> Any:
    """Lists back to the tuples of the frozen dataclasses."""
    if isinstance(value, list):
        return tuple(_tuples(v) for v in value)
    return value


def description_to_json(description: Any) -> str:
    """The description as JSON text; ``path`` is left out (the FMU keeps no path of the build machine)."""
    data = {f.name: getattr(description, f.name) for f in dataclasses.fields(description) if f.name != "path"}
    data["links"] = [{f.name: getattr(lk, f.name) for f in dataclasses.fields(lk)} for lk in description.links]
    data["extra"] = dict(description.extra)
    return json.dumps({"format": _FORMAT, "description": _plain(data)}, indent=1, sort_keys=True,
                      allow_nan=False) + "\n"


def description_from_json(text: str, source: str = ROBOT_RESOURCE) -> Any:
    """The :class:`model.RobotDescription` written by :func:`description_to_json`.

    Raises
    ------
    model.RobotDescriptionError
        The text is not such a description (``source`` names where it came from), or it has more
        links than :data:`model.limits.MAX_JOINTS`.
    """
    import types

    from model.description import LinkDescription, RobotDescription, RobotDescriptionError
    from model.limits import MAX_JOINTS

    try:
        doc = json.loads(text)
        if doc.get("format") != _FORMAT:
            raise InputError(f"format {doc.get('format')!r}, expected {_FORMAT!r}")
        data = dict(doc["description"])
        if len(data["links"]) > MAX_JOINTS:
            raise RobotDescriptionError(f"{source}: {len(data['links'])} links: more than the joint-count limit "
                                        f"of {MAX_JOINTS}")
        links = tuple(LinkDescription(**{k: _tuples(v) for k, v in lk.items()}) for lk in data.pop("links"))
        extra = types.MappingProxyType(dict(data.pop("extra", {})))
        return RobotDescription(links=links, extra=extra, path="", **{k: _tuples(v) for k, v in data.items()})
    except RobotDescriptionError:
        raise
    except RecursionError:
        raise RobotDescriptionError(f"{source}: not a robot description of this workbench: nested too deeply") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise RobotDescriptionError(f"{source}: not a robot description of this workbench: {exc}") from None


def read_robot_resource(fmu_path: str | Path) -> Any | None:
    """The description embedded in an FMU, or None if it has none (FMUs of other tools, older exports).

    Raises
    ------
    model.RobotDescriptionError
        The resource is larger than :data:`model.limits.MAX_FILE_BYTES`, not UTF-8, or not a description.
    fmu.archive.FmuArchiveError
        The archive breaks a limit of :mod:`fmu.archive`.
    """
    from model.description import RobotDescriptionError
    from model.limits import MAX_FILE_BYTES

    from .archive import check_fmu_archive

    check_fmu_archive(fmu_path)
    where = f"{fmu_path}: {ROBOT_RESOURCE}"
    with zipfile.ZipFile(fmu_path) as zf:
        if ROBOT_RESOURCE not in zf.namelist():
            return None
        size = zf.getinfo(ROBOT_RESOURCE).file_size
        if size > MAX_FILE_BYTES:
            raise RobotDescriptionError(f"{where}: {size} bytes: larger than the robot file size limit of "
                                        f"{MAX_FILE_BYTES} bytes")
        try:
            text = zf.read(ROBOT_RESOURCE).decode()
        except UnicodeDecodeError as exc:
            raise RobotDescriptionError(f"{where}: not UTF-8 text (byte {exc.start})") from None
    return description_from_json(text, where)
