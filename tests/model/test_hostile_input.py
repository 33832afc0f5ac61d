"""Hostile files: every sample is made here, refused with one line naming the file and the limit, exit status 2.

FMU archives go through ``manip validate-fmu`` in a subprocess (the real entry
point, stderr as a user sees it): absolute and ``..`` member names, a symbolic
link, a huge declared member, a zip bomb's compression ratio, too many members,
an entity-declaring ``modelDescription.xml``. Each run happens in an empty
working folder, and the places an escaping member would land are checked to
stay empty. Robot files, URDFs and waypoint files go through ``manip info``
and ``manip track`` in this process (``main``, stderr captured) and the loaders.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path

import pytest

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from model.description import RobotDescriptionError, description_from_dict
from model.loading import load_description
from model.limits import (
    FMU_RATIO_FLOOR_BYTES,
    MAX_FILE_BYTES,
    MAX_FMU_MEMBER_BYTES,
    MAX_FMU_MEMBERS,
    MAX_FMU_RATIO,
    MAX_JOINTS,
    MAX_WAYPOINTS,
)
from model.tasks import WaypointError, load_waypoints

ROOT = Path(__file__).resolve().parents[2]
MODEL_DESCRIPTION = ('<?xml version="1.0" encoding="UTF-8"?>\n<fmiModelDescription fmiVersion="2.0" modelName="m" '
                     'guid="{00000000-0000-0000-0000-000000000000}"><ModelVariables/><ModelStructure/>'
                     '</fmiModelDescription>\n')


def manip(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, "-m", "workbench.cli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600, check=False)


def assert_refused(proc: subprocess.CompletedProcess, *fragments: str) -> None:
    """Exit status 2, one line on stderr holding every fragment, no traceback."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert proc.stderr.count("\n") == 1, proc.stderr
    for fragment in fragments:
        assert fragment in proc.stderr, (fragment, proc.stderr)


def main_refuses(capsys, args: list[str], *fragments: str) -> str:
    """``manip ARGS`` in this process: exit status 2, one line on stderr holding every fragment."""
    from workbench.cli import main

    status = main(args)
    out, err = capsys.readouterr()
    assert_refused(subprocess.CompletedProcess(args, status, out, err), *fragments)
    return out + err


# ------------------------------------------------------------------------- FMU archives

