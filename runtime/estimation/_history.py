"""Where the estimate of :class:`~clomp.runtime.estimation.odometry.ScanOdometry` was, when:
the kept history of its poses and of the wheel commands, a revolution de-skewed along it, and a
correction carried through it.

A mixin and :func:`deskew`, moved out of :mod:`clomp.runtime.estimation.odometry` unchanged
(the module reached its 600-line limit); both are used from there
(``from clomp.runtime.estimation.odometry import deskew`` keeps working).

>>> from clomp.runtime.estimation.odometry import ScanOdometry
>>> issubclass(ScanOdometry, PoseHistory)
True
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from clomp.formal.geometry import arc_offsets, compose, points_from_frames, points_to_frame, relative, wrap_angle
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import unwrap
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.estimation.prior import OdometryPrior

__all__ = ["PoseHistory", "deskew"]


def deskew(points: np.ndarray, point_times: np.ndarray | None, v: float, w: float) -> np.ndarray:
    """A revolution taken while moving at (``v``, ``w``) as if taken at once at its timestamp.

    ``point_times`` (s, <= 0, relative to the timestamp) say when each point was taken;
    without them the points are returned unchanged.

    >>> import numpy as np
    >>> deskew(np.array([[1.0, 0.0]]), np.array([-1.0]), 0.1, 0.0)  # seen 1 s ago at 0.1 m/s
    array([[0.9, 0. ]])
    """
    if point_times is None or len(points) == 0 or (v == 0.0 and w == 0.0):
        return points
    px, py, th = arc_offsets(v, w, np.asarray(point_times, dtype=float))  # where each point was taken
    return points_from_frames(points, px, py, th)


class PoseHistory:
    """The history half of :class:`~clomp.runtime.estimation.odometry.ScanOdometry` (see there
    for the settings it reads): the estimate at a past time, a revolution de-skewed along the
    estimate's own motion, the commands as the body follows them late, and a correction
    carried through the history."""

    prior: OdometryPrior
    filter: OdometryFilter
    pose: Pose
    _t: float
    _commands: deque[tuple[float, float, float]]
    _history: deque[tuple[float, Pose]]

    def _delayed(self, t: float, v: float, w: float) -> tuple[float, float]:
        """The twist the body drove over the step from the last advance to ``t``, the wheels
        commanded (``v``, ``w``) over it: the commands' mean over the same step ``prior.delay``
        s earlier (the body follows late)."""
        if not self._commands or self._commands[-1][1:] != (v, w):
            self._commands.append((self._t, v, w))
        d = self.prior.delay
        a, b = self._t - d, float(t) - d
        while len(self._commands) > 1 and self._commands[1][0] <= a:
            self._commands.popleft()
        if not b > a:
            return self._commands[-1][1], self._commands[-1][2]
        seg = list(self._commands)
        sv = sw = 0.0
        for k, (since, cv, cw) in enumerate(seg):
            until = seg[k + 1][0] if k + 1 < len(seg) else math.inf
            span = min(until, b) - max(since, a)
            if span > 0:
                sv, sw = sv + cv * span, sw + cw * span
        return sv / (b - a), sw / (b - a)

    def pose_at(self, t: float) -> Pose:
        """The estimate at time ``t`` (interpolated in the kept history; clamped at its ends)."""
        h = self._history
        if not h or t >= h[-1][0]:
            return self.pose
        if t <= h[0][0]:
            return h[0][1]
        for (t0, p0), (t1, p1) in zip(h, list(h)[1:]):
            if t0 <= t <= t1:
                f = 0.0 if t1 == t0 else (t - t0) / (t1 - t0)
                dth = wrap_angle(p1.theta - p0.theta)
                return Pose(p0.x + f * (p1.x - p0.x), p0.y + f * (p1.y - p0.y), wrap_angle(p0.theta + f * dth))
        return self.pose  # pragma: no cover - the loop covers [h[0], h[-1]]

    def _deskew_along(self, points: np.ndarray, point_times: np.ndarray, stamp: float) -> np.ndarray:
        """A revolution as if taken at once at ``stamp``, each point moved by the estimate's
        own motion since it was taken (the kept history, whose heading a gyro gave): unlike
        the commanded twist, this follows a turn that starts or ends within the revolution
        (the commands lead the body by the actuation latency)."""
        h = self._history
        t = np.fromiter((q[0] for q in h), float, len(h))
        hx = np.fromiter((q[1].x for q in h), float, len(h))
        hy = np.fromiter((q[1].y for q in h), float, len(h))
        hth = unwrap(np.fromiter((q[1].theta for q in h), float, len(h)))  # np.unwrap's, bit for bit
        when = stamp + point_times
        x, y, th = np.interp(when, t, hx), np.interp(when, t, hy), np.interp(when, t, hth)
        x0, y0, th0 = float(np.interp(stamp, t, hx)), float(np.interp(stamp, t, hy)), float(np.interp(stamp, t, hth))
        taken = points_to_frame(np.stack((x, y), axis=1), (x0, y0, th0))  # where each was taken, seen from stamp
        return points_from_frames(points, taken[:, 0], taken[:, 1], th - th0)

    def _carry(self, before: Pose, at: Pose, stamp: float) -> Pose:
        """The filter moved from ``before``: take its pose, carry the correction through the
        history since ``stamp``, and return where ``at`` (the estimate at ``stamp``) moved."""
        after = self.filter.pose
        self.pose = after
        self._history = deque((t, compose(after, relative(before, p))) if t >= stamp else (t, p) for t, p in self._history)
        return compose(after, relative(before, at))
