"""The processes a test started, and only those: marked through their environment.

A test that starts a command (``manip sweep``, ``manip teach``) passes :func:`marked_env` to
it; every process the command starts inherits the mark, also one orphaned by a kill, and
:func:`marked` finds them by it. So "nothing left running or listening" is checked on the
test's own processes, never on the machine's listening ports, which other programs reuse.
"""

from __future__ import annotations

import os
import signal
import uuid

__all__ = ["MARK", "alive", "interruptible", "listening_ports", "marked", "marked_env"]

#: The environment variable that carries a test's mark.
MARK = "MANIP_TEST_TREE"


def marked_env(base: dict[str, str] | None = None) -> tuple[dict[str, str], str]:
    """An environment for a command of the test (``base``, default this one's) with a fresh mark; and the mark."""
    token = uuid.uuid4().hex
    return {**(os.environ if base is None else base), MARK: token}, token


def interruptible() -> None:
    """``preexec_fn`` of a command the test stops with SIGINT (Ctrl-C): SIGINT at its default in the child.

    A shell starts a background job (``make test &``) with SIGINT ignored, a child inherits that, and
    Python keeps an ignored SIGINT ignored: the command would never see the test's Ctrl-C.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def marked(token: str) -> list:
    """The live (not zombie) ``psutil.Process`` objects that carry the mark ``token``."""
    import psutil

    found = []
    for proc in psutil.process_iter():
        try:
            if proc.environ().get(MARK) == token and proc.status() != psutil.STATUS_ZOMBIE:
                found.append(proc)
        except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
            continue  # gone, or another user's (not ours)
    return found


def alive(token: str) -> list[int]:
    """The pids of the live processes marked ``token``."""
    return sorted(p.pid for p in marked(token))


def listening_ports(token: str) -> set[int]:
    """The ports on which a process marked ``token`` listens (TCP, IPv4 and IPv6)."""
    import psutil

    ports = set()
    for proc in marked(token):
        try:
            ports |= {c.laddr.port for c in proc.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN}
        except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
            continue
    return ports
