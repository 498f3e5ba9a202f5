"""ROS 2 messages <-> clomp's types: LaserScan -> points, Odometry/Imu -> poses and headings,
wheel speeds <-> Twist, plans and cognitive maps -> Path and MarkerArray.

Everything here takes messages by their fields (duck typing), so it is importable and
testable without rclpy; the builders import the message classes when called. A message
that cannot be read raises :class:`MessageError` with one line that says what is wrong
with it (the node logs it and drops the message).

Conventions (REP 103/105): metres, radians, x forward, y left, z up. A LaserScan reading
``i`` is at ``angle_min + i * angle_increment`` in the LiDAR's frame (any sign and count);
inf, NaN and readings outside ``[range_min, range_max]`` are no return; the LiDAR's pose
on the base moves the points into the robot frame.

>>> from types import SimpleNamespace as M
>>> scan = M(angle_min=0.0, angle_max=math.pi, angle_increment=math.pi, ranges=[1.0, 2.0],
...          range_min=0.1, range_max=5.0, time_increment=0.0, scan_time=0.1)
>>> laserscan_to_points(scan).round(3).tolist()
[[1.0, 0.0], [-2.0, 0.0]]
>>> [round(v, 4) for v in twist_from_wheels(0.1, 0.2, 0.15)]
[0.15, 0.6667]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from clomp.formal.geometry import compose, wrap_angle
from clomp.formal.model import Pose
from clomp.runtime.records.bags import laserscan_points, points_to_ranges

__all__ = [
    "MessageError",
    "laserscan_to_points",
    "scan_point_times",
    "points_to_laserscan",
    "odometry_pose",
    "odometry_covariance",
    "planar_covariance",
    "imu_yaw",
    "yaw_quaternion",
    "twist_from_wheels",
    "wheels_from_twist",
    "make_twist",
    "make_odometry",
    "make_path",
    "map_markers",
    "stamp_seconds",
    "unwrap",
]


class MessageError(ValueError):
    """A message that cannot be used, with one line saying what is wrong with it."""


def stamp_seconds(stamp: Any) -> float:
    """A ``builtin_interfaces/Time`` as seconds.

    >>> from types import SimpleNamespace as M
    >>> stamp_seconds(M(sec=2, nanosec=500_000_000))
    2.5
    """
    return int(stamp.sec) + int(stamp.nanosec) * 1e-9


def _check_scan(msg: Any) -> np.ndarray:
    """The ranges of a LaserScan whose angles make sense; MessageError otherwise."""
    a0, a1, inc = float(msg.angle_min), float(msg.angle_max), float(msg.angle_increment)
    if not (math.isfinite(a0) and math.isfinite(a1) and math.isfinite(inc)):
        raise MessageError(f"LaserScan angles must be finite, got angle_min={a0}, angle_max={a1}, angle_increment={inc}")
    if inc == 0.0:
        raise MessageError("LaserScan angle_increment is 0: the readings have no bearings")
    r = np.asarray(msg.ranges, dtype=float).reshape(-1)
    span = (a1 - a0) / inc
    if span < -1e-3:
        raise MessageError(f"LaserScan angle_increment {inc:g} points away from angle_max: "
                           f"angle_min={a0:g}, angle_max={a1:g}")
    expected = int(round(span)) + 1
    # drivers disagree by one about whether angle_max is a reading: accept n or n-1 or n+1
    if len(r) == 0 or abs(len(r) - expected) > 1:
        raise MessageError(f"LaserScan has {len(r)} ranges but its angles (angle_min={a0:g}, angle_max={a1:g}, "
                           f"angle_increment={inc:g}) make {expected}")
    return r


def laserscan_to_points(msg: Any, offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
                        max_range: float | None = None) -> np.ndarray:
    """The robot-frame points (N×2) of a ``sensor_msgs/LaserScan``; ``offset`` is the LiDAR's
    pose (x, y, θ) on the base; ``max_range`` crops farther readings too (the planner's reach).
    MessageError for angles that make no sense or a ``ranges`` of the wrong length."""
    r = _check_scan(msg)
    hi = float(msg.range_max)
    if max_range is not None:
        hi = min(hi, max_range) if math.isfinite(hi) else max_range
    return laserscan_points(float(msg.angle_min), float(msg.angle_increment), r, float(msg.range_min), hi, offset)


def scan_point_times(msg: Any, offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
                     max_range: float | None = None) -> np.ndarray | None:
    """When each kept point of :func:`laserscan_to_points` was measured, in seconds
    relative to the last reading (<= 0), from ``time_increment``; None when the scan does
    not say (``time_increment`` 0)."""
    inc = float(getattr(msg, "time_increment", 0.0) or 0.0)
    if not (math.isfinite(inc) and inc > 0):
        return None
    r = _check_scan(msg)
    lo = float(msg.range_min) if math.isfinite(float(msg.range_min)) else 0.0
    hi = float(msg.range_max) if not math.isnan(float(msg.range_max)) else math.inf
    if max_range is not None:
        hi = min(hi, max_range)
    keep = np.isfinite(r) & (r >= lo) & (r <= hi)
    t = (np.arange(len(r)) - (len(r) - 1)) * inc
    out: np.ndarray = t[keep]
    return out


def points_to_laserscan(points: np.ndarray, count: int, range_max: float) -> tuple[float, float, float, np.ndarray]:
    """A full counter-clockwise revolution from 0 in ``count`` readings: (angle_min,
    angle_max, angle_increment, ranges) for robot-frame ``points`` (the sim's LiDAR)."""
    inc = 2 * math.pi / count
    return 0.0, inc * (count - 1), inc, points_to_ranges(points, 0.0, inc, count, range_max)


def _yaw(q: Any) -> float:
    x, y, z, w = float(q.x), float(q.y), float(q.z), float(q.w)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def yaw_quaternion(theta: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``theta`` about z.

    >>> [round(v, 3) for v in yaw_quaternion(math.pi / 2)]
    [0.0, 0.0, 0.707, 0.707]
    """
    return 0.0, 0.0, math.sin(theta / 2), math.cos(theta / 2)


def odometry_pose(msg: Any, frame: str | None = None, child: str | None = None) -> Pose:
    """The planar pose of a ``nav_msgs/Odometry`` (x, y, yaw); MessageError for a pose
    that is not finite or, when ``frame``/``child`` are given, in another frame."""
    fid = str(msg.header.frame_id).lstrip("/")
    if frame is not None and fid != frame.lstrip("/"):
        raise MessageError(f"Odometry in frame {fid!r}, expected {frame!r} (set the node's odom_frame parameter)")
    cid = str(getattr(msg, "child_frame_id", "")).lstrip("/")
    if child is not None and cid and cid != child.lstrip("/"):
        raise MessageError(f"Odometry of child frame {cid!r}, expected {child!r} (set the node's base_frame parameter)")
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    vals = (float(p.x), float(p.y), float(q.x), float(q.y), float(q.z), float(q.w))
    if not all(math.isfinite(v) for v in vals):
        raise MessageError(f"Odometry pose is not finite: position ({p.x}, {p.y}), orientation ({q.x}, {q.y}, {q.z}, {q.w})")
    if abs(math.sqrt(sum(v * v for v in vals[2:])) - 1.0) > 0.1:
        raise MessageError(f"Odometry orientation is not a unit quaternion: ({q.x}, {q.y}, {q.z}, {q.w})")
    return Pose(float(p.x), float(p.y), _yaw(q))


_PLANAR = (0, 1, 5)  # x, y and rotation about z in a ROS 6×6 (x, y, z, rot x, rot y, rot z) covariance


def planar_covariance(values: Sequence[float]) -> np.ndarray | None:
    """The planar (x, y, yaw) 3×3 block of a ROS 6×6 row-major covariance; None when it is
    unknown: all zeros, -1 in its first element (REP 145), not finite, or a negative variance
    (a base that cannot say, or says nonsense, leaves the estimator its own noise).

    >>> c = [0.0] * 36; c[0], c[7], c[35], c[5], c[30] = 0.04, 0.09, 0.01, 0.002, 0.002
    >>> planar_covariance(c).tolist()
    [[0.04, 0.0, 0.002], [0.0, 0.09, 0.0], [0.002, 0.0, 0.01]]
    >>> planar_covariance([0.0] * 36) is None, planar_covariance([-1.0] + [0.0] * 35) is None
    (True, True)
    """
    full = np.asarray(values, dtype=float).reshape(-1)
    if full.size != 36 or not np.all(np.isfinite(full)) or full[0] == -1.0 or not np.any(full):
        return None
    out: np.ndarray = full.reshape(6, 6)[np.ix_(_PLANAR, _PLANAR)]
    out = (out + out.T) / 2
    if np.any(np.diag(out) < 0) or not np.any(out):
        return None
    return out


def odometry_covariance(msg: Any) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The planar (pose, twist) covariances of a ``nav_msgs/Odometry`` (the pose's in its
    frame, the twist's in its child frame), each None when unknown (:func:`planar_covariance`)."""
    return planar_covariance(msg.pose.covariance), planar_covariance(msg.twist.covariance)


def imu_yaw(msg: Any) -> float | None:
    """The yaw of a ``sensor_msgs/Imu``'s orientation; None when it has none (covariance[0]
    = -1, the REP 145 convention, or an all-zero quaternion); MessageError when not finite."""
    q = msg.orientation
    vals = (float(q.x), float(q.y), float(q.z), float(q.w))
    if float(msg.orientation_covariance[0]) == -1.0 or not any(vals):
        return None
    if not all(math.isfinite(v) for v in vals):
        raise MessageError(f"Imu orientation is not finite: ({q.x}, {q.y}, {q.z}, {q.w})")
    return _yaw(q)


def twist_from_wheels(left: float, right: float, wheel_base: float) -> tuple[float, float]:
    """(linear.x m/s, angular.z rad/s) of wheel speeds (m/s) on a differential drive."""
    return (left + right) / 2, (right - left) / wheel_base


def wheels_from_twist(v: float, w: float, wheel_base: float) -> tuple[float, float]:
    """(left, right) wheel speeds (m/s) for a twist: the inverse of :func:`twist_from_wheels`.

    >>> [round(v, 4) for v in wheels_from_twist(0.15, 0.6666666, 0.15)]
    [0.1, 0.2]
    """
    return v - w * wheel_base / 2, v + w * wheel_base / 2


def make_twist(v: float = 0.0, w: float = 0.0) -> Any:
    """A ``geometry_msgs/Twist`` with linear.x ``v`` and angular.z ``w`` (zero: stop)."""
    from geometry_msgs.msg import Twist

    msg = Twist()
    msg.linear.x, msg.angular.z = float(v), float(w)
    return msg


def _set_pose(target: Any, pose: Pose) -> None:
    target.position.x, target.position.y = float(pose.x), float(pose.y)
    q = yaw_quaternion(pose.theta)
    target.orientation.x, target.orientation.y, target.orientation.z, target.orientation.w = q


def make_odometry(pose: Pose, stamp: Any, frame: str, child: str, twist: tuple[float, float] = (0.0, 0.0),
                  pose_covariance: Sequence[float] | None = None, twist_covariance: Sequence[float] | None = None) -> Any:
    """A ``nav_msgs/Odometry`` of a planar pose (and its body twist); the covariances (36
    values each, row-major 6×6) stay zero, unknown, unless given."""
    from nav_msgs.msg import Odometry

    msg = Odometry()
    msg.header.stamp, msg.header.frame_id, msg.child_frame_id = stamp, frame, child
    _set_pose(msg.pose.pose, pose)
    msg.twist.twist.linear.x, msg.twist.twist.angular.z = float(twist[0]), float(twist[1])
    if pose_covariance is not None:
        msg.pose.covariance = [float(v) for v in pose_covariance]
    if twist_covariance is not None:
        msg.twist.covariance = [float(v) for v in twist_covariance]
    return msg


def make_path(poses: Sequence[Sequence[float]], stamp: Any, frame: str) -> Any:
    """A ``nav_msgs/Path`` through ``[[x, y, theta], …]`` (a plan record's ``path``)."""
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Path

    msg = Path()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    for x, y, th in poses:
        ps = PoseStamped()
        ps.header = msg.header
        _set_pose(ps.pose, Pose(float(x), float(y), float(th)))
        msg.poses.append(ps)
    return msg


def _rgba(marker: Any, r: float, g: float, b: float, a: float = 1.0) -> None:
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = r, g, b, a


def map_markers(result: Any, origin: Pose, stamp: Any, frame: str) -> Any:
    """A ``visualization_msgs/MarkerArray`` of a plan's cognitive map in the odometry frame:
    every explored task as a thin line (grey), the plan as a bold line (green), each state
    labelled (``q3:RIGHT``) at its end, each collision (a task cut short by a disturbance)
    a red sphere; the first marker deletes the previous drawing."""
    from geometry_msgs.msg import Point
    from visualization_msgs.msg import Marker, MarkerArray

    def marker(mid: int, kind: int, ns: str) -> Any:
        m = Marker()
        m.header.stamp, m.header.frame_id = stamp, frame
        m.ns, m.id, m.type, m.action = ns, mid, kind, Marker.ADD
        m.pose.orientation.w = 1.0
        return m

    def point(p: Pose) -> Any:
        w = compose(origin, p)
        return Point(x=float(w.x), y=float(w.y), z=0.0)

    out = MarkerArray()
    clear = Marker()
    clear.header.stamp, clear.header.frame_id, clear.action = stamp, frame, Marker.DELETEALL
    out.markers.append(clear)
    tree = marker(0, Marker.LINE_LIST, "tree")
    tree.scale.x = 0.005
    _rgba(tree, 0.6, 0.6, 0.6, 0.8)
    for q in result.map:
        if q.ident == 0 and q.start == q.end:
            continue
        tree.points += [point(q.start), point(q.end)]
    out.markers.append(tree)
    plan = marker(1, Marker.LINE_STRIP, "plan")
    plan.scale.x = 0.03
    _rgba(plan, 0.1, 0.8, 0.2)
    states = [result.map[i] for i in result.plan.states]
    plan.points = [point(states[0].start)] + [point(q.end) for q in states] if states else []
    out.markers.append(plan)
    mid = 2
    for q in result.map:
        label = marker(mid, Marker.TEXT_VIEW_FACING, "labels")
        label.pose.position = point(q.end)
        label.pose.position.z = 0.05
        label.scale.z = 0.04
        _rgba(label, 1.0, 1.0, 1.0)
        label.text = q.label + (" (goal)" if q.reached_goal else "")
        out.markers.append(label)
        mid += 1
        if q.interrupted:
            hit = marker(mid, Marker.SPHERE, "collisions")
            hit.pose.position = point(q.end)
            hit.scale.x = hit.scale.y = hit.scale.z = 0.04
            _rgba(hit, 0.9, 0.1, 0.1)
            out.markers.append(hit)
            mid += 1
    return out


def unwrap(previous: float | None, angle: float) -> float:
    """``angle`` moved by whole turns to lie within π of ``previous`` (a continuous heading).

    >>> round(unwrap(3.1, -3.1), 4)
    3.1832
    """
    return angle if previous is None else previous + wrap_angle(angle - previous)
