"""Time-optimal motion along a joint-space path within motor torque, joint velocity and acceleration limits.

* :mod:`~model.retime.path` - the geometric path: straight segments stopping at each waypoint, or a C2 spline.
* :mod:`~model.retime.limits` - the limits: motor torques through the gears, joint speeds and accelerations.
* :mod:`~model.retime.solver` - the reachability analysis (TOPP-RA), exact in the path speed with viscous friction.
* :mod:`~model.retime.result` - the time law, evaluable at any time, and its checks.

>>> import model
>>> from model.retime import retime, retime_limits
>>> robot = model.load_robot("planar2r")                  # 2 x 50 kg links, gears 100, gravity on
>>> limits = retime_limits(robot, tau_m_max=[20.0, 10.0])  # N m per motor; 90 % of it used (the default)
>>> motion = retime(robot, [[0.0, 0.0], [1.0, 0.5]], limits, grid=200)
>>> round(motion.duration, 2), motion.check().torque <= 1.0 + 1e-9   # s; every torque within its bound
(0.96, True)
"""

from .core import DEFAULT_GRID, retime, retime_path
from .limits import DEFAULT_TORQUE_MARGIN, RetimeLimits, retime_limits
from .path import PATH_KINDS, PathLimitError, RetimePath, blended_path, segment_grids, straight_path
from .result import DEFAULT_SAMPLE_STEP, DEFAULT_SMOOTH, GridCheck, Retiming
from .solver import PathConstraints, RetimeInfeasibleError, SegmentSolution, path_constraints, solve_segment

__all__ = [
    "DEFAULT_GRID",
    "DEFAULT_SAMPLE_STEP",
    "DEFAULT_SMOOTH",
    "DEFAULT_TORQUE_MARGIN",
    "GridCheck",
    "PATH_KINDS",
    "PathConstraints",
    "PathLimitError",
    "RetimeInfeasibleError",
    "RetimeLimits",
    "RetimePath",
    "Retiming",
    "SegmentSolution",
    "blended_path",
    "path_constraints",
    "retime",
    "retime_limits",
    "retime_path",
    "segment_grids",
    "solve_segment",
    "straight_path",
]
