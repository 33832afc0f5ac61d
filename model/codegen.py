"""The one CasADi -> C -> compiler pipeline: generate, compile (in parallel), load (ctypes) and cache.

Everything that turns CasADi Functions into machine code goes through here,
the dynamics library of :class:`model.dynamics.Dynamics` as well as the FMUs
of :mod:`fmu.build`:

* compiler discovery, :func:`find_compiler`: ``$CC`` if set, else ``gcc``, else ``cc``;
* the flag policy, :func:`compile_flags`: ``-std=c99 -fPIC -ffp-contract=off
  -Wall -Wextra -Werror``, plus ``-Wno-unused-parameter`` for generated files
  (CasADi's evaluation functions take ``iw``, ``w`` and ``mem`` whether they use
  them or not) and an optimisation level chosen by the size of the file (see
  :func:`optimisation_level`). ``-ffp-contract=off`` is stated explicitly: no
  fused multiply-add, so the compiled code rounds like CasADi's own evaluation
  and results stay bit-identical between optimisation levels and machines
  (tests compare them). No ``-ffast-math``, no ``-march=native``;
* C generation, :func:`generate_c`: :class:`casadi.CodeGenerator` with the
  integer and real types of the one shared header ``model/dynamics/c/casadi_abi.h``
  (included at the top of every generated file and copied next to it; it
  asserts the sizes at compile time, and :class:`CompiledLibrary` checks them
  again when it loads a library).

A library (:func:`build_library`) puts each Function in its own translation
unit, compiles the units in parallel (``$MANIP_BUILD_JOBS``, default the
number of CPUs), links them with the handwritten batch loop
``model/dynamics/c/batch.c`` into one shared object and caches it in
``$MANIP_CACHE_DIR`` (default ``~/.cache/manipulator-workbench``) under a key
that hashes the caller's key material (robot, motor model, model sources), the
generator version, this module's source, the C files of ``model/dynamics/c``,
the CasADi version, the compiler and the flag policy. Files land in the cache
by write-to-temporary then ``os.replace``, so concurrent builds of the same key
are safe: the library first, then its metadata (``.json``, which records the
library's SHA-256 and whose presence marks a complete entry). Before a cached
library is loaded its SHA-256 is checked against the metadata; a mismatch (a
truncated or altered file), unreadable metadata or a library that does not
load deletes the entry, warns once (:class:`CorruptCacheWarning`) and
rebuilds. A ``progress`` callback receives a :class:`BuildEvent` per stage.
"""

from __future__ import annotations

import ctypes
import dataclasses
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import threading
import time
import warnings
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable, Mapping, Sequence

import casadi as ca
import numpy as np

from .errors import InputError, NumericalError, ToolchainError

__all__ = [
    "ABI_HEADER",
    "BASE_CFLAGS",
    "BuildEvent",
    "BuildInfo",
    "CacheFallbackWarning",
    "CASADI_INT",
    "CASADI_REAL",
    "CompileError",
    "CompiledLibrary",
    "CompilerNotFoundError",
    "CorruptCacheWarning",
    "FunctionSignature",
    "GENERATED_CFLAGS",
    "GENERATOR_VERSION",
    "LazyLibrary",
    "NoCompilerWarning",
    "PLANT_STEP_SOURCES",
    "PointEvaluator",
    "Progress",
    "UnitInfo",
    "build_library",
    "build_jobs",
    "cache_dir",
    "casadi_evaluate",
    "compile_flags",
    "compile_objects",
    "find_compiler",
    "generate_c",
    "optimisation_level",
]

#: Bump when the generated code or its layout changes: it is part of every cache key.
GENERATOR_VERSION = "dyn-2"
C_DIR = Path(__file__).resolve().parent / "dynamics" / "c"
BATCH_SOURCE = C_DIR / "batch.c"
#: The fixed-step rule of the plant (``plant_step.c``) and its header: linked into the libraries that
#: integrate the plant (:mod:`model.compiled_plant`, the closed-loop kernel) and shipped in every FMU.
PLANT_STEP_SOURCES = (C_DIR / "plant_step.c", C_DIR / "plant_step.h")
#: The one C header of the CasADi types (``typedef``-like macros and their ``_Static_assert``).
ABI_HEADER = C_DIR / "casadi_abi.h"
#: The C types given to casadi.CodeGenerator; they must match ABI_HEADER (a test reads both).
CASADI_INT = "long long int"
CASADI_REAL = "double"
_CTYPES_INT = ctypes.c_longlong

