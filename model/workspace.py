"""The reachable workspace of the tool point: sampled, with its envelope in two sections.

:func:`reachable_workspace` draws joint vectors uniformly within the joint
limits (unlimited joints bounded by the project's one rule,
:func:`model.tasks.finite_limits`: [-pi, pi] rad, [-1, 1] m), maps them through
the model's own compiled ``fkine_batch`` (in blocks of rows) and describes the
cloud of tool points in two planes:

* the top view, x-y: the projection of the whole workspace onto the base's
  horizontal plane (for a SCARA every height has this same section);
* the side view, r-z, ``r`` the distance from the world z axis through the
  base origin: when the first joint turns about that axis through a full
  circle the workspace is a solid of revolution and this is its meridian
  section; otherwise it is the r-z projection (:attr:`ReachableWorkspace.axisymmetric`).

The envelope of each view is computed on a grid, not as a convex hull (a
SCARA's top view is an annulus, a hull would fill its hole): the cells holding
a sample are marked, then closed morphologically (dilation, then erosion) by a
disc of ``closing`` cells, which fills the gaps of random sampling narrower than
that disc and keeps every hole and concavity wider than it. The envelope is the
boundary of the closed cells: its position is known to within about one cell
(:attr:`Section.cell`), and features smaller than the closing disc are not
resolved.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .tasks import finite_limits
from .errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from .arm import KinematicArm

__all__ = ["Section", "ReachableWorkspace", "reachable_workspace", "envelope"]

#: Samples per fkine_batch call (memory: 20000 poses of 16 doubles, 2.6 MB).
_CHUNK = 20_000


@dataclass(frozen=True, eq=False)
class Section:
    """A plane view of the workspace and its envelope on a grid.

    Attributes
    ----------
    axes
        Names of the two coordinates (``("x", "y")`` or ``("r", "z")``), m.
    points
        (N, 2) the samples in this plane, m.
    edges
        Cell edges along each coordinate, ``(nu + 1,)`` and ``(nv + 1,)``, m.
    region
        (nu, nv) bool: the cells of the workspace after the closing.
    cell
        Length of a cell's diagonal, m: the resolution of the envelope.
    """

    axes: tuple[str, str]
    points: np.ndarray
    edges: tuple[np.ndarray, np.ndarray]
    region: np.ndarray
    cell: float

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell centres along each coordinate, m."""
        return tuple(0.5 * (e[1:] + e[:-1]) for e in self.edges)  # type: ignore[return-value]

    def boundary(self) -> np.ndarray:
        """(K, 2) centres of the region's boundary cells (a cell of the region with a 4-neighbour outside it), m."""
        from scipy import ndimage

        inner = ndimage.binary_erosion(self.region, border_value=0)
        iu, iv = np.nonzero(self.region & ~inner)
        cu, cv = self.centres()
        return np.column_stack([cu[iu], cv[iv]])

    def contains(self, u: float, v: float) -> bool:
        """Whether the point (u, v) lies in a cell of the region (False outside the grid)."""
        iu = int(np.searchsorted(self.edges[0], u, side="right")) - 1
        iv = int(np.searchsorted(self.edges[1], v, side="right")) - 1
        if not (0 <= iu < self.region.shape[0] and 0 <= iv < self.region.shape[1]):
            return False
        return bool(self.region[iu, iv])


@dataclass(frozen=True, eq=False)
class ReachableWorkspace:
    """The sampled workspace of a robot's tool point.

    Attributes
    ----------
    robot
        Robot name.
    q
        (N, n) the joint samples, rad or m.
    points
        (N, 3) tool positions ``fkine(q)[:3, 3]`` in the world frame, m.
    base
        (3,) world position of the base origin (frame 0), m.
    top, side
        The x-y and r-z :class:`Section`.
    axisymmetric
        Whether the first joint is revolute about the world z axis through the base origin with a
        range of at least 2 pi (then ``side`` is the meridian section, not only a projection).
    limits
        (2, n) the joint ranges sampled, rad or m.
    seed
        The random generator's seed.
    """

    robot: str
    q: np.ndarray
    points: np.ndarray
    base: np.ndarray
    top: Section
    side: Section
    axisymmetric: bool
    limits: np.ndarray
    seed: int

    @property
    def radius_range(self) -> tuple[float, float]:
        """Smallest and largest distance of a sample from the world z axis through the base, m."""
        r = self.side.points[:, 0]
        return float(r.min()), float(r.max())

    @property
    def height_range(self) -> tuple[float, float]:
        """Lowest and highest sample z, world frame, m."""
        z = self.points[:, 2]
        return float(z.min()), float(z.max())


