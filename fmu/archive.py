"""The FMU archive checker: a user's FMU is inspected before anything is extracted or loaded.

An FMU is a zip archive from whoever sent it. :func:`check_fmu_archive` reads
its central directory (and ``modelDescription.xml``, with ``defusedxml``) and
refuses, with one line naming the file, the member and the limit:

* a file that is not a zip archive, or has no ``modelDescription.xml``;
* more than :data:`~model.limits.MAX_FMU_MEMBERS` members, a member above
  :data:`~model.limits.MAX_FMU_MEMBER_BYTES` or a total above
  :data:`~model.limits.MAX_FMU_TOTAL_BYTES` uncompressed, a member above
  :data:`~model.limits.FMU_RATIO_FLOOR_BYTES` compressed more than
  :data:`~model.limits.MAX_FMU_RATIO` times (a zip bomb);
* member names that leave the extraction folder: absolute (``/x``, ``C:x``),
  with a ``..`` component, or with backslashes (a Windows separator);
  duplicate names;
* symbolic links and other special files (the Unix mode in the external
  attributes), encrypted members, compression other than stored and deflate;
* a ``modelDescription.xml`` with a document type declaration (entities that
  could read local files or expand without bound), or one that is not
  well-formed XML.

Every function of :mod:`fmu` that opens a user's FMU (validation, FMPy runs,
libcosim runs, the embedded robot description) calls it first. It costs
milliseconds (Puma 560 FMU, 27 kB of XML: 17 ms, of which 2 ms the zip and 9 ms
the XML parse, measured on a loaded 2-core machine), against seconds for what
follows it.
"""

from __future__ import annotations

import os
import re
import stat
import zipfile
from pathlib import Path
from xml.etree.ElementTree import ParseError

from model.errors import InputError
from model.limits import (
    FMU_RATIO_FLOOR_BYTES,
    MAX_FMU_MEMBER_BYTES,
    MAX_FMU_MEMBERS,
    MAX_FMU_RATIO,
    MAX_FMU_TOTAL_BYTES,
)

__all__ = ["FmuArchiveError", "check_fmu_archive", "model_description_xml", "MODEL_DESCRIPTION"]

#: The one member every FMU has.
MODEL_DESCRIPTION = "modelDescription.xml"
_ALLOWED_COMPRESSION = (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED)
_DRIVE = re.compile(r"^[A-Za-z]:")


class FmuArchiveError(InputError):
    """An FMU archive breaks a limit or a rule of :mod:`fmu.archive`; the message names the file and the member."""


def _name_problem(name: str) -> str | None:
    """Why a member name could leave the extraction folder, or None."""
    if name.startswith(("/", "\\")) or _DRIVE.match(name):
        return "an absolute path"
    if "\\" in name:
        return "a backslash in the name (a Windows path separator)"
    if "\0" in name:
        return "a NUL character in the name"
    if ".." in name.split("/"):
        return "a '..' component"
    return None


def _type_problem(info: zipfile.ZipInfo) -> str | None:
    """Why a member is not a plain file or folder, or None."""
    mode = info.external_attr >> 16
    if info.create_system == 3 and mode:  # Unix attributes: the file type is in the high bits
        kind = stat.S_IFMT(mode)
        if stat.S_ISLNK(mode):
            return "a symbolic link"
        if kind not in (0, stat.S_IFREG, stat.S_IFDIR):
            return f"a special file (mode {oct(mode)})"
    if info.flag_bits & 0x1:
        return "encrypted"
    if info.compress_type not in _ALLOWED_COMPRESSION:
        return f"compression method {info.compress_type} (expected stored or deflate)"
    return None


def check_fmu_archive(fmu_path: str | os.PathLike[str]) -> None:
    """Refuse an FMU archive that could harm whoever extracts it (see the module docstring).

    Nothing is extracted: only the central directory and ``modelDescription.xml``
    are read.

    Raises
    ------
    FmuArchiveError
        One line: ``"<file>: member '<name>': <what>: <limit>"`` or ``"<file>: <what>"``.
    """
    import defusedxml
    import defusedxml.ElementTree as safe_et

    path = Path(fmu_path)
    if not path.is_file():
        raise FmuArchiveError(f"not an FMU: {path} is not a file")
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise FmuArchiveError(f"not an FMU: {path} is not a zip archive ({exc})") from None
    with zf:
        infos = zf.infolist()
        if len(infos) > MAX_FMU_MEMBERS:
            raise FmuArchiveError(f"{path}: {len(infos)} members: more than the FMU member limit of {MAX_FMU_MEMBERS}")
        seen: set[str] = set()
        total = 0
        for info in infos:
            name = info.filename
            where = f"{path}: member {name!r}"
            problem = _name_problem(name)
            if problem is not None:
                raise FmuArchiveError(f"{where}: {problem}: refused, every member must stay inside the FMU's folder")
            if name in seen:
                raise FmuArchiveError(f"{where}: stored twice: refused, member names must be unique")
            seen.add(name)
            problem = _type_problem(info)
            if problem is not None:
                raise FmuArchiveError(f"{where}: {problem}: refused, an FMU holds plain files only")
            if info.file_size > MAX_FMU_MEMBER_BYTES:
                raise FmuArchiveError(f"{where}: {info.file_size} bytes uncompressed: larger than the FMU member "
                                      f"limit of {MAX_FMU_MEMBER_BYTES} bytes")
            if info.file_size > FMU_RATIO_FLOOR_BYTES and info.file_size > MAX_FMU_RATIO * max(info.compress_size, 1):
                ratio = info.file_size / max(info.compress_size, 1)
                raise FmuArchiveError(f"{where}: compressed {ratio:.0f} times: above the FMU compression-ratio limit "
                                      f"of {MAX_FMU_RATIO} (a zip bomb)")
            total += info.file_size
            if total > MAX_FMU_TOTAL_BYTES:
                raise FmuArchiveError(f"{path}: more than {MAX_FMU_TOTAL_BYTES} bytes uncompressed: above the FMU "
                                      f"size limit (at member {name!r})")
        if MODEL_DESCRIPTION not in seen:
            raise FmuArchiveError(f"not an FMU: {path} has no {MODEL_DESCRIPTION}")
        try:
            xml = zf.read(MODEL_DESCRIPTION)
        except (zipfile.BadZipFile, OSError, EOFError) as exc:  # a CRC or header mismatch
            raise FmuArchiveError(f"{path}: member {MODEL_DESCRIPTION!r} does not read back: {exc}") from None
    try:
        safe_et.fromstring(xml, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except (defusedxml.DTDForbidden, defusedxml.EntitiesForbidden, defusedxml.ExternalReferenceForbidden):
        raise FmuArchiveError(f"{path}: {MODEL_DESCRIPTION} declares a document type (<!DOCTYPE ...>): refused, its "
                              "entities could read other files or expand without bound") from None
    except ParseError as exc:
        raise FmuArchiveError(f"{path}: {MODEL_DESCRIPTION} is not well-formed XML: {exc}") from None


def model_description_xml(fmu_path: str | os.PathLike[str]) -> bytes:
    """The ``modelDescription.xml`` of an FMU, after :func:`check_fmu_archive`.

    Raises
    ------
    FmuArchiveError
        A ValueError naming the file: not an FMU, or an archive that breaks a limit.
    """
    check_fmu_archive(fmu_path)
    with zipfile.ZipFile(fmu_path) as zf:
        return zf.read(MODEL_DESCRIPTION)
