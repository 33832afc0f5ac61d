"""``manip sweep``: thousands of closed-loop runs over varied parameters, in local processes or on Dask.

``manip sweep SPEC.toml --out DIR [--workers K] [--scheduler ADDRESS] [--listen HOST] [--resume] [--no-plots]``
reads the spec (:mod:`closed_loop.sweep_spec`; refused in one line before any work),
runs every case with the compiled closed loop in a local process pool (:mod:`closed_loop.sweep_pool`;
an embedded Dask cluster for a ``--listen`` HOST other than loopback, or the Dask scheduler at ADDRESS) and writes ``DIR/results.csv``, ``DIR/results.parquet``,
``DIR/summary.json`` and the plots (:mod:`closed_loop.sweep`). Progress goes to stderr.
"""

from __future__ import annotations

import argparse
from typing import Any

from .args import UsageError, add_no_plots, host_address, scheduler_address
from .outputs import check_out_dir

__all__ = ["register", "run_sweep_command"]


def run_sweep_command(args: argparse.Namespace) -> int:
    """``manip sweep``: run a sweep spec, write its table, summary and plots."""
    from closed_loop.sweep import run_sweep
    from closed_loop.sweep_spec import load_spec

    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers: expected a number of processes >= 1, got {args.workers!r}")
    if args.scheduler is not None and args.workers is not None:
        raise UsageError("--workers: the cluster at --scheduler has its own workers; give one of the two")
    spec = load_spec(args.spec)
    check_out_dir(args.out)
    result = run_sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler, host=args.listen,
                   resume=args.resume, plots=not args.no_plots)
    s = result.summary
    q = s["max_error_quantiles"]
    unit = s["max_error_unit"]
    print(f"{spec.robot}: {spec.controller}, {s['cases']} cases ({spec.method}, seed {spec.seed}) in "
          f"{result.wall_time:.1f} s on {result.workers} workers; {s['diverged']} diverged")
    print(f"max error ({unit}): median {q['0.5']:.3e}, 95 % {q['0.95']:.3e}, 99 % {q['0.99']:.3e}")
    if "bound" in s:
        b = s["bound"]
        print(f"P(max error > {b['max_error']:g}) = {b['probability']:.4f} "
              f"(95 % interval {b['ci95'][0]:.4f} to {b['ci95'][1]:.4f}, {b['exceeded']} cases)")
    w = s["worst_case"]
    params = ", ".join(f"{k} = {v:.4g}" for k, v in w["parameters"].items())
    print(f"worst case {w['case']}: max error {w['max_error']:.3e} at {params}")
    print(f"wrote {len(result.files)} files to {args.out}")
    return 0


def register(subparsers: Any, full: bool = True) -> None:
    """Add the ``sweep`` sub-command to ``manip``'s sub-parsers."""
    p = subparsers.add_parser("sweep", help="closed-loop runs over varied payload, friction, masses, gains, rate (Dask)")
    p.set_defaults(func=run_sweep_command)
    if not full:
        return
    p.add_argument("spec", help="sweep spec (TOML)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")
    p.add_argument("--workers", type=int, default=None, metavar="K",
                   help="worker processes on this machine (default: the machine's cores; 1: this process)")
    p.add_argument("--scheduler", type=scheduler_address, default=None, metavar="ADDRESS",
                   help="run on an existing Dask cluster (tcp://host:port) instead of an embedded one")
    p.add_argument("--listen", type=host_address, default="127.0.0.1", metavar="HOST",
                   help="with a HOST other than loopback, run an embedded Dask cluster listening on it (reachable "
                        "from the network; warns) instead of the local process pool (default 127.0.0.1)")
    p.add_argument("--resume", action="store_true", help="keep the cases an interrupted run of this spec wrote in DIR")
    add_no_plots(p)
