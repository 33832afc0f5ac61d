"""The arms of the example-robot-data collection, one name away: ``erd:ur10``, ``erd:talos_left``, ...

The PyPI package ``example-robot-data`` (the ``robots`` extra: ``pip install
'manipulator-workbench[robots]'``) ships the URDF files of the field's robots; the
catalogue ``model/robots/example-robot-data.toml`` names the arms among them, each
with the ``base_link`` and ``tip_link`` of its chain, and says which robots are not
arms and why. A name is read like a URDF robot file that points at the package's
URDF (:func:`model.urdf.description_from_urdf`), with the base pose of an arm mounted
on a larger robot (a torso, a mount) taken from that robot's URDF at all joints 0.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from .description import BUILTIN_DIR, RobotDescription, RobotDescriptionError, tr2rpy
from .errors import InputError, did_you_mean
from .limits import load_toml

__all__ = ["CATALOGUE", "ERD_PREFIX", "ExtraMissingError", "collection_dir", "erd_description", "erd_names",
           "erd_urdf", "is_erd_name"]

#: The prefix of a robot name from the collection.
ERD_PREFIX = "erd:"
#: The catalogue of the collection's arms (package data).
CATALOGUE = BUILTIN_DIR / "example-robot-data.toml"
_DISTRIBUTION = "example-robot-data"
_INSTALL = "pip install 'manipulator-workbench[robots]'"


class ExtraMissingError(InputError):
    """The ``robots`` extra (the example-robot-data package) is not installed; the message says how to install it."""


def is_erd_name(name: str) -> bool:
    """Whether ``name`` names a robot of the collection (``erd:...``)."""
    return name.startswith(ERD_PREFIX)


@lru_cache(maxsize=1)
def _catalogue() -> dict[str, dict[str, str]]:
    return load_toml(CATALOGUE, "robot catalogue", RobotDescriptionError)


def erd_names() -> tuple[str, ...]:
    """The listed arms, ``erd:``-prefixed, in the catalogue's order (no package needed)."""
    return tuple(ERD_PREFIX + key for key in _catalogue())


@lru_cache(maxsize=1)
def collection_dir() -> Path:
    """The ``robots/`` folder of the installed example-robot-data package.

    Raises
    ------
    ExtraMissingError
        The package is not installed (one line: how to install the extra).
    """
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        dist = distribution(_DISTRIBUTION)
    except PackageNotFoundError:
        raise ExtraMissingError(f"the example-robot-data robots need the robots extra: {_INSTALL}") from None
    marker = "/share/example-robot-data/robots/"
    for file in dist.files or ():
        text = "/" + file.as_posix()
        if marker in text and text.endswith(".urdf"):
            return Path(dist.locate_file(text[1:text.index(marker) + len(marker) - 1]))
    raise ExtraMissingError(f"example-robot-data {dist.version} carries no robots/ folder of URDF files: {_INSTALL}")


def _entry(name: str) -> dict[str, str]:
    key = name[len(ERD_PREFIX):] if is_erd_name(name) else name
    entries = _catalogue()
    if key not in entries:
        hint = did_you_mean(ERD_PREFIX + key, erd_names())
        raise RobotDescriptionError(f"robot {name!r}: not an arm of the example-robot-data catalogue ({CATALOGUE.name}: "
                                    f"`manip robots --all` lists them){hint}")
    return entries[key]


def erd_urdf(name: str) -> Path:
    """The URDF file of the collection's arm ``name`` (``erd:KEY`` or ``KEY``)."""
    return collection_dir() / _entry(name)["urdf"]


def _base_pose(robot: Any, base_link: str) -> np.ndarray:
    """(4, 4) pose of ``base_link`` in the URDF's root frame with every joint at 0 (the origins along the path)."""
    parent = {j.child: j for j in robot.joints}
    T = np.eye(4)
    link = base_link
    while link in parent:
        joint = parent[link]
        if joint.origin is not None:
            T = joint.origin @ T
        link = joint.parent
    return T


def _rest(chain: Any) -> list[float]:
    """0 for each joint, or the middle of its limits when 0 is outside them."""
    rest = []
    for joint in chain.joints:
        lo, hi = joint.qlim if joint.qlim is not None else (-math.inf, math.inf)
        rest.append(0.0 if lo <= 0.0 <= hi else 0.5 * (lo + hi))
    return rest


def erd_description(name: str) -> RobotDescription:
    """The description of the collection's arm ``name`` (``erd:KEY``): its URDF chain, base pose and rest.

    Raises
    ------
    ExtraMissingError
        The robots extra is not installed.
    RobotDescriptionError
        ``name`` is not in the catalogue (with a did-you-mean), or its URDF cannot be read.
    """
    from .urdf import description_from_urdf, read_urdf, serial_chain

    entry = _entry(name)
    key = name[len(ERD_PREFIX):]
    path = erd_urdf(name)
    robot = read_urdf(path)
    chain = serial_chain(robot, path, entry["base_link"], entry["tip_link"])
    data: dict[str, Any] = {"name": f"erd_{key}", "base_link": entry["base_link"], "tip_link": entry["tip_link"],
                            "description": entry["description"], "rest": _rest(chain),
                            # the URDFs' <dynamics> are not motor data (as for the built-ins): no friction
                            "joints": {joint.name: {} for joint in chain.joints},
                            "source": f"{_DISTRIBUTION} {entry['urdf']} (base_link {entry['base_link']}, "
                                      f"tip_link {entry['tip_link']})"}
    T = _base_pose(robot, entry["base_link"])
    if not np.allclose(T, np.eye(4), rtol=0.0, atol=0.0):
        data["base"] = {"xyz": [float(v) for v in T[:3, 3]], "rpy": [float(v) for v in tr2rpy(T[:3, :3])]}
    return description_from_urdf(path, data, f"{name} ({path.name})")
