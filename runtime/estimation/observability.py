"""What a scan match truly observes: its information checked against the scene's shape (issue #36).

The matcher (:func:`~clomp.runtime.estimation.icp.match_scans`) gives each map point the
normal of the line through its neighbours within 8 cm, and a point whose neighbours do not
lie on a line is matched point to point: it pins both coordinates. At ``harsh`` noise
(2.5 cm of range noise) the map's walls are bands a few centimetres thick on a 1 cm grid,
and within 8 cm such a band is a blob, not a line: most of a wall's points are matched
point to point, and each claims to pin the position *along* the wall as well as across
it. Between two parallel walls (a corridor) nothing pins the position along them, but the
match said it did, to a few millimetres: ``corridor`` 21/0 without a gyro was pushed
0.205 m along its corridor at 11.3 s, every later revolution matched 100 % of its points
with a 1 cm residual where the prediction put it, the filter's position sd along the
corridor stayed 3 mm, and the run claimed the goal (95 % bound 0.079 m) truly 0.294 m off.

:func:`observed_information` looks at the revolution itself at a scale its noise does not
hide: each point's neighbours within ``radius`` (0.2 m, several times a noisy band's
thickness) either lie along a line (the point then observes only its normal) or do not (a
post, a box, a corner: both coordinates). Summed over the points the match paired, with
the matcher's own Jacobian, this is the information the scene's shape can give; a direction
of the position (a translation, or one mostly so) with less of it per paired point than the
matcher's own ``min_information`` is not observed, and is taken out of the match's
information: the filter keeps dead reckoning along it, and its covariance grows there as
the prediction's does. A direction the matcher observed through real structure (the other
wall, a box, a corner) is left as the matcher gave it, so a match in a rich scene is
returned unchanged.

>>> import numpy as np
>>> from clomp.formal.model import Pose
>>> xs = np.linspace(-1.0, 1.0, 81)
>>> corridor = np.r_[np.c_[xs, np.full(81, 0.36)], np.c_[xs, np.full(81, -0.36)]]
>>> full = np.diag([160.0, 160.0, 40.0])                       # a match claiming every direction
>>> info, lost = observed_information(full, corridor, Pose(0.0, 0.0, 0.0), np.ones(162, bool))
>>> lost, round(float(info[0, 0]), 6), round(float(info[1, 1]), 1)   # along the walls: nothing
(('x',), 0.0, 160.0)
>>> room = np.r_[corridor, np.c_[np.full(41, 1.0), np.linspace(-0.36, 0.36, 41)]]
>>> observed_information(full, room, Pose(0.0, 0.0, 0.0), np.ones(203, bool))[1]   # an end wall: unchanged
()
"""

from __future__ import annotations

import numpy as np

from clomp.formal.geometry import points_from_frame
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import eigh, eigvalsh
from clomp.runtime.estimation._shape_core import shape_estimate
from clomp.runtime.estimation.icp import direction_name, neighbour_lines
from clomp.runtime.jit import interruptible

__all__ = ["observed_information", "shape_information"]


def shape_information(world: np.ndarray, centre: tuple[float, float], *, radius: float = 0.2, neighbours: int = 32,
                      line_ratio: float = 0.25, lever: float = 0.5) -> tuple[np.ndarray, int]:
    """The information (3×3, rotation scaled by ``lever`` m, as the matcher's) that the shape
    of the points ``world`` (N×2, supervisor frame) gives about the pose of a robot at
    ``centre``, and how many points gave it: a point whose ``neighbours`` nearest within
    ``radius`` spread along a line (the spread across it at most ``line_ratio`` of the spread
    along, the matcher's test) observes its normal; one with at least 4 neighbours that do
    not, both coordinates; one with fewer, nothing (a stray return shows no shape).

    >>> import numpy as np
    >>> wall = np.c_[np.linspace(-1.0, 1.0, 81), np.full(81, 0.5)]
    >>> h, n = shape_information(wall, (0.0, 0.0))
    >>> n, round(float(h[0, 0]), 3), round(float(h[1, 1]), 1)     # a wall pins only across it
    (81, 0.0, 81.0)
    """
    pts = np.asarray(world, dtype=float).reshape(-1, 2)
    if len(pts) < 4:
        return np.zeros((3, 3)), 0
    count, line, angle = neighbour_lines(pts, radius, neighbours, line_ratio)  # the matcher's test
    usable = count >= 4
    line = usable & line
    spot = usable & ~line
    # d(point)/d(theta), over the lever: the point about the robot, turned a right angle
    arm = np.c_[-(pts[:, 1] - centre[1]), pts[:, 0] - centre[0]] / lever
    normal = np.c_[-np.sin(angle), np.cos(angle)]
    rows = [np.c_[normal[line], np.einsum("ij,ij->i", normal[line], arm[line])],
            np.c_[np.ones(int(spot.sum())), np.zeros(int(spot.sum())), arm[spot, 0]],
            np.c_[np.zeros(int(spot.sum())), np.ones(int(spot.sum())), arm[spot, 1]]]
    j = np.concatenate(rows)
    return j.T @ j, int(usable.sum())


