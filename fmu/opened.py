"""One opened FMU: the archive checked once, its model description, its variables by name, its extracted folder.

Every module that reads a user's FMU (validation, the closed-loop masters, the controller FMUs, the FMPy
and libcosim runs, the tests) opens it here and nowhere else::

    with open_fmu("puma560.fmu") as fmu:                 # an OpenedFmu
        fmu.fmi_version, fmu.interfaces, fmu.select(["q[1]", "q[2]"]).vrs
        with fmu.instance("cs", "plant") as inst:        # an fmu.instance.Instance
            inst.start(0.0)

:func:`open_fmu` runs :func:`fmu.archive.check_fmu_archive` (limits, paths, links, zip bombs) before FMPy
reads ``modelDescription.xml``, so a hostile archive is refused before anything is parsed with FMPy or
extracted. The archive is extracted once, on first need (an instance, :attr:`OpenedFmu.unzip_dir`), into a
temporary folder that :meth:`OpenedFmu.close` removes.

Variables are addressed by scalar name in both FMI versions: ``q[2]`` is variable ``q[2]`` of an FMI 2.0 FMU
and element 2 of the array ``q`` of an FMI 3.0 one (:meth:`OpenedFmu.select`).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from model.errors import InputError

from .archive import MODEL_DESCRIPTION, check_fmu_archive
from .selection import Selection

if TYPE_CHECKING:
    from .instance import Instance

__all__ = ["OpenedFmu", "Selection", "open_fmu"]

#: The interface names of this module: Co-Simulation and Model Exchange.
KINDS = ("cs", "me")


def _size(variable: Any) -> int:
    """Number of elements of an FMPy model variable (1 for a scalar)."""
    dims = getattr(variable, "dimensions", None)
    return int(np.prod([d.start for d in dims])) if dims else 1


class OpenedFmu:
    """An FMU archive checked by :func:`fmu.archive.check_fmu_archive` and read by FMPy; use :func:`open_fmu`.

    Attributes
    ----------
    path
        The archive.
    md
        FMPy's ``ModelDescription``.
    fmi_version
        2 or 3.
    interfaces
        ``{"cs": modelIdentifier, "me": modelIdentifier}`` for the interfaces the FMU has.
    variables
        FMPy's model variables by name.
    """

    def __init__(self, path: Path, md: Any, fmi_version: int) -> None:
        self.path = path
        self.md = md
        self.fmi_version = fmi_version
        self.interfaces = {kind: getattr(md, attr).modelIdentifier
                           for kind, attr in (("cs", "coSimulation"), ("me", "modelExchange"))
                           if getattr(md, attr) is not None}
        self.variables = {v.name: v for v in md.modelVariables}
        self._unzip: str | None = None
        self._own_unzip = False

    # ------------------------------------------------------------------ description

    @property
    def name(self) -> str:
        """The file name (for messages)."""
        return self.path.name

    @property
    def guid(self) -> str:
        """The GUID (FMI 2.0) or instantiation token (FMI 3.0)."""
        return str(self.md.guid)

    @property
    def default_step(self) -> float | None:
        """The ``DefaultExperiment`` step size in s, or None."""
        de = self.md.defaultExperiment
        return float(de.stepSize) if de is not None and de.stepSize is not None else None

    @property
    def n_states(self) -> int:
        """Number of continuous states (scalars)."""
        return int(self.md.numberOfContinuousStates)

    @property
    def n_event_indicators(self) -> int:
        """Number of event indicators."""
        return int(self.md.numberOfEventIndicators)

    def has(self, name: str) -> bool:
        """Whether the scalar ``name`` exists (``q[2]``: a variable of FMI 2.0, an array element of FMI 3.0)."""
        try:
            self.select([name])
        except InputError:
            return False
        return True

    def vr(self, name: str) -> int:
        """The value reference of the variable ``name`` (a whole variable: ``q`` in FMI 3.0, ``q[1]`` in 2.0)."""
        variable = self.variables.get(name)
        if variable is None:
            raise InputError(f"{self.name}: no variable {name!r}", parameter="name")
        return int(variable.valueReference)

    def names(self, causality: str | None = None, variability: str | None = None) -> list[str]:
        """Scalar names (``q[1]`` .. for an FMI 3.0 array ``q``) by value reference, filtered by causality
        and variability when given."""
        out: list[str] = []
        for v in sorted(self.md.modelVariables, key=lambda v: v.valueReference):
            if causality is not None and v.causality != causality:
                continue
            if variability is not None and v.variability != variability:
                continue
            size = _size(v) if getattr(v, "dimensions", None) else 0
            out += [f"{v.name}[{k}]" for k in range(1, size + 1)] if size else [v.name]
        return out

    def select(self, names: Sequence[str]) -> Selection:
        """Resolve scalar ``names`` to value references (see :class:`Selection`).

        Raises
        ------
        model.errors.InputError
            A name the FMU does not have, naming the file and every missing name.
        """
        vrs: list[int] = []
        sizes: list[int] = []
        offsets: dict[int, int] = {}
        where: list[int] = []
        missing: list[str] = []
        for name in names:
            variable, index = self.variables.get(name), 0
            if variable is None and self.fmi_version >= 3 and name.endswith("]") and "[" in name:
                base, _, tail = name[:-1].partition("[")
                variable = self.variables.get(base)
                try:
                    index = int(tail) - 1
                except ValueError:
                    variable = None
                if variable is not None and not 0 <= index < _size(variable):
                    variable = None
            if variable is None:
                missing.append(name)
                continue
            vr = int(variable.valueReference)
            if vr not in offsets:
                offsets[vr] = sum(sizes)
                vrs.append(vr)
                sizes.append(_size(variable) if self.fmi_version >= 3 else 1)
            where.append(offsets[vr] + index)
        if missing:
            raise InputError(f"{self.name}: no variable{'s' if len(missing) > 1 else ''} "
                             f"{', '.join(repr(m) for m in missing)}", parameter="names")
        return Selection(tuple(names), tuple(vrs), tuple(sizes), tuple(where))

    def derivative_names(self) -> list[str]:
        """Scalar names of the state derivatives in state order (``der(q[1])`` in FMI 2.0, ``der(q)[1]`` in 3.0)."""
        out: list[str] = []
        for d in self.md.derivatives:
            v = d.variable
            size = _size(v) if self.fmi_version >= 3 and getattr(v, "dimensions", None) else 0
            out += [f"{v.name}[{k}]" for k in range(1, size + 1)] if size else [v.name]
        return out

    def start_values(self, names: Sequence[str]) -> np.ndarray:
        """The ``start`` attributes of scalar ``names`` as floats (NaN where none is given)."""
        out = np.full(len(names), np.nan)
        for i, name in enumerate(names):
            sel = self.select([name])
            start = self.variables[self.md_name(sel.vrs[0])].start
            if start is None:
                continue
            values = str(start).split() if self.fmi_version >= 3 else [str(start)]
            k = sel.where[0]
            out[i] = float(values[k] if k < len(values) else values[0])
        return out

    def md_name(self, vr: int) -> str:
        """The variable name of value reference ``vr`` (the first, for aliases)."""
        for v in self.md.modelVariables:
            if int(v.valueReference) == vr:
                return v.name
        raise InputError(f"{self.name}: no variable with value reference {vr}", parameter="vr")

    # ------------------------------------------------------------------ archive

    def member(self, name: str) -> bytes | None:
        """The bytes of archive member ``name`` (its size already checked by the archive check), or None."""
        with zipfile.ZipFile(self.path) as zf:
            try:
                return zf.read(name)
            except KeyError:
                return None

    def member_size(self, name: str) -> int | None:
        """The uncompressed size in bytes of archive member ``name`` (as its header declares it), or None."""
        with zipfile.ZipFile(self.path) as zf:
            try:
                return zf.getinfo(name).file_size
            except KeyError:
                return None

    def members(self) -> list[str]:
        """Every member name of the archive."""
        with zipfile.ZipFile(self.path) as zf:
            return zf.namelist()

    def model_description_xml(self) -> bytes:
        """The raw ``modelDescription.xml``."""
        data = self.member(MODEL_DESCRIPTION)
        assert data is not None  # the archive check requires it
        return data

    @property
    def unzip_dir(self) -> str:
        """The extracted folder (extracted on first use, removed by :meth:`close`)."""
        if self._unzip is None:
            self.extract_to(tempfile.mkdtemp(prefix="mw_fmu_"))
            self._own_unzip = True
        assert self._unzip is not None
        return self._unzip

    def extract_to(self, folder: str | os.PathLike[str]) -> str:
        """Extract into ``folder`` (kept by :meth:`close`: it is the caller's) and use it from now on."""
        from fmpy import extract

        self._unzip = str(extract(str(self.path), unzipdir=str(folder)))
        self._own_unzip = False
        return self._unzip

    # ------------------------------------------------------------------ instances

    def instance(self, kind: str = "cs", name: str | None = None, *, logging_on: bool = False) -> "Instance":
        """A new, not yet instantiated :class:`fmu.instance.Instance` of interface ``kind`` ("cs" or "me").

        Raises
        ------
        model.errors.InputError
            The FMU has no such interface.
        """
        from .instance import Instance

        if kind not in KINDS:
            raise InputError(f"expected an interface in {KINDS}, got {kind!r}", parameter="kind")
        if kind not in self.interfaces:
            label = "Co-Simulation" if kind == "cs" else "Model Exchange"
            raise InputError(f"{self.name} has no {label} interface", parameter="kind")
        return Instance(self, kind, name or f"{self.interfaces[kind]}_{kind}", logging_on=logging_on)

    def close(self) -> None:
        """Remove the extracted folder if this object made it."""
        if self._unzip is not None and self._own_unzip:
            shutil.rmtree(self._unzip, ignore_errors=True)
        self._unzip = None

    def __enter__(self) -> "OpenedFmu":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"OpenedFmu({str(self.path)!r}, FMI {self.fmi_version}, {sorted(self.interfaces)})"


def open_fmu(path: str | os.PathLike[str], *, validate: bool = True, parameter: str = "fmu_path") -> OpenedFmu:
    """Check the archive at ``path`` and read its model description (see the module docstring).

    ``validate``: FMPy's schema check of the description (its default); ``validate-fmu`` opens without it
    after reporting the schema's problems itself.

    Raises
    ------
    fmu.archive.FmuArchiveError
        Not a file, not a zip archive, or an archive that breaks a limit (one line naming the file and member).
    model.errors.InputError
        A model description FMPy cannot read, or an FMI version other than 2.0 and 3.0.
    """
    from fmpy import read_model_description

    fmu_path = Path(path)
    check_fmu_archive(fmu_path)
    try:
        md = read_model_description(str(fmu_path), validate=validate)
    except Exception as exc:  # FMPy raises plain Exceptions for descriptions it cannot read
        raise InputError(f"{fmu_path}: {MODEL_DESCRIPTION} cannot be read: {exc}", parameter=parameter) from None
    version = str(md.fmiVersion)
    if not version.startswith(("2.", "3.")):
        raise InputError(f"{fmu_path}: FMI version {version!r}: expected 2.0 or 3.0", parameter=parameter)
    return OpenedFmu(fmu_path, md, 3 if version.startswith("3.") else 2)