#: Flags of every compilation (handwritten and generated C).
BASE_CFLAGS: tuple[str, ...] = ("-std=c99", "-fPIC", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror")
#: Flags of CasADi-generated files (unused work arguments are not an error there).
GENERATED_CFLAGS: tuple[str, ...] = BASE_CFLAGS + ("-Wno-unused-parameter",)
#: Optimisation by size of a generated file in CasADi operations (``Function.n_instructions``),
#: largest threshold first. Measured here (gcc 12, x86-64): gcc spends ~0.3 ms of CPU per
#: operation at -O1 and 2-3 times that at -O2/-O3 (register allocation dominates), while the
#: compiled Puma 560 rne, accel and inertia run within noise (+-10 %) at -O1, -O2 and -O3
#: and coriolis fastest at -O1. Small files keep -O2; everything larger is compiled at -O1.
_OPT_POLICY: tuple[tuple[int, str], ...] = ((1500, "-O1"), (0, "-O2"))
_STAMP = "/* Generated by manipulator-workbench model/codegen.py from CasADi {version}: do not edit. */\n"


class CompilerNotFoundError(ToolchainError):
    """No C compiler was found (``$CC`` unset or not on PATH, and no ``gcc``/``cc``)."""


class CompileError(ToolchainError):
    """The C compiler rejected generated code; the message holds the command and its output."""


class CorruptCacheWarning(UserWarning):
    """A cached library did not match its recorded SHA-256 or did not load: it was deleted and rebuilt."""


@dataclass(frozen=True)
class BuildEvent:
    """One step of a build, for a progress display.

    Attributes
    ----------
    stage
        ``"cached"``, ``"symbolic"``, ``"generate"``, ``"compile"``, ``"link"`` or ``"done"``.
    message
        One line for a person (``str(event)`` gives it).
    done, total
        Units finished and to do in a ``"compile"`` stage (0 and 0 elsewhere).
    """

    stage: str
    message: str
    done: int = 0
    total: int = 0

    def __str__(self) -> str:
        return self.message


#: A progress callback: called with each :class:`BuildEvent` of a build.
Progress = Callable[[BuildEvent], None]


@dataclass(frozen=True)
class UnitInfo:
    """One translation unit of a build: its Function, size, optimisation and compile time."""

    name: str
    instructions: int
    c_bytes: int
    optimisation: str
    seconds: float


@dataclass(frozen=True)
class FunctionSignature:
    """Sizes of a generated Function's (dense) inputs and outputs."""

    name: str
    in_names: tuple[str, ...]
    in_sizes: tuple[int, ...]
    out_names: tuple[str, ...]
    out_shapes: tuple[tuple[int, int], ...]

    @classmethod
    def of(cls, f: ca.Function) -> "FunctionSignature":
        return cls(
            name=f.name(),
            in_names=tuple(f.name_in()),
            in_sizes=tuple(int(f.numel_in(i)) for i in range(f.n_in())),
            out_names=tuple(f.name_out()),
            out_shapes=tuple((int(f.size1_out(i)), int(f.size2_out(i))) for i in range(f.n_out())),
        )

    @classmethod
    def from_dict(cls, data: dict) -> "FunctionSignature":
        """Inverse of ``dataclasses.asdict`` after a JSON round trip (lists back to tuples)."""
        return cls(
            name=data["name"],
            in_names=tuple(data["in_names"]),
            in_sizes=tuple(data["in_sizes"]),
            out_names=tuple(data["out_names"]),
            out_shapes=tuple(tuple(shape) for shape in data["out_shapes"]),
        )


@dataclass(frozen=True)
class BuildInfo:
    """What a build did and how long each stage took (seconds).

    ``flags`` are the flags common to every unit; ``units`` gives each
    generated file's optimisation level (empty for a cache hit).
    """

    key: str
    library: Path
    cached: bool
    seconds_symbolic: float
    seconds_generate: float
    seconds_compile: float
    seconds_total: float
    compiler: str
    flags: tuple[str, ...]
    units: tuple[UnitInfo, ...] = ()

    @property
    def c_bytes(self) -> int:
        """Total size of the generated C, bytes (0 for a cache hit)."""
        return sum(u.c_bytes for u in self.units)


class CacheFallbackWarning(RuntimeWarning):
    """The cache folder cannot be written; a temporary folder (gone at exit) is used instead."""


#: Unwritable cache folder -> the temporary folder used instead (one warning per folder and process).
_FALLBACK_CACHE: dict[Path, tempfile.TemporaryDirectory] = {}


def _writable_dir(folder: Path) -> str | None:
    """None if files can be created in ``folder`` (made if missing), else the reason."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".probe-")
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(probe)
    return None


def cache_dir() -> Path:
    """The cache folder: ``$MANIP_CACHE_DIR`` or ``~/.cache/manipulator-workbench``.

    When it cannot be written, a temporary folder of this process is used instead,
    with a one-line :class:`CacheFallbackWarning` (the build is then not cached).
    """
    env = os.environ.get("MANIP_CACHE_DIR")
    folder = Path(env) if env else Path.home() / ".cache" / "manipulator-workbench"
    if folder not in _FALLBACK_CACHE:
        reason = _writable_dir(folder)
        if reason is None:
            return folder
        _FALLBACK_CACHE[folder] = tempfile.TemporaryDirectory(prefix="manip-cache-")
        warnings.warn(f"cache {str(folder)!r} ({'MANIP_CACHE_DIR' if env else 'default'}) is not writable ({reason}); "
                      f"using the temporary cache {_FALLBACK_CACHE[folder].name!r} for this run",
                      CacheFallbackWarning, stacklevel=2)
    return Path(_FALLBACK_CACHE[folder].name)


def find_compiler() -> str:
    """The C compiler command: ``$CC`` if set (it must exist), else ``gcc`` or ``cc`` on PATH."""
    env = os.environ.get("CC")
    candidates = [env] if env else ["gcc", "cc"]
    for cmd in candidates:
        if cmd and shutil.which(cmd):
            return cmd
    raise CompilerNotFoundError(f"no C compiler found (tried {candidates}); install gcc or set CC", parameter="CC")


def build_jobs() -> int:
    """Parallel compiler processes: ``$MANIP_BUILD_JOBS`` if set (>= 1), else the number of CPUs."""
    env = os.environ.get("MANIP_BUILD_JOBS")
    if env:
        try:
            jobs = int(env)
        except ValueError:
            jobs = 0
        if jobs < 1:
            raise InputError(f"expected a whole number >= 1, got {env!r}", parameter="MANIP_BUILD_JOBS")
        return jobs
    return os.cpu_count() or 1


def optimisation_level(instructions: int) -> str:
    """The ``-O`` flag for a generated file of ``instructions`` CasADi operations (see :data:`_OPT_POLICY`)."""
    for threshold, level in _OPT_POLICY:
        if instructions > threshold:
            return level
    return _OPT_POLICY[-1][1]


def compile_flags(*, generated: bool, optimisation: str = "-O2") -> tuple[str, ...]:
    """Flags of one compilation: :data:`GENERATED_CFLAGS` or :data:`BASE_CFLAGS`, then ``optimisation``."""
    return (GENERATED_CFLAGS if generated else BASE_CFLAGS) + (optimisation,)


def _c_identifier(stem: str) -> str:
    name = "".join(ch if ch.isalnum() else "_" for ch in stem)
    return name if name[:1].isalpha() else f"mw_{name}"


def generate_c(functions: Sequence[ca.Function], path: Path, *, with_header: bool = False,
               preamble: str = "") -> Path:
    """Write the C code of ``functions`` to ``path`` with :class:`casadi.CodeGenerator`.

    The file is stamped generated-do-not-edit and includes ``casadi_abi.h``
    (copied next to it) before CasADi's own type definitions. With
    ``with_header``, ``path`` with suffix ``.h`` declares the functions (same
    stamp and include). ``preamble`` goes between the stamp and the include
    (e.g. a symbol-visibility macro). The file stem names the C symbols: it
    must be a C identifier.
    """
    path = Path(path)
    if _c_identifier(path.stem) != path.stem:
        raise InputError(f"expected a file stem that is a C identifier, got {path.stem!r}", parameter="path")
    gen = ca.CodeGenerator(path.name, {"with_header": with_header, "casadi_int": CASADI_INT, "casadi_real": CASADI_REAL})
    for f in functions:
        gen.add(f)
    gen.generate(str(path.parent.resolve()) + os.sep)  # prefix + file name: no os.chdir, which is process-wide
    shutil.copyfile(ABI_HEADER, path.parent / ABI_HEADER.name)
    top = _STAMP.format(version=ca.__version__) + preamble + f'#include "{ABI_HEADER.name}"\n'
    path.write_text(top + path.read_text())
    if with_header:
        header = path.with_suffix(".h")
        header.write_text(top + header.read_text())
    return path


def compile_objects(compiler: str | Sequence[str], jobs_list: Sequence[tuple[Path, Path, Sequence[str]]], *,
                    jobs: int | None = None, on_done: Callable[[int, float], None] | None = None,
                    error: type[Exception] = CompileError) -> list[float]:
    """Compile each ``(source, object, flags)`` with ``compiler -c``, ``jobs`` at a time; seconds per unit.

    ``compiler`` is one command or its words (``["python", "-m", "ziglang", "cc", "-target", ...]``).

    ``on_done(index, seconds)`` is called as each unit finishes. A failure
    raises ``error`` (default :class:`CompileError`) with the command and the
    compiler's output.
    """
    workers = max(1, min(jobs or build_jobs(), len(jobs_list)))
    seconds = [0.0] * len(jobs_list)

    def run(index: int) -> tuple[int, float]:
        source, obj, flags = jobs_list[index]
        cmd = [*([compiler] if isinstance(compiler, str) else compiler), *flags, "-c", str(source), "-o", str(obj)]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise error(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stdout}{proc.stderr[-4000:]}")
        return index, time.perf_counter() - t0

    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(run, i) for i in range(len(jobs_list))]
        try:
            for fut in as_completed(futures):
                index, secs = fut.result()
                seconds[index] = secs
                if on_done is not None:
                    on_done(index, secs)
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
    return seconds


class CompiledLibrary:
    """A loaded shared library of generated Functions with the batch entry point ``mw_batch``.

    Evaluation is re-entrant: work memory is allocated per call inside C.
    """

    def __init__(self, path: Path, signatures: Sequence[FunctionSignature]) -> None:
        self.path = Path(path)
        self._lib = ctypes.CDLL(str(self.path))
        self.signatures = {s.name: s for s in signatures}
        fn = self._lib.mw_batch
        fn.restype = ctypes.c_int
        fn.argtypes = [
            ctypes.c_void_p, ctypes.c_void_p,
            ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_longlong),
            ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_longlong),
            ctypes.c_longlong,
        ]
        self._batch = fn
        for name in self.signatures:  # the run-time twin of casadi_abi.h's _Static_assert
            size = getattr(self._lib, f"{name}_casadi_int_size")()
            if size != ctypes.sizeof(_CTYPES_INT):
                raise CompileError(f"{self.path}: {name} was compiled with a {size}-byte casadi_int, "
                                   f"expected {ctypes.sizeof(_CTYPES_INT)} ({CASADI_INT})")
        self._pointers = {
            name: (
                ctypes.cast(getattr(self._lib, name), ctypes.c_void_p).value,
                ctypes.cast(getattr(self._lib, f"{name}_work"), ctypes.c_void_p).value,
            )
            for name in self.signatures
        }

    def __contains__(self, name: str) -> bool:
        return name in self.signatures

    def entry_points(self, name: str) -> tuple[int, int]:
        """Addresses of Function ``name``'s evaluation and work-size functions (for handwritten C that calls it)."""
        return self._pointers[name]

    def symbol(self, name: str) -> ctypes._CFuncPtr:
        """A C function of the library by name (e.g. the entry point of an ``extra_sources`` file)."""
        return getattr(self._lib, name)

    def point_evaluator(self, name: str, external: Mapping[int, np.ndarray] | None = None) -> "PointEvaluator":
        """A :class:`PointEvaluator` of Function ``name`` (one point per call, buffers allocated once)."""
        return PointEvaluator(self, name, external)

    def evaluate(self, name: str, inputs: Sequence[np.ndarray], n_points: int) -> list[np.ndarray]:
        """Evaluate Function ``name`` at ``n_points`` points in one C call.

        Parameters
        ----------
        inputs
            One array per input, C-contiguous float64, shaped ``(n_points, size)``
            (one row per point) or ``(size,)`` (the same value for every point).

        Returns
        -------
        list of np.ndarray
            One ``(n_points, numel)`` array per output; matrices are column-major in each row.
        """
        sig = self.signatures[name]
        strides = []
        for arr, size, arg in zip(inputs, sig.in_sizes, sig.in_names):
            if arr.dtype != np.float64 or not arr.flags.c_contiguous:
                raise InputError("expected a C-contiguous float64 array", parameter=arg)
            if arr.shape == (size,):
                strides.append(0)
            elif arr.shape == (n_points, size):
                strides.append(size)
            else:
                raise InputError(f"expected shape ({n_points}, {size}) or ({size},), got {arr.shape}", parameter=arg)
        outputs = [np.empty((n_points, r * c)) for r, c in sig.out_shapes]
        n_in, n_out = len(inputs), len(outputs)
        in_ptr = (ctypes.c_void_p * n_in)(*[a.ctypes.data for a in inputs])
        in_str = (ctypes.c_longlong * n_in)(*strides)
        out_ptr = (ctypes.c_void_p * n_out)(*[a.ctypes.data for a in outputs])
        out_str = (ctypes.c_longlong * n_out)(*[o.shape[1] for o in outputs])
        f_ptr, w_ptr = self._pointers[name]
        status = self._batch(f_ptr, w_ptr, n_in, in_ptr, in_str, n_out, out_ptr, out_str, n_points)
        if status != 0:
            raise NumericalError(f"{name}: compiled evaluation failed with status {status}")
        return outputs


def casadi_evaluate(f: ca.Function, inputs: Sequence[np.ndarray], n_points: int) -> np.ndarray:
    """(n_points, numel) first output of ``f`` evaluated by CasADi: the layout of :meth:`CompiledLibrary.evaluate`.

    The evaluation without a C compiler. ``inputs`` as there: ``(n_points, size)`` rows or
    one ``(size,)`` vector shared by every point; matrices are column-major in each row.
    """
    cols = [a.T if a.ndim == 2 else a for a in inputs]
    out = np.array(f.map(n_points)(*cols) if n_points > 1 else f(*cols))  # (rows, cols * n_points)
    rows, cols_per_point = f.size1_out(0), f.size2_out(0)
    return out.reshape(rows, n_points, cols_per_point).transpose(1, 2, 0).reshape(n_points, -1)


class PointEvaluator:
    """One Function of a :class:`CompiledLibrary` evaluated at a single point, everything allocated once.

    The pointer arrays (``arg``, ``res``), the work vectors (``iw``, ``w``), the
    input buffers :attr:`inputs` (views into one contiguous float64 :attr:`block`)
    and the output buffers :attr:`outputs` are built here; a call writes nothing
    but the outputs and calls the generated function directly (the same code,
    ``mem`` 0 and work sizes as ``mw_batch``, so results are bit-identical to
    :meth:`CompiledLibrary.evaluate`).

    Inputs listed in ``external`` are not copied: the evaluator reads the given
    array in place (e.g. the parameter vector), see :meth:`bind`.

    Not thread-safe: calls share the buffers and work vectors. Use one instance
    per thread (the generated code itself is re-entrant).
    """

    __slots__ = ("name", "signature", "block", "inputs", "outputs", "bound", "_lib", "_fn", "_arg", "_res", "_iw", "_w")

    def __init__(self, library: CompiledLibrary, name: str, external: Mapping[int, np.ndarray] | None = None) -> None:
        sig = library.signatures[name]
        external = dict(external or {})
        if not set(external) <= set(range(len(sig.in_sizes))):
            raise InputError(f"external inputs {sorted(external)} out of range 0..{len(sig.in_sizes) - 1}",
                             parameter=name)
        self.name, self.signature, self._lib = name, sig, library
        internal = [j for j in range(len(sig.in_sizes)) if j not in external]
        self.block = np.zeros(sum(sig.in_sizes[j] for j in internal))
        inputs: list[np.ndarray | None] = [None] * len(sig.in_sizes)
        offset = 0
        for j in internal:
            inputs[j] = self.block[offset:offset + sig.in_sizes[j]]
            offset += sig.in_sizes[j]
        self.inputs = tuple(inputs)
        self.outputs = tuple(np.zeros(r * c) for r, c in sig.out_shapes)
        f_ptr, w_ptr = library._pointers[name]
        sizes = [_CTYPES_INT(0) for _ in range(4)]
        work = ctypes.CFUNCTYPE(ctypes.c_int, *[ctypes.POINTER(_CTYPES_INT)] * 4)(w_ptr)
        if work(*[ctypes.byref(s) for s in sizes]) != 0:
            raise ToolchainError(f"{name}: work-size query of the compiled library failed")
        sz_arg, sz_res, sz_iw, sz_w = (s.value for s in sizes)
        if sz_arg < len(sig.in_sizes) or sz_res < len(sig.out_shapes):
            raise ToolchainError(f"{name}: the compiled library's work sizes are smaller than its signature")
        self._arg = (ctypes.c_void_p * sz_arg)()
        self._res = (ctypes.c_void_p * sz_res)(*[o.ctypes.data for o in self.outputs])
        self._iw = (_CTYPES_INT * max(sz_iw, 1))()
        self._w = (ctypes.c_double * max(sz_w, 1))()
        self.bound: list[np.ndarray] = [a for a in self.inputs]  # type: ignore[misc]
        for j, buf in enumerate(self.inputs):
            if buf is not None:
                self._arg[j] = buf.ctypes.data
        for j, arr in external.items():
            self.bind(j, arr)
        # No argtypes: the ctypes arrays pass as pointers and 0 as int, with no per-call conversion.
        self._fn = ctypes.CFUNCTYPE(ctypes.c_int)(f_ptr)

    def bind(self, j: int, array: np.ndarray) -> None:
        """Read input ``j`` from ``array`` in place (kept referenced) from now on."""
        size, arg = self.signature.in_sizes[j], self.signature.in_names[j]
        if self.inputs[j] is not None:
            raise InputError(f"not an external input of {self.name}", parameter=arg)
        if not isinstance(array, np.ndarray) or array.dtype != np.float64 or not array.flags.c_contiguous:
            raise InputError("expected a C-contiguous float64 array", parameter=arg)
        if array.shape != (size,):
            raise InputError(f"expected shape ({size},), got {array.shape}", parameter=arg)
        self._arg[j] = array.ctypes.data
        self.bound[j] = array

    def __call__(self) -> None:
        """Evaluate at the point held by the input buffers; the results land in :attr:`outputs`."""
        status = self._fn(self._arg, self._res, self._iw, self._w, 0)
        if status != 0:
            raise NumericalError(f"{self.name}: compiled evaluation failed with status {status}")


@lru_cache(maxsize=None)
def _source_hash() -> str:
    """SHA-256 of this module and the handwritten C it compiles in: part of every cache key."""
    h = hashlib.sha256()
    for path in (Path(__file__).resolve(), *sorted(C_DIR.iterdir())):
        if path.is_file():
            h.update(path.name.encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def _key(key_material: str, compiler: str, optimisation: str | None) -> str:
    h = hashlib.sha256()
    policy = optimisation or repr(_OPT_POLICY)
    for part in (key_material, GENERATOR_VERSION, ca.__version__, compiler, " ".join(GENERATED_CFLAGS), policy,
                 _source_hash()):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()


@lru_cache(maxsize=None)
def _compiler_version(compiler: str) -> str:
    try:
        return subprocess.run([compiler, "--version"], capture_output=True, text=True, check=False).stdout.splitlines()[0]
    except (OSError, IndexError):
        return compiler


def _file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _load_cached(lib_path: Path, meta_path: Path) -> CompiledLibrary | None:
    """The cached library if its SHA-256 matches the metadata and it loads; else delete the entry, warn, None."""
    try:
        meta = json.loads(meta_path.read_text())
        sigs = [FunctionSignature.from_dict(entry) for entry in meta["functions"]]
        recorded = meta["sha256"]
        actual = _file_sha256(lib_path)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        problem = f"unreadable cache entry ({type(exc).__name__}: {exc})"
    else:
        if actual != recorded:
            problem = f"SHA-256 {actual[:16]}... differs from the recorded {str(recorded)[:16]}... (truncated or altered)"
        else:
            try:
                return CompiledLibrary(lib_path, sigs)
            except (OSError, AttributeError, CompileError) as exc:
                problem = f"does not load ({type(exc).__name__}: {exc})"
    for path in (meta_path, lib_path):  # the metadata first: without it the entry is incomplete
        path.unlink(missing_ok=True)
    message = " ".join(f"{lib_path}: cached library {problem}: deleted, rebuilding".split())
    warnings.warn(message, CorruptCacheWarning, stacklevel=3)
    return None


def _megabytes(n_bytes: int) -> str:
    return f"{n_bytes / 1e6:.2f} MB" if n_bytes >= 1e5 else f"{n_bytes / 1e3:.0f} kB"


def build_library(
    stem: str,
    key_material: str,
    make_functions: Callable[[], Sequence[ca.Function]],
    *,
    directory: Path | None = None,
    force: bool = False,
    optimisation: str | None = None,
    jobs: int | None = None,
    progress: Progress | None = None,
    extra_sources: Sequence[Path] = (),
) -> tuple[CompiledLibrary, BuildInfo]:
    """Load the library for ``key_material`` from the cache, or generate and compile it.

    Parameters
    ----------
    stem
        Readable prefix of the cached file names (e.g. ``"scara-reflected"``); named in progress messages.
    key_material
        Everything the generated code depends on besides the toolchain (robot, motor model, Function set, sources).
    make_functions
        Called only on a cache miss; returns the Functions to generate (its time is ``seconds_symbolic``).
        Their names must be distinct C identifiers: each becomes its own translation unit.
    directory
        Cache folder; :func:`cache_dir` by default.
    force
        Rebuild even if the cache holds the library (the new files replace the old ones).
    optimisation
        One ``-O`` flag for every unit instead of the size policy of :func:`optimisation_level` (part of the key).
    jobs
        Parallel compiler processes; :func:`build_jobs` by default.
    progress
        Called with a :class:`BuildEvent` at each stage (and as each unit finishes compiling).
    extra_sources
        Handwritten C files linked in besides ``batch.c`` (compiled with :data:`BASE_CFLAGS`; their
        contents are part of the key), e.g. the closed-loop kernel; they may include ``casadi_abi.h``
        and the headers listed here too (``.h`` files are copied beside them, not compiled).

    A cached library whose SHA-256 differs from the one recorded at build time, or
    that does not load, is deleted and rebuilt with a :class:`CorruptCacheWarning`.

    Raises
    ------
    CompilerNotFoundError
        No C compiler.
    CompileError
        The compiler failed; the message has its command and output.
    """
    def say(stage: str, message: str, done: int = 0, total: int = 0) -> None:
        if progress is not None:
            progress(BuildEvent(stage, f"{stem}: {message}", done, total))

    t0 = time.perf_counter()
    compiler = find_compiler()
    extra = [Path(x) for x in extra_sources]
    if extra:
        key_material += "|" + ",".join(f"{x.name}:{_file_sha256(x)}" for x in extra)
    key = _key(key_material, f"{compiler} {_compiler_version(compiler)}", optimisation)
    folder = Path(directory) if directory is not None else cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    base = f"{stem}-{key[:20]}"
    lib_path = folder / f"{base}.so"
    meta_path = folder / f"{base}.json"
    cached = _load_cached(lib_path, meta_path) if not force and meta_path.is_file() else None
    if cached is not None:
        total = time.perf_counter() - t0
        say("cached", f"loaded from the cache in {total * 1e3:.0f} ms ({lib_path})")
        return cached, BuildInfo(key, lib_path, True, 0.0, 0.0, 0.0, total, compiler, GENERATED_CFLAGS)

    say("symbolic", "building the symbolic functions")
    t_sym = time.perf_counter()
    functions = list(make_functions())
    names = [f.name() for f in functions]
    bad = [name for name in names if _c_identifier(name) != name or names.count(name) > 1]
    if bad:
        raise InputError(f"expected distinct names that are C identifiers, got {bad}", parameter="functions")
    instructions = {f.name(): int(f.n_instructions()) for f in functions}
    say("symbolic", f"{len(functions)} functions, {sum(instructions.values()):,} operations "
                    f"({', '.join(f'{k} {v:,}' for k, v in instructions.items())})")
    t_gen = time.perf_counter()
    with tempfile.TemporaryDirectory(dir=folder, prefix=f".{base}-") as tmp:
        tmp_dir = Path(tmp)
        src_dir = tmp_dir / "src"
        src_dir.mkdir()
        sources = [generate_c([f], src_dir / f"{f.name()}.c") for f in functions]
        shutil.copyfile(BATCH_SOURCE, src_dir / BATCH_SOURCE.name)
        c_bytes = [s.stat().st_size for s in sources]
        levels = [optimisation or optimisation_level(instructions[f.name()]) for f in functions]
        t_cc = time.perf_counter()
        units = [(src, tmp_dir / f"{src.stem}.o", compile_flags(generated=True, optimisation=lvl))
                 for src, lvl in zip(sources, levels)]
        units.append((src_dir / BATCH_SOURCE.name, tmp_dir / "mw_batch.o", compile_flags(generated=False)))
        for x in extra:
            shutil.copyfile(x, src_dir / x.name)
            if x.suffix != ".h":  # a header is copied beside the sources it is included by
                units.append((src_dir / x.name, tmp_dir / f"mw_extra_{x.stem}.o", compile_flags(generated=False)))
        order = sorted(range(len(units)), key=lambda i: -(c_bytes[i] if i < len(c_bytes) else 0))  # largest first
        units = [units[i] for i in order]
        n_jobs = jobs or build_jobs()
        summary = ", ".join(f"{f.name()} {_megabytes(b)} {lvl}" for f, b, lvl in zip(functions, c_bytes, levels))
        say("generate", f"generated {_megabytes(sum(c_bytes))} of C in {t_cc - t_gen:.1f} s ({summary})")
        say("compile", f"compiling {len(units)} units with {compiler} on {min(n_jobs, len(units))} processes",
            0, len(units))
        finished = [0]

        def on_done(i: int, secs: float) -> None:
            finished[0] += 1
            say("compile", f"compiled {units[i][0].name} in {secs:.1f} s [{finished[0]}/{len(units)}]",
                finished[0], len(units))

        seconds = compile_objects(compiler, units, jobs=n_jobs, on_done=on_done)
        say("link", "linking")
        out = tmp_dir / f"{base}.so"
        cmd = [compiler, "-shared", "-o", str(out), *[str(u[1]) for u in units], "-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise CompileError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-4000:]}")
        t_done = time.perf_counter()
        unit_secs = {u[0].stem: s for u, s in zip(units, seconds)}
        unit_info = tuple(
            UnitInfo(f.name(), instructions[f.name()], b, lvl, unit_secs[f.name()])
            for f, b, lvl in zip(functions, c_bytes, levels)
        )
        sigs = [FunctionSignature.of(f) for f in functions]
        meta = {
            "key": key, "stem": stem, "casadi": ca.__version__, "generator": GENERATOR_VERSION,
            "compiler": compiler, "flags": list(GENERATED_CFLAGS),
            "units": [dataclasses.asdict(u) for u in unit_info],
            "functions": [dataclasses.asdict(s) for s in sigs],
            "sha256": _file_sha256(out),
        }
        meta_tmp = tmp_dir / f"{base}.json"
        meta_tmp.write_text(json.dumps(meta, indent=1))
        src_final = folder / f"{base}-src"
        if src_final.exists():
            shutil.rmtree(src_final, ignore_errors=True)
        try:
            os.replace(src_dir, src_final)
        except OSError:  # a concurrent build put it there first: same content
            pass
        os.replace(out, lib_path)
        os.replace(meta_tmp, meta_path)  # last: its presence marks a complete entry
    library = CompiledLibrary(lib_path, sigs)
    total = time.perf_counter() - t0
    say("done", f"built in {total:.1f} s (symbolic {t_gen - t_sym:.1f} s, C {t_cc - t_gen:.1f} s, "
                f"compile and link {t_done - t_cc:.1f} s): {lib_path}")
    return library, BuildInfo(
        key, lib_path, False, t_gen - t_sym, t_cc - t_gen, t_done - t_cc, total, compiler, GENERATED_CFLAGS, unit_info,
    )


class NoCompilerWarning(RuntimeWarning):
    """No C compiler: the numeric API evaluates with CasADi (correct, but much slower)."""


class LazyLibrary:
    """A library of :func:`build_library` made on first use, or CasADi evaluation without a C compiler.

    The owner (the dynamics or kinematics of one robot) keeps one and evaluates through
    :meth:`backend`: the compiled library, or None after one :class:`NoCompilerWarning`
    saying that ``what`` is evaluated by CasADi instead. Thread-safe.

    Parameters
    ----------
    stem, make_functions
        As in :func:`build_library`.
    key_material
        Called at each :meth:`compile`: the key material of :func:`build_library`.
    what
        What is compiled, in words, for the warning (e.g. ``"the dynamics"``).
    """

    def __init__(self, stem: str, key_material: Callable[[], str],
                 make_functions: Callable[[], Sequence[ca.Function]], what: str) -> None:
        self.stem, self.what = stem, what
        self._key_material, self._make_functions = key_material, make_functions
        self.library: CompiledLibrary | None = None
        self.build_info: BuildInfo | None = None
        self.fallback = False
        self._lock = threading.Lock()

    def compile(self, *, force: bool = False, progress: Progress | None = None) -> BuildInfo:
        """Build (or load from the cache) the library; with ``force`` again even if it is loaded."""
        with self._lock:
            if self.library is not None and not force:
                assert self.build_info is not None
                return self.build_info
            self.library, self.build_info = build_library(self.stem, self._key_material(), self._make_functions,
                                                          force=force, progress=progress)
            self.fallback = False
            return self.build_info

    def backend(self, stacklevel: int = 2) -> CompiledLibrary | None:
        """The compiled library (compiled now if needed), or None without a C compiler (warned once)."""
        if self.library is None and not self.fallback:
            try:
                self.compile()
            except CompilerNotFoundError as exc:
                warnings.warn(f"{exc}; evaluating {self.what} with CasADi instead", NoCompilerWarning,
                              stacklevel=stacklevel + 1)
                self.fallback = True
        return self.library

    def state(self) -> str:
        """``"compiled"``, ``"casadi"`` (no compiler) or ``"not built"``, for a repr."""
        return "compiled" if self.library else ("casadi" if self.fallback else "not built")
