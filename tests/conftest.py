"""Shared fixtures: a per-session compiled-code cache, so test runs start cold and leave ~/.cache alone."""

from __future__ import annotations

import os

import pytest


@pytest.fixture(scope="session", autouse=True)
def manip_cache_dir(tmp_path_factory):
    """Point ``MANIP_CACHE_DIR`` at a fresh folder for the whole session."""
    path = tmp_path_factory.mktemp("manip-cache")
    old = os.environ.get("MANIP_CACHE_DIR")
    os.environ["MANIP_CACHE_DIR"] = str(path)
    yield path
    if old is None:
        os.environ.pop("MANIP_CACHE_DIR", None)
    else:
        os.environ["MANIP_CACHE_DIR"] = old