def envelope(points: np.ndarray, axes: tuple[str, str], cells: int = 160, closing: int = 2) -> Section:
    """The :class:`Section` of (N, 2) ``points``: a grid of ``cells`` along the longer side, closed by ``closing`` cells."""
    from scipy import ndimage

    if cells < 8 or closing < 0:
        raise InputError(f"expected >= 8 and closing >= 0, got {cells} and {closing}", parameter="cells")
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = float(max(hi - lo)) or 1e-3
    size = span / cells
    pad = (closing + 2) * size  # room for the dilation: the erosion must not eat the grid's border
    edges = tuple(np.arange(lo[k] - pad, hi[k] + pad + size, size) for k in range(2))
    occupied = np.histogram2d(points[:, 0], points[:, 1], bins=edges)[0] > 0
    if closing:
        yy, xx = np.mgrid[-closing:closing + 1, -closing:closing + 1]
        disc = xx ** 2 + yy ** 2 <= closing ** 2
        region = ndimage.binary_erosion(ndimage.binary_dilation(occupied, disc), disc, border_value=0)
        region |= occupied
    else:
        region = occupied
    return Section(axes=axes, points=points, edges=edges, region=region, cell=size * math.sqrt(2.0))


def _tool_points(robot: "KinematicArm", q: np.ndarray) -> np.ndarray:
    """(N, 3) tool positions of the (N, n) joint samples ``q``, world frame, m."""
    out = np.empty((q.shape[0], 3))
    for start in range(0, q.shape[0], _CHUNK):
        block = q[start:start + _CHUNK]
        out[start:start + block.shape[0]] = robot.fkine_batch(block)[:, :3, 3]
    return out


def reachable_workspace(robot: "KinematicArm", samples: int = 200_000, seed: int = 0, cells: int = 160,
                        closing: int = 2) -> ReachableWorkspace:
    """Sample the tool point's workspace of ``robot`` and its two sections.

    Parameters
    ----------
    robot
        The robot.
    samples
        Joint vectors drawn uniformly within the limits (seeded).
    seed
        Seed of ``numpy.random.default_rng``.
    cells, closing
        Grid of each section (cells along its longer side) and the closing disc's radius, cells
        (see the module docstring).
    """
    if samples < 100:
        raise InputError(f"expected at least 100, got {samples}", parameter="samples")
    desc = robot.description
    lim = finite_limits(desc)
    rng = np.random.default_rng(seed)
    q = lim[0] + rng.random((samples, robot.n)) * (lim[1] - lim[0])
    p = _tool_points(robot, q)
    frames0 = robot.fkine_all(desc.q_rest)
    base = frames0[0][:3, 3].copy()
    r = np.hypot(p[:, 0] - base[0], p[:, 1] - base[1])
    first = desc.links[0]
    axis0 = _first_axis(robot, frames0)
    axisymmetric = bool(first.is_revolute and lim[1, 0] - lim[0, 0] >= 2 * math.pi - 1e-4
                        and abs(abs(axis0[1][2]) - 1.0) < 1e-9
                        and np.hypot(*(axis0[0][:2] - base[:2])) < 1e-9)
    return ReachableWorkspace(
        robot=desc.name, q=q, points=p, base=base,
        top=envelope(p[:, :2], ("x", "y"), cells, closing),
        side=envelope(np.column_stack([r, p[:, 2]]), ("r", "z"), cells, closing),
        axisymmetric=axisymmetric, limits=lim, seed=seed,
    )


def _first_axis(robot: "KinematicArm", T_links: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World origin and direction of joint 1's axis (it does not depend on q)."""
    from .chain import build_chain, joint_axes

    return joint_axes(build_chain(robot.description), T_links)[0]