def fmu_with(path: Path, *members: tuple[zipfile.ZipInfo | str, bytes], description: str = MODEL_DESCRIPTION) -> Path:
    """A zip holding modelDescription.xml and the given members (names or prepared ZipInfo)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("modelDescription.xml", description)
        for info, data in members:
            zf.writestr(info, data)
    return path


def set_declared_size(path: Path, member: str, size: int) -> None:
    """Write ``size`` as the uncompressed size of ``member`` in its local and central headers."""
    raw = bytearray(path.read_bytes())
    name = member.encode()
    # (signature, offset of the uncompressed size, of the name length, of the name) in a local / central header
    for signature, offset, length_at, name_at in ((b"PK\x03\x04", 22, 26, 30), (b"PK\x01\x02", 24, 28, 46)):
        at = raw.find(signature)
        while at >= 0:
            length = int.from_bytes(raw[at + length_at:at + length_at + 2], "little")
            if raw[at + name_at:at + name_at + length] == name:
                raw[at + offset:at + offset + 4] = size.to_bytes(4, "little")
            at = raw.find(signature, at + 4)
    path.write_bytes(bytes(raw))


@pytest.fixture
def work(tmp_path):
    """An empty working folder for the subprocess; it must stay empty."""
    folder = tmp_path / "work"
    folder.mkdir()
    yield folder
    assert list(folder.iterdir()) == []


def escape_targets(tmp_path: Path, name: str) -> list[Path]:
    """Where a member called ``../name`` would land: next to an extraction folder in the temp dir, or above cwd."""
    return [Path(tempfile.gettempdir()) / name, tmp_path / name, tmp_path.parent / name]


def test_absolute_member_is_refused(tmp_path, work):
    target = Path(tempfile.gettempdir()) / f"mw-hostile-{uuid.uuid4().hex}" / "owned.txt"
    fmu = fmu_with(tmp_path / "absolute.fmu", (zipfile.ZipInfo(target.as_posix()), b"owned"))
    proc = manip("validate-fmu", str(fmu), cwd=work)
    assert_refused(proc, f"absolute.fmu: member '{target.as_posix()}': an absolute path: refused")
    assert not target.exists() and not target.parent.exists()


def test_dotdot_member_is_refused(tmp_path, work):
    name = f"mw-hostile-{uuid.uuid4().hex}.txt"
    fmu = fmu_with(tmp_path / "dotdot.fmu", (f"resources/../../{name}", b"owned"))
    proc = manip("validate-fmu", str(fmu), cwd=work)
    assert_refused(proc, f"dotdot.fmu: member 'resources/../../{name}': a '..' component: refused")
    assert not any(p.exists() for p in escape_targets(tmp_path, name))


def test_symlink_member_is_refused(tmp_path, work):
    link = zipfile.ZipInfo("resources/passwd")
    link.create_system = 3
    link.external_attr = (stat.S_IFLNK | 0o777) << 16
    fmu = fmu_with(tmp_path / "link.fmu", (link, b"/etc/passwd"))
    proc = manip("validate-fmu", str(fmu), cwd=work)
    assert_refused(proc, "link.fmu: member 'resources/passwd': a symbolic link: refused, an FMU holds plain files only")


def test_huge_declared_member_is_refused(tmp_path, work):
    fmu = fmu_with(tmp_path / "huge.fmu", ("resources/big.bin", b"x" * 100))
    set_declared_size(fmu, "resources/big.bin", MAX_FMU_MEMBER_BYTES + 1)
    assert zipfile.ZipFile(fmu).getinfo("resources/big.bin").file_size == MAX_FMU_MEMBER_BYTES + 1  # the sample bites
    proc = manip("validate-fmu", str(fmu), cwd=work)
    assert_refused(proc, f"huge.fmu: member 'resources/big.bin': {MAX_FMU_MEMBER_BYTES + 1} bytes uncompressed: "
                         f"larger than the FMU member limit of {MAX_FMU_MEMBER_BYTES} bytes")


def test_zip_bomb_ratio_is_refused(tmp_path, work):
    # 2 MiB of zeros deflate about 1000 times: above the ratio limit, and above the floor that exempts small members
    zeros = bytes(2 * FMU_RATIO_FLOOR_BYTES)
    fmu = fmu_with(tmp_path / "bomb.fmu", ("resources/zeros.bin", zeros))
    info = zipfile.ZipFile(fmu).getinfo("resources/zeros.bin")
    assert info.file_size / info.compress_size > MAX_FMU_RATIO
    proc = manip("validate-fmu", str(fmu), cwd=work)
    assert_refused(proc, "bomb.fmu: member 'resources/zeros.bin': compressed",
                   f"above the FMU compression-ratio limit of {MAX_FMU_RATIO} (a zip bomb)")


def test_too_many_members_are_refused(tmp_path, work):
    fmu = fmu_with(tmp_path / "many.fmu", *[(f"resources/{k}.txt", b"") for k in range(MAX_FMU_MEMBERS)])
    proc = manip("validate-fmu", str(fmu), cwd=work)
    assert_refused(proc, f"many.fmu: {MAX_FMU_MEMBERS + 1} members: more than the FMU member limit of {MAX_FMU_MEMBERS}")


def test_entities_in_the_model_description_are_refused(tmp_path, work):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET-42")
    xxe = MODEL_DESCRIPTION.replace("<fmiModelDescription", f'<!DOCTYPE fmiModelDescription [<!ENTITY leak SYSTEM '
                                    f'"file://{secret.as_posix()}">]>\n<fmiModelDescription', 1).replace('"m"', '"&leak;"')
    fmu = fmu_with(tmp_path / "xxe.fmu", description=xxe)
    proc = manip("validate-fmu", str(fmu), cwd=work)
    assert_refused(proc, "xxe.fmu: modelDescription.xml declares a document type (<!DOCTYPE ...>): refused")
    assert "TOP-SECRET" not in proc.stderr + proc.stdout


def test_backslash_and_duplicate_members_are_refused(tmp_path):
    from fmu.archive import FmuArchiveError, check_fmu_archive

    fmu = fmu_with(tmp_path / "win.fmu", ("resources\\..\\..\\owned.txt", b"x"))
    with pytest.raises(FmuArchiveError, match=r"win.fmu: member .*: a backslash in the name"):
        check_fmu_archive(fmu)
    fmu = tmp_path / "twice.fmu"
    with pytest.warns(UserWarning, match="Duplicate name"):
        fmu_with(fmu, ("resources/a.txt", b"1"), ("resources/a.txt", b"2"))
    with pytest.raises(FmuArchiveError, match=r"twice.fmu: member 'resources/a.txt': stored twice"):
        check_fmu_archive(fmu)


def test_embedded_robot_description_beyond_the_joint_limit_is_refused(tmp_path):
    """resources/robot.json of a stranger's FMU is a robot file too: the joint-count limit holds there."""
    from fmu.robot_resource import description_to_json, read_robot_resource

    long = description_from_dict(tomllib.loads(chain_toml(MAX_JOINTS)), "x.toml")
    doc = json.loads(description_to_json(long))
    doc["description"]["links"].append(doc["description"]["links"][0])
    fmu = fmu_with(tmp_path / "long.fmu", ("resources/robot.json", json.dumps(doc).encode()))
    with pytest.raises(RobotDescriptionError, match=rf"long.fmu: resources/robot.json: {MAX_JOINTS + 1} links: "
                                                    rf"more than the joint-count limit of {MAX_JOINTS}"):
        read_robot_resource(fmu)
    doc["description"]["links"].pop()                                   # at the limit: read
    fmu = fmu_with(tmp_path / "limit.fmu", ("resources/robot.json", json.dumps(doc).encode()))
    assert read_robot_resource(fmu).n == MAX_JOINTS


