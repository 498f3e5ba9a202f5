"""Planar geometry of a differential-drive robot: the one place for frames and motion.

Poses are :class:`clomp.formal.model.Pose` (x forward, y left, theta counter-clockwise, in
metres and radians). Everything in clomp that composes frames, wraps angles or moves a
pose by wheel speeds uses these functions; nothing else re-implements them (a test scans
the source for it).

- :func:`wrap_angle` — an angle in (-pi, pi].
- :func:`compose` / :func:`relative` — a pose from a robot's frame into the world's and back;
  :func:`points_from_frame` / :func:`points_to_frame` — the same for arrays of points;
  :func:`points_from_frames` — each point from a frame of its own (arrays of frames).
- :func:`polar_to_xy` — range and bearing readings (a LiDAR's) as x, y points.
- :func:`arc_step` / :func:`drive` — the exact motion of a unicycle at constant linear speed
  ``v`` and turn rate ``w`` over ``dt`` (a circular arc, a straight line when ``w`` = 0);
  :func:`arc_offsets` — the same arc from the origin, at an array of times.
- :func:`midpoint_step` — the second-order (midpoint) approximation of one step: the
  heading halfway through it; what the estimator's Kalman filter propagates (its
  Jacobians are this step's), which moves by a distance and a turn, not by (v, w).

>>> from clomp.formal.model import Pose
>>> p = compose(Pose(1.0, 0.0, math.pi / 2), Pose(2.0, 0.0))
>>> round(p.x, 9), round(p.y, 9), round(p.theta, 9)
(1.0, 2.0, 1.570796327)
>>> q = relative(Pose(1.0, 0.0, math.pi / 2), p)
>>> round(q.x, 9), round(q.y, 9) + 0.0, round(q.theta, 9)
(2.0, 0.0, 0.0)
"""

from __future__ import annotations

import math

import numpy as np

from clomp.formal.model import Pose

__all__ = [
    "arc_offsets",
    "arc_step",
    "compose",
    "dead_reckon",
    "drive",
    "midpoint_step",
    "points_from_frame",
    "points_from_frames",
    "points_to_frame",
    "points_to_frames",
    "polar_to_xy",
    "relative",
    "wheel_twist",
    "wrap_angle",
]

FrameLike = Pose | tuple[float, float, float]


def _xyt(frame: FrameLike) -> tuple[float, float, float]:
    if isinstance(frame, Pose):
        return frame.x, frame.y, frame.theta
    x, y, th = frame
    return float(x), float(y), float(th)


