"""An arm whose inertia matrix is singular at some configurations only: the ``spinner``.

Joint 1 turns about the vertical axis; joint 2 slides radially along a horizontal axis
through it (``alpha1 = -pi/2``, ``a1 = 0``). Link 1 has no mass and joint 1 no motor
inertia; link 2 is a point mass (``mass``) at its frame origin, or massless with the
same mass as a payload. So ``B(q) = diag(m d2^2, m + G2^2 Jm2)``, derived by hand:
the point at radius ``d2`` from the vertical axis is joint 1's only inertia. At
``d2 = 0`` (and for ``m = 0`` everywhere) joint 1 moves no mass and B is singular;
elsewhere it is not, so the export check (the rest ``d2 = 0.3`` and random
configurations) passes and the singularity is met only at run time.
"""

from __future__ import annotations

import math

from model import Robot
from model.description import description_from_dict

__all__ = ["spinner", "SPINNER_MASS"]

#: kg: the mass that joint 1 carries at radius d2.
SPINNER_MASS = 2.0


def spinner(as_payload: bool = False) -> Robot:
    """The spinner (module docstring); ``as_payload``: link 2 massless, its mass a 2 kg payload at the tip."""
    link1 = {"joint": "revolute", "a": 0.0, "alpha": -math.pi / 2, "d": 0.0, "theta": 0.0, "mass": 0.0,
             "com": [0.0, 0.0, 0.0], "inertia": [0.0] * 6, "motor_inertia": 0.0, "gear_ratio": 10.0,
             "viscous_friction": 0.0}
    link2 = {"joint": "prismatic", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0,
             "mass": 0.0 if as_payload else SPINNER_MASS, "com": [0.0, 0.0, 0.0], "inertia": [0.0] * 6,
             "motor_inertia": 1e-4, "gear_ratio": 100.0, "viscous_friction": 0.0, "qlim": [-0.5, 0.5]}
    robot = Robot(description_from_dict({"name": "spinner", "links": [link1, link2], "rest": [0.0, 0.3],
                                         "gravity": [0.0, 0.0, -9.81]}))
    return robot.with_payload(SPINNER_MASS) if as_payload else robot