def test_an_exported_fmu_passes_the_checker():
    """The negative control: what export-fmu writes is inside every limit."""
    from fmu.archive import check_fmu_archive
    from tests.support.fmu_support import trivial_fmu

    check_fmu_archive(trivial_fmu())


# ------------------------------------------------------------------------- robot files

def chain_toml(n: int) -> str:
    link = '[[links]]\njoint = "revolute"\na = 0.1\nalpha = 0.0\nd = 0.0\ntheta = 0.0\nmass = 1.0\n'
    return 'name = "long"\n' + link * n


def test_robot_file_with_too_many_links_is_refused(tmp_path, capsys):
    path = tmp_path / "long.toml"
    path.write_text(chain_toml(MAX_JOINTS + 1))
    main_refuses(capsys, ["info", str(path)], f"long.toml: {MAX_JOINTS + 1} links: more than the joint-count limit of {MAX_JOINTS}")


def test_a_chain_at_the_joint_limit_loads():
    """The limit leaves room for the build-scaling goal (a 25-joint chain builds) and no more is refused."""
    assert MAX_JOINTS >= 25
    desc = description_from_dict(tomllib.loads(chain_toml(MAX_JOINTS)), "limit.toml")
    assert desc.n == MAX_JOINTS


def test_robot_file_too_large_is_refused_unread(tmp_path, capsys):
    path = tmp_path / "big.toml"
    with open(path, "wb") as fh:
        fh.write(chain_toml(2).encode())
        fh.truncate(MAX_FILE_BYTES + 1)  # a sparse file: the size, not the bytes, is what is refused
    main_refuses(capsys, ["info", str(path)], f"big.toml: {MAX_FILE_BYTES + 1} bytes: larger than the robot file size limit of "
                         f"{MAX_FILE_BYTES} bytes")


