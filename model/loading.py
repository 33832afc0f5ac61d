"""Robot files to descriptions: a built-in name, a robot TOML or a URDF file, dispatched to its reader.

:mod:`model.description` builds and validates a description from TOML data and
:mod:`model.urdf` from a URDF file; this module, above both, picks the reader.
"""

from __future__ import annotations

from pathlib import Path

from .description import BUILTIN_DIR, BUILTIN_ROBOTS, RobotDescription, RobotDescriptionError, description_from_dict
from .errors import did_you_mean
from .example_robots import erd_description, is_erd_name
from .limits import load_toml
from .urdf import description_from_urdf, description_from_urdf_toml

__all__ = ["load_description"]


def load_description(name_or_path: str | Path) -> RobotDescription:
    """Load a built-in robot by name (see :data:`BUILTIN_ROBOTS`), an arm of the example-robot-data
    collection (``erd:ur10``: :mod:`model.example_robots`), a TOML file or a ``.urdf`` file by path."""
    text_name = str(name_or_path)
    if is_erd_name(text_name) and not Path(text_name).exists():
        return erd_description(text_name)
    if text_name in BUILTIN_ROBOTS:
        path = BUILTIN_DIR / f"{text_name}.toml"
    else:
        path = Path(name_or_path)
        if path.is_dir():
            raise RobotDescriptionError(f"{path}: is a directory: expected a built-in robot name or a robot TOML or URDF file")
        if not path.is_file():
            hint = did_you_mean(text_name, BUILTIN_ROBOTS) if not path.suffix and len(path.parts) == 1 else ""
            raise RobotDescriptionError(
                f"robot {text_name!r}: expected a built-in name ({', '.join(BUILTIN_ROBOTS)}) or a TOML file path; "
                f"no such file{hint}"
            )
    if path.suffix.lower() == ".urdf":
        return description_from_urdf(path)
    data = load_toml(path, "robot file", RobotDescriptionError)
    if "urdf" in data:  # a TOML that points at a URDF and adds what URDF lacks
        return description_from_urdf_toml(data, path)
    return description_from_dict(data, str(path))
