"""Shared fixtures: a per-session compiled-code cache, so test runs start cold and leave ~/.cache alone."""

from __future__ import annotations

import os
import signal

import pytest

# A shell starts background jobs with SIGINT ignored, and an ignored signal stays ignored across exec: the
# commands the tests interrupt with Ctrl-C (SIGINT) would then run to the end. A Python handler here is
# reset to the default by exec, so every child process can be interrupted however pytest was started.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


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
