"""FMU export time with the cross platforms against the host-only export, in the same run.

Run as ``python -m benchmarks.bench_cross`` (``--cold`` also times one export
with an empty zig cache, as on a fresh machine: minutes). For the SCARA:

* the peer: ``export_fmu`` with the host's binary only (gcc), best of 3;
* all five platforms (host gcc, then zig cc for Windows, both macOS slices and
  Linux aarch64), warm zig cache, best of 3, and its ratio to the peer;
* each cross platform alone next to the host's (export with both, minus the peer);
* with ``--cold``: all five with an empty ``ZIG_GLOBAL_CACHE_DIR``, once.

The table goes to stdout and to ``benchmarks/results/cross.md``.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
import warnings
from pathlib import Path

from benchmarks._timing import best_time

__all__ = ["main"]

RESULTS = Path(__file__).resolve().parent / "results" / "cross.md"


def _export(folder: Path, platforms) -> None:
    from fmu import export_fmu
    from model import InertiaConsistencyWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        export_fmu("scara", folder / "scara.fmu", platforms=platforms)


def main(argv: list[str] | None = None) -> int:
    from fmu.cross import zig_command, zig_version
    from fmu.platforms import PLATFORMS, host_platform

    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_cross", description=__doc__.splitlines()[0])
    parser.add_argument("--cold", action="store_true", help="also time one export with an empty zig cache")
    args = parser.parse_args(argv)
    if zig_command() is None:
        print("bench_cross: skipped, the ziglang package is not installed (pip install -e '.[cross]')")
        return 0
    host = host_platform()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_cross_") as tmp:
        folder = Path(tmp)
        _export(folder, PLATFORMS)  # warm zig's cache
        peer = best_time(lambda: _export(folder, None))
        every = best_time(lambda: _export(folder, PLATFORMS))
        rows.append(("host only (gcc): the peer", peer, 1.0))
        rows.append(("all five platforms, warm zig cache", every, every / peer))
        for target in PLATFORMS:
            if target != host:
                both = best_time(lambda t=target: _export(folder, [t]), repeat=2)
                rows.append((f"+ {target.name} alone (zig cc -target {target.zig_target})", both - peer, None))
        if args.cold:
            cache = folder / "zig-cache"
            os.environ["ZIG_GLOBAL_CACHE_DIR"] = str(cache)
            try:
                t0 = time.perf_counter()
                _export(folder, PLATFORMS)
                cold = time.perf_counter() - t0
            finally:
                del os.environ["ZIG_GLOBAL_CACHE_DIR"]
            rows.append(("all five platforms, empty zig cache (a fresh machine)", cold, cold / peer))
    lines = [f"# FMU export with cross platforms (SCARA; zig {zig_version()}, {platform.machine()}, "
             f"{os.cpu_count()} CPUs)", "", "| export | wall time, s | / host only |", "|---|---|---|"]
    lines += [f"| {name} | {secs:.2f} | {'' if ratio is None else f'{ratio:.1f}'} |" for name, secs, ratio in rows]
    text = "\n".join(lines) + "\n"
    print(text)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