def wrap_angle(a: float) -> float:
    """Wrap an angle to (-pi, pi].

    >>> wrap_angle(3 * math.pi / 2) == -math.pi / 2
    True
    >>> wrap_angle(-math.pi) == math.pi
    True
    """
    a = math.fmod(a + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


def compose(base: Pose, local: Pose) -> Pose:
    """The pose ``local`` (given in the frame of a robot at ``base``) in ``base``'s frame.

    >>> compose(Pose(1.0, 2.0), Pose(0.5, 0.0))
    Pose(x=1.5, y=2.0, theta=0.0)
    """
    c, s = math.cos(base.theta), math.sin(base.theta)
    return Pose(
        base.x + c * local.x - s * local.y,
        base.y + s * local.x + c * local.y,
        wrap_angle(base.theta + local.theta),
    )


def relative(base: Pose, other: Pose) -> Pose:
    """The pose ``other`` seen from a robot at ``base`` (inverse of :func:`compose`).

    >>> relative(Pose(1.0, 2.0), Pose(1.5, 2.0))
    Pose(x=0.5, y=0.0, theta=0.0)
    """
    c, s = math.cos(base.theta), math.sin(base.theta)
    dx, dy = other.x - base.x, other.y - base.y
    return Pose(c * dx + s * dy, -s * dx + c * dy, wrap_angle(other.theta - base.theta))


def points_from_frame(points: np.ndarray, frame: FrameLike) -> np.ndarray:
    """N×2 ``points`` given in the frame of a robot at ``frame`` → the frame ``frame`` is given in.

    ``frame`` is a :class:`Pose` or an (x, y, theta) tuple. An empty array comes back as is.

    >>> points_from_frame(np.array([[1.0, 0.0]]), Pose(2.0, 0.0, math.pi / 2)).round(9).tolist()
    [[2.0, 1.0]]
    """
    if len(points) == 0:
        return points
    x, y, th = _xyt(frame)
    c, s = math.cos(th), math.sin(th)
    out: np.ndarray = np.stack((x + c * points[:, 0] - s * points[:, 1], y + s * points[:, 0] + c * points[:, 1]), axis=1)
    return out


def points_from_frames(points: np.ndarray, x: np.ndarray, y: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """N×2 ``points``, point i given in the frame of a robot at (``x[i]``, ``y[i]``, ``theta[i]``)
    → the frame those frames are given in: :func:`points_from_frame` with one frame per point
    (a revolution taken while the robot moved, each point from where it was taken).

    >>> pts = np.array([[1.0, 0.0], [1.0, 0.0]])
    >>> points_from_frames(pts, np.array([0.0, 2.0]), np.zeros(2), np.array([0.0, math.pi / 2])).round(9).tolist()
    [[1.0, 0.0], [2.0, 1.0]]
    """
    c, s = np.cos(theta), np.sin(theta)
    out: np.ndarray = np.stack((x + c * points[:, 0] - s * points[:, 1], y + s * points[:, 0] + c * points[:, 1]), axis=1)
    return out


def points_to_frame(points: np.ndarray, frame: FrameLike) -> np.ndarray:
    """N×2 ``points`` → the frame of a robot at ``frame`` (inverse of :func:`points_from_frame`).

    >>> points_to_frame(np.array([[2.0, 1.0]]), Pose(2.0, 0.0, math.pi / 2)).round(9).tolist()
    [[1.0, 0.0]]
    """
    x, y, th = _xyt(frame)
    c, s = math.cos(th), math.sin(th)
    rel = np.asarray(points, dtype=float) - np.array([x, y])
    out: np.ndarray = np.stack((rel[:, 0] * c + rel[:, 1] * s, -rel[:, 0] * s + rel[:, 1] * c), axis=1)
    return out


def points_to_frames(points: np.ndarray, xs: list[float], ys: list[float], ths: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """N×2 ``points`` → the frames of T robot poses at once: (u, v), each T×N, row t
    bit-identical to ``points_to_frame(points, (xs[t], ys[t], ths[t]))``'s two columns (the
    same scalar cos/sin and the same elementwise operations, broadcast over the poses).
    Why: a rollout tests its footprint at every tick; testing a block of ticks in one
    call costs one numpy call instead of one per tick.

    >>> u, v = points_to_frames(np.array([[2.0, 1.0]]), [2.0, 0.0], [0.0, 0.0], [math.pi / 2, 0.0])
    >>> u.round(9).tolist(), v.round(9).tolist()
    ([[1.0], [2.0]], [[0.0], [1.0]])
    """
    c = np.array([math.cos(t) for t in ths])[:, None]
    s = np.array([math.sin(t) for t in ths])[:, None]
    pts = np.asarray(points, dtype=float)
    rx = pts[:, 0][None, :] - np.asarray(xs, dtype=float)[:, None]
    ry = pts[:, 1][None, :] - np.asarray(ys, dtype=float)[:, None]
    return rx * c + ry * s, -rx * s + ry * c


def polar_to_xy(ranges: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Readings at ``ranges`` (m) and bearings ``angles`` (rad, counter-clockwise from x)
    → points ``(r cos a, r sin a)``, stacked on a last axis of 2 (N×2 for N readings).

    The one polar conversion: the scenarios' and simulators' ray casts, recorded bags and
    the fused revolutions all call it (numpy arithmetic in the inputs' own dtype).

    >>> polar_to_xy(np.array([1.0, 2.0]), np.array([0.0, math.pi / 2])).round(9).tolist()
    [[1.0, 0.0], [0.0, 2.0]]
    """
    out: np.ndarray = np.stack((ranges * np.cos(angles), ranges * np.sin(angles)), axis=-1)
    return out


def wheel_twist(left: float, right: float, wheel_base: float) -> tuple[float, float]:
    """Wheel speeds (m/s) → (linear speed v, turn rate w) of a differential drive.

    >>> wheel_twist(0.25, 0.75, 0.25)
    (0.5, 2.0)
    """
    return (left + right) / 2, (right - left) / wheel_base


def arc_step(x: float, y: float, th: float, v: float, w: float, dt: float) -> tuple[float, float, float]:
    """Exact unicycle motion over ``dt`` at linear speed ``v`` and turn rate ``w``.

    The heading is returned unwrapped (``th + w * dt``); :func:`drive` wraps it.

    >>> arc_step(0.0, 0.0, 0.0, 0.2, 0.0, 1.0)
    (0.2, 0.0, 0.0)
    >>> x, y, th = arc_step(0.0, 0.0, 0.0, math.pi / 2, math.pi / 2, 1.0)  # a quarter circle, r = 1
    >>> round(x, 9), round(y, 9), round(th, 9)
    (1.0, 1.0, 1.570796327)
    """
    if abs(w) < 1e-12:
        return x + v * dt * math.cos(th), y + v * dt * math.sin(th), th
    th2 = th + w * dt
    r = v / w
    return x + r * (math.sin(th2) - math.sin(th)), y - r * (math.cos(th2) - math.cos(th)), th2


def arc_offsets(v: float, w: float, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where a unicycle that starts at the origin heading along x is after each of the times
    ``dt`` (an array, s; negative: before) at linear speed ``v`` and turn rate ``w``: the exact
    arc of :func:`arc_step`, vectorised over the times. Returns the arrays (x, y, heading).

    A turn rate under 1e-9 rad/s is taken as a straight line (the arc's radius ``v / w``
    would carry no digits of the offset sideways).

    >>> x, y, th = arc_offsets(math.pi / 2, math.pi / 2, np.array([1.0, -1.0]))  # r = 1
    >>> x.round(9).tolist(), y.round(9).tolist(), th.round(9).tolist()
    ([1.0, -1.0], [1.0, 1.0], [1.570796327, -1.570796327])
    >>> [a.tolist() for a in arc_offsets(0.1, 0.0, np.array([-1.0]))]
    [[-0.1], [0.0], [-0.0]]
    """
    th = w * dt
    if abs(w) < 1e-9:
        return v * dt, np.zeros_like(dt), th
    r = v / w
    return r * np.sin(th), r * (1 - np.cos(th)), th


def midpoint_step(x: float, y: float, th: float, distance: float, turned: float) -> tuple[float, float, float]:
    """The pose (``x``, ``y``, ``th``) after moving ``distance`` (m) while its heading turns by
    ``turned`` (rad), by the midpoint rule: straight along the heading halfway through the
    turn. A second-order step (short of the exact arc's :func:`arc_step` by about
    ``distance * turned**2 / 24``); the estimator's Kalman filter propagates by it because
    its Jacobians are simple and its distance and turn come from separate sensors (wheels
    and gyro) with calibrations of their own. The heading is returned wrapped.

    >>> x, y, th = midpoint_step(0.0, 0.0, 0.0, 0.1, 0.2)
    >>> round(x, 6), round(y, 6), round(th, 9)
    (0.0995, 0.009983, 0.2)
    """
    thm = th + turned / 2
    return x + distance * math.cos(thm), y + distance * math.sin(thm), wrap_angle(th + turned)


def drive(pose: Pose, v: float, w: float, dt: float) -> Pose:
    """``pose`` after ``dt`` seconds at linear speed ``v`` and turn rate ``w`` (exact arc).

    >>> drive(Pose(0.0, 0.0, 0.0), 0.0, math.pi, 1.0) == Pose(0.0, 0.0, math.pi)
    True
    """
    x, y, th = arc_step(pose.x, pose.y, pose.theta, v, w, dt)
    # a straight step keeps the (already wrapped) heading bit for bit
    return Pose(x, y, th if abs(w) < 1e-12 else wrap_angle(th))


def dead_reckon(pose: Pose, left: float, right: float, wheel_base: float, dt: float) -> Pose:
    """``pose`` after ``dt`` seconds at the wheel speeds ``left``, ``right`` (m/s): dead reckoning.

    Unchanged when ``dt`` <= 0 or both wheels are stopped. What a controller without
    odometry believes from the speeds it commanded.

    >>> dead_reckon(Pose(0.0, 0.0), 0.1, 0.1, 0.2, 2.0)
    Pose(x=0.2, y=0.0, theta=0.0)
    >>> dead_reckon(Pose(1.0, 0.0), 0.0, 0.0, 0.2, 2.0)
    Pose(x=1.0, y=0.0, theta=0.0)
    """
    if dt <= 0 or (left == 0 and right == 0):
        return pose
    v, w = wheel_twist(left, right, wheel_base)
    return drive(pose, v, w, dt)