def test_deeply_nested_toml_is_one_line(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    path.write_text("name = " + "[" * 100_000 + "]" * 100_000 + "\n")
    main_refuses(capsys, ["info", str(path)], "deep.toml: arrays or tables nested too deeply to parse")


def test_task_with_too_many_waypoints_is_refused(tmp_path):
    rows = "[" + ", ".join(["[0.0]"] * (MAX_WAYPOINTS + 1)) + "]"
    path = tmp_path / "tasks.toml"
    path.write_text(chain_toml(1) + f'[[tasks]]\nname = "many"\nwaypoints = {rows}\n')
    with pytest.raises(RobotDescriptionError, match=rf"tasks.toml: tasks\[1\].waypoints: {MAX_WAYPOINTS + 1} "
                                                    rf"waypoints: more than the waypoint limit of {MAX_WAYPOINTS}"):
        load_description(path)


def test_xxe_urdf_through_manip_info(tmp_path, capsys):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET-42")
    path = tmp_path / "xxe.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY leak SYSTEM "file://{secret.as_posix()}">]>\n'
                    '<robot name="&leak;"><link name="b"/></robot>\n')
    printed = main_refuses(capsys, ["info", str(path)], "xxe.urdf: refused: the file declares a document type")
    assert "TOP-SECRET" not in printed


def test_billion_laughs_urdf_through_manip_info(tmp_path, capsys):
    entities = '<!ENTITY lol "lol">' + "".join(
        f'<!ENTITY lol{k} "{("&lol" + (str(k - 1) if k > 1 else "") + ";") * 10}">' for k in range(1, 10))
    path = tmp_path / "laughs.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<!DOCTYPE robot [{entities}]>\n<robot name="&lol9;"><link name="b"/></robot>\n')
    main_refuses(capsys, ["info", str(path)], "laughs.urdf: refused: the file declares a document type")


# ------------------------------------------------------------------------- waypoint files

def test_csv_with_too_many_waypoints_is_refused(tmp_path):
    path = tmp_path / "many.csv"
    path.write_text("q1,q2\n" + "0.1,0.2\n" * (MAX_WAYPOINTS + 1))
    with pytest.raises(WaypointError, match=rf"many.csv: {MAX_WAYPOINTS + 2} lines: more than the waypoint limit "
                                            rf"of {MAX_WAYPOINTS}"):
        load_waypoints(path, "planar2r")
    path.write_text("q1,q2\n" + "0.1,0.2\n" * MAX_WAYPOINTS)  # at the limit: read
    assert load_waypoints(path, "planar2r").waypoints.shape == (MAX_WAYPOINTS, 2)


def test_toml_with_too_many_waypoints_is_refused(tmp_path):
    path = tmp_path / "many.toml"
    path.write_text("waypoints = [" + ", ".join(["[0.1, 0.2]"] * (MAX_WAYPOINTS + 1)) + "]\n")
    with pytest.raises(WaypointError, match=rf"many.toml: {MAX_WAYPOINTS + 1} waypoints: more than the waypoint "
                                            rf"limit of {MAX_WAYPOINTS}"):
        load_waypoints(path, "planar2r")


def test_waypoint_file_too_large_through_manip_track(tmp_path, capsys):
    path = tmp_path / "huge.csv"
    with open(path, "wb") as fh:
        fh.write(b"0.1,0.2\n0.3,0.4\n")
        fh.truncate(MAX_FILE_BYTES + 1)
    main_refuses(capsys, ["track", "planar2r", "--controller", "pd", "--waypoints", str(path), "--out",
                          str(tmp_path / "out")], f"huge.csv: {MAX_FILE_BYTES + 1} bytes: larger than the waypoint file size limit of "
                         f"{MAX_FILE_BYTES} bytes")
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------- compile cache

