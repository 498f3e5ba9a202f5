"""``clomp ros sim``: the execution world as a ROS 2 node.

:class:`SimNode` runs a :class:`~clomp.runtime.backends.world.WorldRobot` (a scenario or
layout, a noise preset, a seed) in real time — a timer advances it to the wall clock — and
speaks the topics a ROS base does:

- publishes ``/scan`` (``sensor_msgs/LaserScan``, sensor-data QoS): each revolution of the
  world's LiDAR when it completes, its beams measured while the robot moved (counter-clockwise
  from the front, ``time_increment`` set, stamped at its first beam);
- ``/odom`` (``nav_msgs/Odometry``, ``odom`` → ``base_link``): wheel odometry integrated from
  the wheels' turning, so it drifts as the world's slip and heading drift say;
- ``/imu`` (``sensor_msgs/Imu``): the world's rate gyro (its integrated heading and rate);
- ``/ground_truth`` (``nav_msgs/Odometry``, frame ``map``: the scenario's world frame);
- consumes ``/cmd_vel`` (``geometry_msgs/Twist``): wheel speeds by the model's wheel base,
  subject to the world's latency and acceleration limits; a command older than
  ``cmd_timeout`` s stops the wheels (a base's own fail-safe).
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

from clomp.formal.geometry import dead_reckon, relative
from clomp.formal.model import Pose
from clomp.runtime.backends.world import WorldRobot
from clomp.runtime.ros.convert import make_odometry, points_to_laserscan, wheels_from_twist, yaw_quaternion

__all__ = ["SimNode"]


class SimNode:
    """The world behind ROS topics (see the module). ``node`` is an rclpy node spun elsewhere."""

    def __init__(self, node: Any, world: WorldRobot, wheel_base: float, *, cmd_timeout: float = 0.5,
                 rate: float = 50.0, laser_frame: str = "laser") -> None:
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import Imu, LaserScan

        if not (math.isfinite(cmd_timeout) and cmd_timeout > 0):
            raise ValueError(f"cmd_timeout must be a positive number of seconds, got {cmd_timeout!r}")
        self.node, self.world, self.wheel_base = node, world, float(wheel_base)
        self.cmd_timeout, self.laser_frame = float(cmd_timeout), laser_frame
        self.lock = threading.Lock()
        self.odom = Pose(0.0, 0.0, 0.0)  # wheel odometry, odom frame (the start pose is its origin)
        self.commands = 0
        self.stale_stops = 0
        self.scans = 0
        self.scan_sent_at: list[float] = []  # monotonic time each /scan went out (benchmarks)
        self.error: BaseException | None = None
        self._last_cmd: float | None = None
        self._last: float | None = None
        self._sent: Any = None
        self._scan_pub = node.create_publisher(LaserScan, "/scan", qos_profile_sensor_data)
        self._odom_pub = node.create_publisher(Odometry, "/odom", 10)
        self._imu_pub = node.create_publisher(Imu, "/imu", qos_profile_sensor_data)
        self._truth_pub = node.create_publisher(Odometry, "/ground_truth", 10)
        self._sub = node.create_subscription(Twist, "/cmd_vel", self._on_cmd, 10)
        self._timer = node.create_timer(1.0 / rate, self._step)

    # -- callbacks (the executor's thread) -----------------------------------------------------
    def _on_cmd(self, msg: Any) -> None:
        v, w = float(msg.linear.x), float(msg.angular.z)
        if not (math.isfinite(v) and math.isfinite(w)):
            self.node.get_logger().error(f"/cmd_vel not finite ({v}, {w}): wheels stopped")
            v = w = 0.0
        with self.lock:
            self._catch_up()
            self.world.set_wheel_speeds(*wheels_from_twist(v, w, self.wheel_base))
            self._last_cmd = time.monotonic() if (v, w) != (0.0, 0.0) else None  # a stop does not go stale
            self.commands += 1

    def _catch_up(self) -> None:
        """Advance the world to now, step by physics step, integrating the wheel odometry."""
        now = time.monotonic()
        if self._last is None:
            self._last = now
            return
        end = self.world.now() + (now - self._last)
        self._last = now
        w = self.world
        while w.now() < end - 1e-9:
            dt = min(w.dt, end - w.now())
            w.sleep(dt)
            left, right = w.wheel_speeds
            self.odom = dead_reckon(self.odom, left, right, self.wheel_base, dt)

    def _step(self) -> None:
        try:
            with self.lock:
                self._catch_up()
                if self._last_cmd is not None and time.monotonic() - self._last_cmd > self.cmd_timeout:
                    self.world.stop()
                    self._last_cmd = None
                    self.stale_stops += 1
                    self.node.get_logger().warning(f"/cmd_vel stale for {self.cmd_timeout:g} s: wheels stopped")
                self._publish()
        except Exception as exc:  # keep it for the command's summary; the timer goes on
            self.error = exc

    def _publish(self) -> None:
        stamp = self.node.get_clock().now()
        msg_stamp = stamp.to_msg()
        w = self.world
        left, right = w.wheel_speeds
        twist = ((left + right) / 2, (right - left) / self.wheel_base)
        self._odom_pub.publish(make_odometry(self.odom, msg_stamp, "odom", "base_link", twist))
        self._truth_pub.publish(make_odometry(w.ground_truth_pose(), msg_stamp, "map", "base_link"))
        heading = w.rotation()
        if heading is not None:
            self._imu_pub.publish(self._imu(heading, twist[1], msg_stamp))
        frame = w.newest_revolution()
        if frame is not None and frame is not self._sent:
            self._sent = frame
            self._scan_pub.publish(self._scan(frame.points, stamp, w.now() - frame.timestamp))
            self.scans += 1
            self.scan_sent_at.append(time.monotonic())

    def _imu(self, heading: float, rate: float, stamp: Any) -> Any:
        from sensor_msgs.msg import Imu

        msg = Imu()
        msg.header.stamp, msg.header.frame_id = stamp, "base_link"
        q = yaw_quaternion(heading)
        msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = q
        msg.angular_velocity.z = float(rate)
        msg.linear_acceleration.z = 9.81
        return msg

    def _scan(self, points: Any, stamp: Any, age: float) -> Any:
        """A revolution that ended ``age`` s before ``stamp`` as a LaserScan stamped at its first beam."""
        from rclpy.duration import Duration
        from sensor_msgs.msg import LaserScan

        w = self.world
        a0, a1, inc, ranges = points_to_laserscan(points, w.rays, w.max_range)
        msg = LaserScan()
        period = 1.0 / w.scan_rate
        first = max(0.0, age) + period * (w.rays - 1) / w.rays
        msg.header.stamp = (stamp - Duration(nanoseconds=int(first * 1e9))).to_msg()
        msg.header.frame_id = self.laser_frame
        msg.angle_min, msg.angle_max, msg.angle_increment = a0, a1, inc
        msg.time_increment = period / w.rays
        msg.scan_time = period
        msg.range_min, msg.range_max = 0.01, float(w.max_range)
        msg.ranges = ranges.tolist()
        return msg

    # -- for the command and tests ------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        """Where the robot is (world frame), how far from the scenario's goal, its collisions,
        and the odometry's error against the truth (m)."""
        with self.lock:
            w = self.world
            truth = w.ground_truth_pose()
            gx, gy = w.scene.goal
            seen = relative(w.start_pose, truth)
            return {"pose": truth.as_list(), "goal_distance": math.hypot(truth.x - gx, truth.y - gy),
                    "collisions": w.collisions, "odometry_error": math.hypot(seen.x - self.odom.x, seen.y - self.odom.y),
                    "commands": self.commands, "scans": self.scans, "stale_stops": self.stale_stops}

    def close(self) -> None:
        """Stop the wheels and the timer."""
        with self.lock:
            self.world.stop()
        self.node.destroy_timer(self._timer)
        self.node.destroy_subscription(self._sub)
