"""The robot carried inside an FMU (``resources/robot.json``): description, motor model and parameters.

Validation and the closed-loop tools rebuild the Python model of an FMU from
the FMU alone: the exporter writes the robot it exported as JSON into
``resources/``: the whole :class:`model.RobotDescription` (every link field,
gravity, rest, base and tool, whatever the description holds, without the path
of the file it came from, so the FMU names nothing of the build machine), its
motor model and its dynamics parameters (payload, friction, gravity: the FMU
parameters' start values). :func:`read_robot` gives back a :class:`model.Robot`
equal to the exported one. FMUs of format 1 carry the description only.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any
from model.errors import InputError

__all__ = ["ROBOT_RESOURCE", "RobotNotReloadableError", "description_to_json", "description_from_json", "fmu_robot",
           "fmu_robot_digest", "read_robot", "read_robot_resource", "reload_fmu_robot", "robot_from_json",
           "robot_to_json"]

#: Where the description lives inside the FMU.
ROBOT_RESOURCE = "resources/robot.json"
_FORMAT = "manipulator-workbench robot description 1"
#: Format 2: the description of format 1 plus the motor model and the parameters (by name).
_FORMAT_ROBOT = "manipulator-workbench robot 2"


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


def _description_data(description: Any) -> Any:
    data = {f.name: getattr(description, f.name) for f in dataclasses.fields(description) if f.name != "path"}
    data["links"] = [{f.name: getattr(lk, f.name) for f in dataclasses.fields(lk)} for lk in description.links]
    data["extra"] = dict(description.extra)
    return _plain(data)


def _dumps(doc: dict[str, Any]) -> str:
    return json.dumps(doc, indent=1, sort_keys=True, allow_nan=False) + "\n"


def description_to_json(description: Any) -> str:
    """The description as JSON text (format 1); ``path`` is left out (the FMU keeps no path of the build machine)."""
    return _dumps({"format": _FORMAT, "description": _description_data(description)})


def robot_to_json(robot: Any) -> str:
    """A :class:`model.Robot` as JSON text (format 2): its description, motor model and parameters by name."""
    return _dumps({"format": _FORMAT_ROBOT, "description": _description_data(robot.description),
                   "motor_model": robot.motor_model, "parameters": robot.parameters.as_dict()})


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
        if doc.get("format") not in (_FORMAT, _FORMAT_ROBOT):
            raise InputError(f"format {doc.get('format')!r}, expected {_FORMAT_ROBOT!r} or {_FORMAT!r}")
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


def robot_from_json(text: str, source: str = ROBOT_RESOURCE, motor_model: str = "reflected") -> Any:
    """The :class:`model.Robot` written by :func:`robot_to_json` (its motor model and parameters); for a
    format-1 text (a description only) the robot with ``motor_model`` and the description's parameters.

    Raises
    ------
    model.RobotDescriptionError
        Not such a robot (``source`` names where it came from): a bad description, motor model or
        parameter set (names other than the description's, values out of range).
    """
    from model import Robot
    from model.description import RobotDescriptionError

    description = description_from_json(text, source)
    doc = json.loads(text)
    if doc.get("format") != _FORMAT_ROBOT:
        return Robot(description, motor_model=motor_model)
    try:
        robot = Robot(description, motor_model=doc["motor_model"])
        values = doc["parameters"]
        layout = robot.parameters.layout
        if not isinstance(values, dict) or sorted(values) != sorted(layout.names):
            raise InputError(f"parameters: expected the names {list(layout.names)}")
        return robot.with_parameters(type(robot.parameters)(layout, [float(values[k]) for k in layout.names]))
    except (ValueError, KeyError, TypeError) as exc:
        raise RobotDescriptionError(f"{source}: not a robot of this workbench: {exc}") from None


def read_robot(fmu_path: str | Path, motor_model: str = "reflected") -> Any | None:
    """The :class:`model.Robot` embedded in an FMU (description, motor model, parameters), or None if it has
    none; a format-1 resource gives the description's robot with ``motor_model``. Raises as
    :func:`read_robot_resource`."""
    text = _resource_text(fmu_path)
    return None if text is None else robot_from_json(text, f"{fmu_path}: {ROBOT_RESOURCE}", motor_model)


def read_robot_resource(fmu_path: str | Path) -> Any | None:
    """The description embedded in an FMU, or None if it has none (FMUs of other tools, older exports).

    Raises
    ------
    model.RobotDescriptionError
        The resource is larger than :data:`model.limits.MAX_FILE_BYTES`, not UTF-8, or not a description.
    fmu.archive.FmuArchiveError
        The archive breaks a limit of :mod:`fmu.archive`.
    """
    text = _resource_text(fmu_path)
    return None if text is None else description_from_json(text, f"{fmu_path}: {ROBOT_RESOURCE}")


def _resource_text(fmu_path: str | Path) -> str | None:
    from model.description import RobotDescriptionError
    from model.limits import MAX_FILE_BYTES

    from .opened import open_fmu

    where = f"{fmu_path}: {ROBOT_RESOURCE}"
    with open_fmu(fmu_path, validate=False) as fmu:
        size = fmu.member_size(ROBOT_RESOURCE)
        if size is None:
            return None
        if size > MAX_FILE_BYTES:
            raise RobotDescriptionError(f"{where}: {size} bytes: larger than the robot file size limit of "
                                        f"{MAX_FILE_BYTES} bytes")
        data = fmu.member(ROBOT_RESOURCE)
    assert data is not None  # the member exists: its size was read
    try:
        return data.decode()
    except UnicodeDecodeError as exc:
        raise RobotDescriptionError(f"{where}: not UTF-8 text (byte {exc.start})") from None


# ------------------------------------------------- the robot an FMU records

def _robot_node(fmu_path: str | os.PathLike[str]) -> Any:
    from defusedxml.ElementTree import fromstring  # no entities, no external references

    from .opened import open_fmu

    with open_fmu(fmu_path, validate=False) as fmu:
        root = fromstring(fmu.model_description_xml())
    node = root.find("./VendorAnnotations/Tool[@name='manipulator-workbench']/Robot")  # FMI 2.0
    if node is None:
        node = root.find("./Annotations/Annotation[@type='manipulator-workbench']/Robot")  # FMI 3.0
    if node is None or not node.get("name"):
        return None
    return node


def fmu_robot(fmu_path: str | os.PathLike[str]) -> tuple[str, str] | None:
    """``(robot, motor_model)`` recorded in the FMU's VendorAnnotations, or None for other FMUs."""
    node = _robot_node(fmu_path)
    if node is None:
        return None
    return node.get("name", ""), node.get("motorModel", "reflected")


def fmu_robot_digest(fmu_path: str | os.PathLike[str]) -> str | None:
    """The description digest recorded with the robot (``RobotDescription.digest()``), or None."""
    node = _robot_node(fmu_path)
    return None if node is None else node.get("digest") or None


class RobotNotReloadableError(InputError):
    """The robot recorded in an FMU does not load again as the robot the FMU was built from."""


def reload_fmu_robot(fmu_path: str | os.PathLike[str]) -> Any:
    """The robot the FMU was built from, from the FMU alone; None if it records none.

    The robot embedded as ``resources/robot.json`` is loaded: its description, motor model and
    parameters (:func:`fmu.robot_resource.read_robot`), equal to the exported robot (FMUs exported
    before the resource: the built-in robot of the recorded name; before the parameters were
    embedded: the description's parameters). The description's digest must equal the one recorded
    in the VendorAnnotations.

    Raises
    ------
    RobotNotReloadableError
        The digests differ (the resource was edited, or an older FMU of a
        modified robot that kept a built-in name).
    model.RobotDescriptionError
        The embedded description does not load, or (older FMUs) the name is
        not a built-in robot.
    """
    from model import Robot
    from model.loading import load_description

    recorded = fmu_robot(fmu_path)
    if recorded is None:
        return None
    name, motor_model = recorded
    robot = read_robot(fmu_path, motor_model)
    if robot is None:
        robot = Robot(load_description(name), motor_model=motor_model)
    digest = fmu_robot_digest(fmu_path)
    if digest is not None and robot.description.digest() != digest:
        raise RobotNotReloadableError(
            f"the FMU was built from a modified description (digest {digest[:16]}), not the one {name!r} "
            f"loads now (digest {robot.description.digest()[:16]})")
    return robot
