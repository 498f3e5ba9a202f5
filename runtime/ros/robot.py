"""A :class:`~clomp.runtime.interface.Robot` whose devices are ROS 2 topics.

:class:`RosRobot` subscribes to ``/scan`` (``sensor_msgs/LaserScan``), ``/odom``
(``nav_msgs/Odometry``) and, when it comes, ``/imu`` (``sensor_msgs/Imu``: the heading),
all with the sensor-data QoS, and publishes the wheel speeds as ``geometry_msgs/Twist``
on ``/cmd_vel`` (reliable). The supervisor drives it as any other backend: the newest
scan in the robot frame (the LiDAR's pose on the base applied), the base's odometry, the
IMU's heading. The ``/odom`` covariance (pose and twist), when the base fills it in,
is the least noise the estimator takes for each step of that odometry (all zeros or -1:
unknown, the estimator's own model then).

Fail-safe, as the hardware robot's stream watch: a watchdog in the ROS executor's thread
*trips* the robot when ``/scan`` (or ``/odom``, when used) brings nothing valid for
``sensor_timeout`` s, or when a message carries garbage (an odometry pose that is not
finite, a stamp earlier than the one before): a zero Twist goes out at once, and every
later call raises :class:`~clomp.runtime.interface.RobotFault` with the reason. A message
that cannot be used (a LaserScan with ``angle_increment`` 0, ``ranges`` of the wrong
length, an odometry of another frame) is logged with what is wrong and dropped: if no
valid one follows, the watchdog trips with that reason. A scan's NaN readings are no
return (REP 117) and are counted in the log.

Nothing here runs rclpy at import time; the constructor takes a node.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from clomp.formal.model import Pose
from clomp.planner.noise import NoiseTerms
from clomp.runtime.backends.calibration import ToldCalibration
from clomp.runtime.interface import RobotFault, ScanFrame
from clomp.runtime.records.runlog import RunLogLike
from clomp.runtime.ros.convert import (
    MessageError,
    imu_yaw,
    laserscan_to_points,
    make_twist,
    odometry_covariance,
    odometry_pose,
    scan_point_times,
    stamp_seconds,
    twist_from_wheels,
    unwrap,
)

__all__ = ["CalibratedRosRobot", "RosRobot", "RosRobotConfig"]


@dataclass(frozen=True)
class RosRobotConfig:
    """Topics, frames and limits of a :class:`RosRobot` (SI units).

    >>> RosRobotConfig().sensor_timeout, RosRobotConfig(use_odom=False).topics()["odom"]
    (0.5, None)
    """

    scan_topic: str = "/scan"
    odom_topic: str = "/odom"
    imu_topic: str = "/imu"
    cmd_topic: str = "/cmd_vel"
    odom_frame: str = "odom"
    base_frame: str = "base_link"
    lidar_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    use_odom: bool = True
    use_imu: bool = True
    sensor_timeout: float = 0.5
    startup_timeout: float = 10.0
    dry_run: bool = False

    def __post_init__(self) -> None:
        for name in ("sensor_timeout", "startup_timeout"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {v!r}")
        if len(self.lidar_offset) != 3 or not all(math.isfinite(v) for v in self.lidar_offset):
            raise ValueError(f"lidar_offset must be three finite numbers x, y, theta, got {self.lidar_offset!r}")

    def topics(self) -> dict[str, str | None]:
        """The topics in use (None: not subscribed)."""
        return {"scan": self.scan_topic, "odom": self.odom_topic if self.use_odom else None,
                "imu": self.imu_topic if self.use_imu else None, "cmd_vel": self.cmd_topic}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        d = asdict(self)
        d["lidar_offset"] = list(self.lidar_offset)
        return d


class RosRobot:
    """The robot behind ROS 2 topics (see the module); ``node`` is an ``rclpy`` node whose
    executor runs in another thread; ``wheel_base`` turns wheel speeds into a Twist."""

    def __init__(self, node: Any, wheel_base: float, config: RosRobotConfig | None = None,
                 log: RunLogLike | None = None) -> None:
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry
        from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
        from sensor_msgs.msg import Imu, LaserScan

        self.node, self.wheel_base = node, float(wheel_base)
        self.config = c = config or RosRobotConfig()
        self._log_sink = log
        self._cond = threading.Condition()
        self._frame: ScanFrame | None = None
        self._fresh = False
        self._scan_at: float | None = None  # monotonic time of the last valid scan / odometry
        self._odom_at: float | None = None
        self._stamps: dict[str, float] = {}
        self._pose: Pose | None = None
        self._covariance: tuple[np.ndarray | None, np.ndarray | None] = (None, None)  # of /odom: pose, twist
        self._yaw: float | None = None
        self._rejected: dict[str, str] = {}  # topic -> why its last message was dropped
        self.rejects: dict[str, int] = {"scan": 0, "odom": 0, "imu": 0}
        self._told: set[str] = set()
        self.nan_readings = 0
        self.scans = 0
        self.commands = 0
        self._fault: str | None = None
        self._armed = False
        self._closed = False
        self.wheels_stopped = True
        self.last_scan_received: float | None = None
        #: per scan a control step read: (its header stamp in ns, when it arrived, when the first
        #: command of that step went out; monotonic s), for benchmarks
        self.latencies: list[tuple[int, float, float]] = []
        self._frame_received: tuple[int, float] = (0, 0.0)
        self._caused_by: tuple[int, float] | None = None
        self._cmd_pub = node.create_publisher(Twist, c.cmd_topic, QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
        self._subs = [node.create_subscription(LaserScan, c.scan_topic, self._on_scan, qos_profile_sensor_data)]
        if c.use_odom:
            self._subs.append(node.create_subscription(Odometry, c.odom_topic, self._on_odom, qos_profile_sensor_data))
        if c.use_imu:
            self._subs.append(node.create_subscription(Imu, c.imu_topic, self._on_imu, qos_profile_sensor_data))
        self._period = min(0.05, c.sensor_timeout / 4)
        self._watched = time.monotonic()
        self._timer = node.create_timer(self._period, self._watch)

    # -- the executor's side ---------------------------------------------------------------
    def _write(self, event: str, **fields: Any) -> None:
        if self._log_sink is not None:
            try:
                self._log_sink.write(event, **fields)
            except Exception:  # a full disk must not stop the fail-safe
                self._log_sink = None

    def _reject(self, topic: str, why: str) -> None:
        """Log a message that cannot be used (each reason once, and every 50th drop)."""
        self.rejects[topic] += 1
        self._rejected[topic] = why
        n = self.rejects[topic]
        first = why not in self._told and len(self._told) < 100
        self._told.add(why)
        if first or n % 50 == 0:
            self.node.get_logger().error(f"dropped a message on {topic} ({n} so far): {why}")
            self._write("ros", topic=topic, rejected=n, error=why)

    def _monotonic(self, stamp: Any) -> float:
        """The monotonic time of a ROS stamp (the receive time when the stamp is not recent)."""
        now = time.monotonic()
        age = self.node.get_clock().now().nanoseconds * 1e-9 - stamp_seconds(stamp)
        return now - age if 0.0 <= age <= 1.0 else now

    def _backwards(self, topic: str, stamp: Any) -> bool:
        t = stamp_seconds(stamp)
        last = self._stamps.get(topic)
        if last is not None and t < last:
            self.trip(f"{topic} time went backwards: stamp {t:.3f} s after {last:.3f} s", source=topic)
            return True
        self._stamps[topic] = t
        return False

    def _on_scan(self, msg: Any) -> None:
        received = time.monotonic()
        if self._backwards("scan", msg.header.stamp):
            return
        c = self.config
        try:
            points = laserscan_to_points(msg, c.lidar_offset)
            times = scan_point_times(msg, c.lidar_offset)
        except (MessageError, ValueError) as exc:
            self._reject("scan", str(exc))
            return
        nans = int(np.isnan(np.asarray(msg.ranges, dtype=np.float32)).sum())
        if nans:
            self.nan_readings += nans
            if self.nan_readings == nans:
                why = f"LaserScan with {nans} NaN readings: taken as no return (REP 117)"
                self.node.get_logger().warning(why)
                self._write("ros", topic="scan", warning=why)
        stamp = self._monotonic(msg.header.stamp)
        end = stamp + (0.0 if times is None else float(len(msg.ranges) - 1) * float(msg.time_increment))
        frame = ScanFrame(points, timestamp=min(end, received), point_times=times)
        with self._cond:
            self._frame, self._fresh = frame, True
            self._scan_at = self.last_scan_received = received
            self._frame_received = (int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec), received)
            self.scans += 1
            self._rejected.pop("scan", None)
            self._cond.notify_all()

    def _on_odom(self, msg: Any) -> None:
        c = self.config
        try:
            pose = odometry_pose(msg, c.odom_frame, c.base_frame)
        except MessageError as exc:
            if "not finite" in str(exc) or "unit quaternion" in str(exc):
                self.trip(f"/odom carries garbage: {exc}", source="odom")
            else:
                self._reject("odom", str(exc))
            return
        if self._backwards("odom", msg.header.stamp):
            return
        covariance = odometry_covariance(msg)
        with self._cond:
            self._pose, self._odom_at, self._covariance = pose, time.monotonic(), covariance
            self._rejected.pop("odom", None)
            self._cond.notify_all()

    def _on_imu(self, msg: Any) -> None:
        try:
            yaw = imu_yaw(msg)
        except MessageError as exc:
            self._reject("imu", str(exc))
            return
        if yaw is not None:
            with self._cond:
                self._yaw = unwrap(self._yaw, yaw)

    def _watch(self) -> None:
        """The watchdog (executor thread): trip on a sensor that fell silent. Not in a round
        that comes late: then this thread itself was held up, and the messages that came
        meanwhile wait in its queue (a false trip otherwise)."""
        now, limit = time.monotonic(), self.config.sensor_timeout
        starved = now - self._watched > 2 * self._period  # this thread was held up (the GIL, the machine)
        self._watched = now
        if not self._armed or self._fault is not None or starved:
            return  # a starved executor has messages queued: judge after it took them
        for topic, at in (("scan", self._scan_at), ("odom", self._odom_at if self.config.use_odom else now)):
            if at is not None and now - at > limit:
                why = self._rejected.get(topic)
                self.trip(f"{topic} silent: no valid message for {now - at:.2f} s"
                          + (f" (last dropped: {why})" if why else ""), source=topic)
                return

    def trip(self, reason: str, source: str = "ros") -> None:
        """Latch a fault and send a zero Twist now (from whichever thread found it)."""
        with self._cond:
            if self._fault is not None:
                return
            self._fault = reason
            self._cond.notify_all()
        self.node.get_logger().error(f"fault: {reason}; wheels stopped")
        self._write("fault", reason=reason, source=source)
        self._publish(0.0, 0.0)

    # -- the Robot protocol (the supervisor's thread) -------------------------------------------
    @property
    def fault(self) -> str | None:
        """Why the robot tripped, None while it has not."""
        return self._fault

    def _check(self) -> None:
        if self._fault is not None:
            raise RobotFault(self._fault)
        if self._closed:
            raise RobotFault("the ROS robot is closed")

    def wait_ready(self) -> None:
        """Wait for the first scan (and odometry, when used), then arm the watchdog;
        RobotFault naming the silent topics after ``startup_timeout`` s."""
        c = self.config
        deadline = time.monotonic() + c.startup_timeout
        with self._cond:
            while not (self._scan_at is not None and (self._odom_at is not None or not c.use_odom)):
                left = deadline - time.monotonic()
                if left <= 0 or self._fault is not None:
                    break
                self._cond.wait(left)
            self._check()
            missing = [t for t, at in ((c.scan_topic, self._scan_at), (c.odom_topic, self._odom_at if c.use_odom else 0.0))
                       if at is None]
            if missing:
                why = "; ".join(f"{k}: {v}" for k, v in self._rejected.items())
                raise RobotFault(f"nothing valid on {' and '.join(missing)} for {c.startup_timeout:g} s"
                                 + (f" (dropped: {why})" if why else ""))
            self._armed = True

    def wait_scan(self, until: float) -> None:
        """Block until a scan not yet read arrives, a fault, or monotonic time ``until``."""
        with self._cond:
            while not self._fresh and self._fault is None:
                left = until - time.monotonic()
                if left <= 0:
                    return
                self._cond.wait(left)

    def read_scan(self, timeout: float | None = None) -> ScanFrame | None:
        """The newest scan not returned before, waiting up to ``timeout`` s (None: until one comes)."""
        self._check()
        until = None if timeout is None else time.monotonic() + max(0.0, timeout)
        with self._cond:
            while not self._fresh and self._fault is None:
                left = None if until is None else until - time.monotonic()
                if left is not None and left <= 0:
                    break
                self._cond.wait(left)
            self._check()
            if not self._fresh:
                return None
            self._fresh = False
            self._caused_by = self._frame_received
            return self._frame

    def _publish(self, left: float, right: float) -> None:
        if self.config.dry_run:
            return
        v, w = twist_from_wheels(left, right, self.wheel_base)
        self._cmd_pub.publish(make_twist(v, w))
        self.commands += 1
        if self._caused_by is not None:
            self.latencies.append((*self._caused_by, time.monotonic()))
            self._caused_by = None
        self.wheels_stopped = v == 0.0 and w == 0.0

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Publish the wheel speeds as a Twist (nothing in a dry run); RobotFault once tripped."""
        self._check()
        if not (math.isfinite(left) and math.isfinite(right)):
            raise ValueError(f"wheel speeds must be finite, got ({left}, {right})")
        self._publish(float(left), float(right))

    def stop(self) -> None:
        """Publish a zero Twist; always allowed, also after a fault or :meth:`close`."""
        try:
            self._publish(0.0, 0.0)
        except Exception:  # the context may be shut down already: nothing more can be sent
            self.wheels_stopped = False
            raise

    def odometry(self) -> Pose | None:
        """The newest ``/odom`` pose (odom frame), None without odometry."""
        self._check()
        return self._pose if self.config.use_odom else None

    def odometry_covariance(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The newest ``/odom``'s planar (pose, twist) covariance, None where the base leaves
        it unknown (all zeros, or -1 first): the estimator's prediction noise for a step is
        no smaller than it (:mod:`clomp.runtime.estimation.reported`)."""
        return self._covariance if self.config.use_odom else (None, None)

    def rotation(self) -> float | None:
        """The IMU's heading (rad, unwrapped: turns add up), None before an Imu with an orientation came."""
        return self._yaw

    def close(self) -> None:
        """Stop (a zero Twist) and unsubscribe."""
        if self._closed:
            return
        try:
            self.stop()
        finally:
            self._closed = True
            self._armed = False
            for s in self._subs:
                self.node.destroy_subscription(s)
            self.node.destroy_timer(self._timer)


class CalibratedRosRobot(ToldCalibration, RosRobot):
    """A :class:`RosRobot` told its drive's calibration (``clomp ros node --calibration FILE``,
    parameter ``calibration``; :mod:`clomp.runtime.backends.calibration`): the estimator's wheel
    prior is sized to ``calibration``'s terms (:class:`~clomp.runtime.interface.Calibrated`)
    instead of the worst case's. The other arguments are :class:`RosRobot`'s."""

    def __init__(self, node: Any, wheel_base: float, config: RosRobotConfig | None = None,
                 log: RunLogLike | None = None, *, calibration: NoiseTerms) -> None:
        self.tell(calibration)
        super().__init__(node, wheel_base, config, log)
