"""Atomic outputs (model/files.py): complete or absent, with the permissions a plain write gives."""

from __future__ import annotations

import os
import stat

import pytest

from model.files import TEMP_SUFFIX, atomic_path, write_atomic


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def umask_027():
    old = os.umask(0o027)
    yield
    os.umask(old)


def test_a_new_file_gets_0666_less_the_umask(tmp_path, umask_027):
    plain = tmp_path / "plain.txt"
    plain.write_text("x")  # what open(path, "w") gives: the reference, not a number written here
    written = write_atomic(tmp_path / "atomic.txt", "x")
    assert _mode(written) == _mode(plain) == 0o640  # mkstemp alone would give 0o600


def test_a_replaced_file_keeps_its_mode(tmp_path):
    path = tmp_path / "out.json"
    path.write_text("{}")
    os.chmod(path, 0o604)
    write_atomic(path, "{\"a\": 1}")
    assert _mode(path) == 0o604 and path.read_text() == "{\"a\": 1}"


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "out.txt"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(path) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir() if TEMP_SUFFIX in p.name] == []
