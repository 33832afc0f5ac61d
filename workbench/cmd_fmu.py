"""``manip export-fmu`` and ``manip validate-fmu``: the FMU sub-commands."""

from __future__ import annotations

import argparse

from .args import positive_float
from .outputs import out_file

__all__ = ["register"]


def _internal_step(text: str) -> float:
    """The export's ``--step``: positive, finite and not below the FMU's ``internal_step`` minimum."""
    from fmu.variables import MIN_STEP

    value = positive_float(text)
    if value < MIN_STEP:
        raise argparse.ArgumentTypeError(f"expected an internal step of at least {MIN_STEP:g} s, got {text!r}")
    return value


def _cmd_export(args: argparse.Namespace) -> int:
    from fmu.build import export_fmu

    out_file(args.output, "--output", create=False)  # export_fmu makes the folder once the FMU is built
    path = export_fmu(args.robot, args.output, step=args.step, motor_model=args.motor_model,
                      fmi_version=args.fmi_version, progress=print)
    print(f"wrote {path}")
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
    p.add_argument("--step", type=_internal_step, default=1e-3, metavar="H",
                   help="internal step of the co-simulation integrator (RK4), s (default 0.001, at least 1e-6)")
    p.add_argument("--motor-model", choices=("reflected", "full"), default="reflected",
                   help="motor model of the dynamics (default reflected)")
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