CACHE_SCRIPT = """
import json, warnings
import casadi as ca
import numpy as np
from model.codegen import CorruptCacheWarning, build_library

x = ca.SX.sym("x", 3)
f = ca.Function("hostile_f", [x], [ca.vertcat(ca.sin(x[0]) * x[1], x[2] ** 3 - x[0] / (1 + x[1] ** 2))])
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    lib, info = build_library("hostile", "hostile-cache-test", lambda: [f])
X = np.random.default_rng(1).standard_normal((50, 3))
y = lib.evaluate("hostile_f", [X], 50)[0]
ref = np.array([np.asarray(f(row)).ravel() for row in X])
print(json.dumps({"cached": info.cached, "library": str(info.library), "error": float(np.max(np.abs(y - ref))),
                  "warnings": [str(w.message) for w in caught if issubclass(w.category, CorruptCacheWarning)]}))
"""


def build_in_subprocess(cache: Path) -> dict:
    """One build of a small Function in a fresh process (a library loaded in this one would stay mapped)."""
    env = {**os.environ, "MANIP_CACHE_DIR": str(cache),
           "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run([sys.executable, "-c", CACHE_SCRIPT], env=env, capture_output=True, text=True, timeout=600,
                          check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


# The compiled C and CasADi's own evaluation do the same operations in the same order with the same libm
# (the codegen tests find them bit-identical); 1e-14 absolute on values of order 1-10 leaves rounding room.
CACHE_ATOL = 1e-14


def test_a_corrupt_cached_library_is_rebuilt(tmp_path):
    cache = tmp_path / "cache"
    first = build_in_subprocess(cache)
    assert not first["cached"] and first["warnings"] == [] and first["error"] <= CACHE_ATOL
    library = Path(first["library"])
    assert build_in_subprocess(cache)["cached"]                         # the entry is used when it is intact
    good = library.read_bytes()

    with open(library, "r+b") as fh:                                     # truncated (an interrupted copy)
        fh.truncate(len(good) // 2)
    again = build_in_subprocess(cache)
    assert not again["cached"] and again["error"] <= CACHE_ATOL
    assert len(again["warnings"]) == 1 and "\n" not in again["warnings"][0]
    assert "cached library SHA-256" in again["warnings"][0] and "(truncated or altered): deleted, rebuilding" in again["warnings"][0]
    assert library.read_bytes() == good                                  # the build is deterministic

    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0x01                                      # one bit, in the middle
    library.write_bytes(bytes(flipped))
    again = build_in_subprocess(cache)
    assert not again["cached"] and again["error"] <= CACHE_ATOL and len(again["warnings"]) == 1
    assert "(truncated or altered)" in again["warnings"][0]

    # a library whose recorded SHA-256 was rewritten to match garbage: the load fails, the entry is rebuilt
    library.write_bytes(b"not a shared object")
    meta_path = library.with_suffix(".json")
    meta = json.loads(meta_path.read_text())
    meta["sha256"] = hashlib.sha256(b"not a shared object").hexdigest()
    meta_path.write_text(json.dumps(meta))
    again = build_in_subprocess(cache)
    assert not again["cached"] and again["error"] <= CACHE_ATOL and len(again["warnings"]) == 1
    assert "cached library does not load (OSError" in again["warnings"][0]
    assert build_in_subprocess(cache)["cached"]


def test_a_binary_that_is_not_a_shared_object_is_a_problem_not_a_crash(tmp_path):
    from fmu.validate import binary_problems

    fmu = fmu_with(tmp_path / "garbage.fmu", ("binaries/linux64/m.so", b"MZ not an ELF file"))
    problems, _ = binary_problems(fmu)
    assert len(problems) == 1 and "binaries/linux64/m.so is not a shared object nm can read" in problems[0]