def _surely_observed(world: np.ndarray, centre: tuple[float, float], r: np.ndarray, min_information: float, *,
                     radius: float, lever: float) -> bool:
    """Whether the exact test of :func:`observed_information` surely finds every direction of
    ``r`` (orthonormal columns, the matcher's units) observed: the compiled estimate of the
    shape's information per point exceeds ``min_information`` there by more than its rounding
    (bounded by 1e-7 of its trace per point: the two differ by about 1e-13 of it), and no
    comparison in it was a tie. By Weyl's inequality the exact figure's least eigenvalue is
    then above ``min_information`` too, and the exact test returns the match unchanged."""
    pts = np.ascontiguousarray(world, dtype=float).reshape(-1, 2)
    if len(pts) < 4 or not np.isfinite(pts).all():
        return False
    shape, n, unsure = interruptible(shape_estimate, pts, float(centre[0]), float(centre[1]), float(radius), 32, 0.25,
                                     float(lever))
    if unsure or n < 1:
        return False
    per = shape / n
    slack = 1e-7 * float(np.trace(per)) + 1e-12
    return bool(eigvalsh(r.T @ per @ r).min() >= min_information + slack)


def observed_information(information: np.ndarray, points: np.ndarray, pose: Pose, paired: np.ndarray, *,
                         lever: float = 0.5, min_information: float = 0.02, heading_share: float = 0.3,
                         radius: float = 0.2, screen: bool = True) -> tuple[np.ndarray, tuple[str, ...]]:
    """A match's ``information`` (3×3, state units: m, m, rad) without the directions the
    scene's shape does not observe (see the module), and their names (``"x"``, ``"y"`` or a
    mixed direction; empty when nothing was taken out, and then ``information`` itself is
    returned). ``points``: the revolution (robot frame), ``pose``: where the match put it,
    ``paired``: which of its points the match paired with the map (only they gave it
    information). A direction is not observed when the shape's information per paired point
    along it is below ``min_information`` (the matcher's own test, rotation scaled by
    ``lever``) and it is mostly a translation (its heading share at most ``heading_share``:
    rotation about one small box is the matcher's and the filter's own concern).

    ``screen``: first judge the match with :func:`~clomp.runtime.estimation._shape_core.shape_estimate`
    (compiled, the same figure up to rounding) and return ``information`` at once when every
    direction it claims is observed by more than that rounding can move (issue #41: most
    revolutions, at a fraction of the cost); the answer is the same bit for bit, and ``False``
    always computes the exact shape (the reference the tests compare it with)."""
    info = np.asarray(information, dtype=float).reshape(3, 3)
    mask = np.asarray(paired, dtype=bool).reshape(-1)
    if not mask.any() or not info.any():
        return info, ()
    world = points_from_frame(np.asarray(points, dtype=float).reshape(-1, 2)[mask], pose)
    scale = np.array([1.0, 1.0, lever])
    h = info / scale[:, None] / scale[None, :]  # the matcher's units
    # only what the match claims can be over-claimed: the shape is judged within the directions
    # the match observes (those it left unobservable carry no information to take out)
    mlam, mvec = eigh((h + h.T) / 2)  # np.linalg.eigh bit for bit, cheaper (_exact; issue #41)
    r = mvec[:, mlam > 1e-9 * max(float(mlam.max()), 1e-300)]
    if not r.size:
        return info, ()
    if screen and _surely_observed(world, (pose.x, pose.y), r, min_information, radius=radius, lever=lever):
        return info, ()
    shape, n = shape_information(world, (pose.x, pose.y), radius=radius, lever=lever)
    slam, svec = eigh(r.T @ (shape / max(n, 1)) @ r)
    dirs = r @ svec
    lost = (slam < min_information) & (np.abs(dirs[2]) <= heading_share)
    if not lost.any():
        return info, ()
    # what the match says of the rest not knowing these directions (the Schur complement):
    # never more than it said, in any direction, and nothing along them
    hr = r.T @ h @ r
    w = svec[:, lost]
    hw = hr @ w
    hr = hr - hw @ np.linalg.pinv(w.T @ hw) @ hw.T
    h = r @ ((hr + hr.T) / 2) @ r.T
    u = dirs[:, lost]
    return h * scale[:, None] * scale[None, :], tuple(direction_name(u[:, k]) for k in range(u.shape[1]))

