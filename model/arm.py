"""What the algorithms need of a robot: narrow interfaces, so they take any arm, not the Robot facade.

:class:`~model.robot.Robot` satisfies both protocols; the algorithms
(:mod:`model.ik`, :mod:`model.singularity`, :mod:`model.plant`,
:mod:`model.linearise`) are typed against them and never import the facade,
so the facade can import them without a cycle.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .description import RobotDescription
    from .dynamics import Dynamics, DynamicsParameters
    from .kinematics import KinematicsFunctions

__all__ = ["DynamicArm", "KinematicArm"]


class KinematicArm(Protocol):
    """A serial arm with numeric forward kinematics: what IK and singularity analysis use."""

    @property
    def description(self) -> RobotDescription: ...

    @property
    def name(self) -> str: ...

    @property
    def n(self) -> int: ...

    @property
    def qlim(self) -> np.ndarray: ...

    @property
    def q_rest(self) -> np.ndarray: ...

    def fkine(self, q: Any) -> np.ndarray:
        """Pose of the tool frame E in the world frame W, T_WE (4, 4), m (base and tool included)."""

    def jacob0(self, q: Any) -> np.ndarray:
        """Geometric Jacobian (6, n) of the tool origin, rows [v; w], world-frame axes."""

    def fkine_batch(self, Q: Any) -> np.ndarray:
        """Poses T_WE (N, 4, 4) of N joint vectors given as an (N, n) array, m."""


class DynamicArm(KinematicArm, Protocol):
    """A :class:`KinematicArm` with symbolic kinematics, dynamics and gears: what the plant and linearise use."""

    @property
    def kinematics(self) -> KinematicsFunctions: ...

    @property
    def dynamics(self) -> Dynamics: ...

    @property
    def gear_ratio(self) -> np.ndarray: ...

    @property
    def parameters(self) -> DynamicsParameters: ...

    def rne(self, q: Any, qd: Any, qdd: Any) -> np.ndarray:
        """Joint torques of the rigid arm, tau (n,), N m or N (inverse dynamics, recursive Newton-Euler)."""
