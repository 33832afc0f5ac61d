"""``manip export-fmu`` and ``manip validate-fmu``: the FMU sub-commands."""

from __future__ import annotations

import argparse
import sys

from .args import UsageError, positive_float
from .outputs import out_file

__all__ = ["register"]


def _internal_step(text: str) -> float:
    """The export's ``--step``: positive, finite and not below the FMU's ``internal_step`` minimum."""
    from fmu.variables import MIN_STEP

    value = positive_float(text)
    if value < MIN_STEP:
        raise argparse.ArgumentTypeError(f"expected an internal step of at least {MIN_STEP:g} s, got {text!r}")
    return value


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def _cmd_export(args: argparse.Namespace) -> int:
    from fmu.build import export_fmu
    from fmu.cross import buildable_platforms
    from fmu.platforms import resolve_platforms

    target = out_file(args.output, "--output", create=False)  # export_fmu makes the folder once the FMU is built
    if target.suffix != ".fmu":
        raise UsageError(f"--output: expected a file name ending in .fmu, got {args.output!r}")
    why = ""
    if args.platforms is not None and not args.platforms.replace(",", "").strip():
        raise UsageError(f"--platforms: expected a comma list of platform names (or host), got {args.platforms!r}")
    if args.platforms is None:  # everything the toolchain builds; the host's alone says why (after the work,
        platforms, why = buildable_platforms()  # so that a bad input still gives one line)
    else:
        platforms = resolve_platforms(args.platforms, flag="--platforms")
    path = export_fmu(args.robot, args.output, step=args.step, motor_model=args.motor_model,
                      fmi_version=args.fmi_version, platforms=platforms, progress=_say)
    if why:
        _say(f"--platforms: {why}")
    print(f"wrote {path} (FMI {args.fmi_version}.0; {', '.join(p.name for p in platforms)})")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from fmu.validate import validate_fmu

    report = validate_fmu(args.fmu, t_end=args.horizon, step=args.step, with_cosim=not args.no_cosim, progress=print)
    print(report.format())
    return 0 if report.ok else 1


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``export-fmu`` and ``validate-fmu`` to the CLI's sub-command parsers."""
    p = subparsers.add_parser("export-fmu", help="export a robot as an FMI 2.0 or 3.0 FMU (Model Exchange and "
                                                 "Co-Simulation)")
    p.add_argument("robot", help="built-in name or TOML file")
    p.add_argument("-o", "--output", required=True, metavar="FILE.fmu", help="the FMU to write")
    p.add_argument("--step", type=_internal_step, default=None, metavar="H",
                   help="internal step of the co-simulation integrator (RK4), s (default 0.001, shorter for a robot "
                        "with drive trains: 1/30 ms for manutec_r3; at least 1e-6)")
    p.add_argument("--motor-model", choices=("reflected", "full"), default="reflected",
                   help="motor model of the dynamics (default reflected)")
    p.add_argument("--platforms", metavar="LIST",
                   help="comma list of binaries to build: linux64, win64, darwin64 (x86_64 and arm64 in one "
                        "universal binary), aarch64-linux, or FMI 3.0 names (x86_64-darwin, aarch64-darwin, ...); "
                        "host = this machine's. Default: all the toolchain can build (all five with the "
                        "[cross] extra); the host's is always built")
    p.add_argument("--fmi-version", type=int, choices=(2, 3), default=2,
                   help="FMI version: 2 (scalar variables, binaries/linux64) or 3 (array variables q, qd, tau_m, "
                        "adjoint derivatives, binaries/x86_64-linux); default 2")
    p.set_defaults(func=_cmd_export)

    p = subparsers.add_parser("validate-fmu", help="validate an FMU: description, binary, FMPy (CS and ME), "
                                                   "state round trips, directional derivatives, libcosim")
    p.add_argument("fmu", metavar="FILE.fmu", help="an FMU written by export-fmu")
    p.add_argument("--horizon", type=positive_float, default=3.0, metavar="T",
                   help="simulated time, s (default 3: open loop drifts, keep it short)")
    p.add_argument("--step", type=positive_float, default=1e-3, metavar="H",
                   help="communication step, s (default 0.001)")
    p.add_argument("--no-cosim", action="store_true", help="skip the libcosim run")
    p.set_defaults(func=_cmd_validate)
