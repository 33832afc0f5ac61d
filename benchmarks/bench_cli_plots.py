"""What drawing costs the commands that draw: each with and without ``--no-plots``, in the same run.

Run as ``python -m benchmarks.bench_cli_plots`` (``--repeat`` runs per command,
the best kept). Every command runs as a user runs it, ``manip`` in a fresh
subprocess (start-up and imports included), on the SCARA, into a temporary
folder; the peer of each row is the same command drawing its PNGs (and, for the
demo, its GIF). The demo is left out unless ``--demo`` is given (it takes
half a minute per run).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Sequence

__all__ = ["main"]

COMMANDS = {
    "design": ["design", "scara", "--controller", "pd"],
    "track": ["track", "scara", "--controller", "pd"],
    "demo": ["demo", "--robot", "scara"],
}


def _run(argv: list[str], out: Path) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "workbench.cli", *argv, "--out", str(out)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_cli_plots", description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per command, the best is kept (default 3)")
    parser.add_argument("--demo", action="store_true", help="also time manip demo")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat: expected at least 1, got {args.repeat}")
    names = ["design", "track"] + (["demo"] if args.demo else [])
    print("| command | with plots [s] | --no-plots [s] | saved | ratio |")
    print("|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        _run(COMMANDS["design"] + ["--no-plots"], Path(tmp) / "warm")  # the compiled dynamics into the cache
        for name in names:
            best = {}
            for flag in ("plots", "no-plots"):
                extra = ["--no-plots"] if flag == "no-plots" else []
                best[flag] = min(_run(COMMANDS[name] + extra, Path(tmp) / f"{name}-{flag}-{k}")
                                 for k in range(args.repeat))
            print(f"| manip {name} | {best['plots']:.2f} | {best['no-plots']:.2f} | "
                  f"{100 * (1 - best['no-plots'] / best['plots']):.0f} % | {best['plots'] / best['no-plots']:.2f} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
