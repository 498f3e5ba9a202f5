"""Which points lie inside the robot's body, grown by a margin, at a pose: the one footprint test.

The body in its own frame (x forward from the rotation centre, y left) is the box from
``-rear`` to ``front`` along and ``±half`` across: a :data:`Box`, ``(rear, front, half)``.
:func:`body_box` grows it by a margin (the planner's ``clearance``; a negative margin shrinks
it, as the plan check's noise allowance does). A point is inside when
``-rear <= u <= front`` and ``|v| <= half`` (on the outline counts); ``strict`` leaves
the outline out (the rule that exempts the robot's own returns).

Every place in clomp that asks this (perception's own returns, the rollouts' contacts
in :mod:`clomp.planner.contact`, the reference engine's tick loop, the plan check and
the run records of :mod:`clomp.runtime.supervision`) calls :func:`inside` (points already
in the body's frame) or :func:`inside_at` (points and a pose in one frame);
``tests/test_architecture_concepts_planner.py`` fails on a second copy.

>>> import numpy as np
>>> from clomp.planner.robot_model import RobotModel
>>> box = body_box(RobotModel(), 0.01)
>>> inside_at(np.array([[0.05, 0.0], [0.3, 0.0], [-0.15, 0.05]]), (0.0, 0.0, 0.0), box).tolist()
[True, False, True]
"""

from __future__ import annotations

import numpy as np

from clomp.formal.geometry import FrameLike, points_to_frame
from clomp.planner.robot_model import RobotModel

__all__ = ["Box", "body_box", "inside", "inside_at"]

#: the body's extents from its rotation centre: (rear, front, half width), metres
Box = tuple[float, float, float]


def body_box(robot: RobotModel, margin: float = 0.0) -> Box:
    """``robot``'s body grown by ``margin`` metres on every side (negative: shrunk).

    >>> [round(v, 3) for v in body_box(RobotModel(), 0.01)]
    [0.19, 0.1, 0.1]
    """
    return (robot.rear_offset + margin, robot.front_offset + margin, robot.width / 2 + margin)


def inside(u: np.ndarray, across: np.ndarray, box: Box, *, strict: bool = False) -> np.ndarray:
    """Which points at body-frame coordinates ``u`` (along the heading) and ``across``
    (the distance across it, ``|v|``) lie inside ``box``: on its outline counts, except
    when ``strict``. Any shapes that broadcast together.

    >>> inside(np.array([0.1, 0.1]), np.array([0.1, 0.05]), (0.1, 0.1, 0.1)).tolist()
    [True, True]
    >>> inside(np.array([0.1, 0.1]), np.array([0.1, 0.05]), (0.1, 0.1, 0.1), strict=True).tolist()
    [False, False]
    """
    rear, front, half = box
    if strict:
        out: np.ndarray = (u > -rear) & (u < front) & (across < half)
    else:
        out = (u >= -rear) & (u <= front) & (across <= half)
    return out


def inside_at(points: np.ndarray, pose: FrameLike, box: Box, *, strict: bool = False) -> np.ndarray:
    """Which of the N×2 ``points`` lie inside ``box`` placed at ``pose`` (a :class:`Pose`
    or (x, y, theta), in the points' frame): :func:`inside` after
    :func:`clomp.formal.geometry.points_to_frame`.

    >>> inside_at(np.array([[1.0, 0.05], [1.0, 0.2]]), (1.0, 0.0, 1.5707963267948966), (0.1, 0.1, 0.1)).tolist()
    [True, False]
    """
    local = points_to_frame(points, pose)
    return inside(local[:, 0], np.abs(local[:, 1]), box, strict=strict)
