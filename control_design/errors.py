"""Errors of the control-design package.

A bad design request subclasses :class:`model.errors.InputError` (a
``ValueError``); a diverged simulation is a :class:`model.errors.NumericalError`
(an ``ArithmeticError``, not bad input). The command line turns either into a
one-line message and exit status 2; each message names the argument, the value
received and what was expected.
"""

from __future__ import annotations

from model.errors import InputError, NumericalError

__all__ = ["ControlDesignError", "DesignSpecError", "SamplingRateError", "UnknownControllerError", "TrajectoryLimitError", "SimulationDivergedError"]


class ControlDesignError(InputError):
    """Base class: a control-design request cannot be honoured."""


class DesignSpecError(ControlDesignError):
    """A design specification (bandwidth, damping, phase margin, ...) is out of range."""


class SamplingRateError(DesignSpecError):
    """The control rate is too low for the requested bandwidth (see :data:`control_design.loops.MIN_RATE_PER_BANDWIDTH_HZ`)."""


class UnknownControllerError(ControlDesignError):
    """The controller name is not one of the known kinds."""


class TrajectoryLimitError(ControlDesignError):
    """A reference trajectory leaves the joint limits of the robot."""


class SimulationDivergedError(NumericalError):
    """The closed-loop simulation left finite numbers (an unstable loop)."""
