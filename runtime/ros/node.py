"""``clomp ros node``'s parts: the node's parameters, its outputs, its goals, its loop.

The node is the supervisor of ``clomp run`` on a :class:`~clomp.runtime.ros.robot.RosRobot`.
Parameters (:data:`PARAMETERS`) give the robot model (the paper's robot by default), the
planner's budget, the topics' frames and ``moving`` (a world that moves, issue #42: the
planner and the supervisor with WAIT and REVERSE; a REVERSE goes out as a negative
``linear.x``, a WAIT as a zero Twist). Outputs (:class:`NodeOutputs`): ``/plan``
(``nav_msgs/Path``), ``/cognitive_map`` (``visualization_msgs/MarkerArray``), the pose
estimate on ``/clomp/estimate`` (``nav_msgs/Odometry``) and the supervisor's state on
``/clomp/state`` (``std_msgs/String``, latched) on every change. Goals
(:class:`GoalInbox`): ``geometry_msgs/PoseStamped`` on ``/goal_pose`` in the odom frame
(nav2's convention); a new goal preempts the one being driven to.

:func:`supervise` ticks the supervisor every ``tick`` s and also as soon as a scan
arrives (not sooner than a tenth of a tick after the last step): the command a scan causes
goes out without waiting for the next tick.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Any

from clomp.formal.geometry import relative
from clomp.formal.model import Pose
from clomp.planner.configurator import Configurator
from clomp.planner.robot_model import RobotModel
from clomp.runtime.records.runlog import plan_fields
from clomp.runtime.ros.convert import make_odometry, make_path, map_markers, odometry_pose
from clomp.runtime.ros.robot import RosRobot, RosRobotConfig

__all__ = ["PARAMETERS", "ROBOT_PARAMETERS", "GoalInbox", "NodeOutputs", "PublishingLog", "configure", "supervise"]

#: ROS parameter -> RobotModel field (defaults: the paper's robot)
ROBOT_PARAMETERS: dict[str, str] = {
    "body_length": "length",
    "body_width": "width",
    "front_offset": "front_offset",
    "wheel_base": "wheel_base",
    "max_speed": "max_speed",
    "straight_speed": "straight_speed",
    "turn_rate": "turn_rate",
    "goal_tolerance": "goal_tolerance",
    "sensor_range": "sensor_range",
}


def _defaults() -> dict[str, Any]:
    m = RobotModel()
    robot = {p: float(getattr(m, f)) for p, f in ROBOT_PARAMETERS.items()}
    c = RosRobotConfig()
    return {**robot, "horizon": 1.2, "max_states": 50, "step_length": 0.27,
            "lidar_offset": [0.0, 0.0, 0.0], "sensor_timeout": c.sensor_timeout, "startup_timeout": c.startup_timeout,
            "odom_frame": c.odom_frame, "base_frame": c.base_frame, "use_odom": True, "use_imu": True, "moving": False,
            "calibration": ""}


#: every parameter of the node and its default
PARAMETERS: dict[str, Any] = _defaults()


def configure(node: Any, dry_run: bool = False) -> tuple[Configurator, RosRobotConfig, dict[str, Any]]:
    """Declare the node's parameters (their values: the defaults, or overrides given to the
    node) and build the planner and the robot's configuration from them; ValueError naming
    the parameter that is wrong.

    >>> from types import SimpleNamespace as M
    >>> node = M(declare_parameter=lambda name, value: M(value=value))
    >>> conf, rc, values = configure(node)
    >>> conf.robot == RobotModel(), rc.sensor_timeout, values["max_states"]
    (True, 0.5, 50)
    """
    values: dict[str, Any] = {}
    for name, default in PARAMETERS.items():
        values[name] = node.declare_parameter(name, default).value
    try:
        step = float(values["step_length"])
        model = RobotModel().with_(**{f: float(values[p]) for p, f in ROBOT_PARAMETERS.items()},
                                   step_length=None if step == 0 else step)
        conf = Configurator(model, max_states=int(values["max_states"]), horizon=float(values["horizon"]),
                            recovery=bool(values["moving"]))  # a world that moves: WAIT and REVERSE (issue #42)
        offset = tuple(float(v) for v in values["lidar_offset"])
        if len(offset) != 3:
            raise ValueError(f"lidar_offset: expected [x, y, theta], got {values['lidar_offset']!r}")
        rc = RosRobotConfig(odom_frame=str(values["odom_frame"]), base_frame=str(values["base_frame"]),
                            lidar_offset=(offset[0], offset[1], offset[2]),
                            use_odom=bool(values["use_odom"]) and not dry_run, use_imu=bool(values["use_imu"]),
                            sensor_timeout=float(values["sensor_timeout"]),
                            startup_timeout=float(values["startup_timeout"]), dry_run=dry_run)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"node parameters: {exc}") from None
    return conf, rc, values


class NodeOutputs:
    """The node's publishers: plan, cognitive map, estimate, state (see the module)."""

    def __init__(self, node: Any, frame: str, base_frame: str) -> None:
        from nav_msgs.msg import Odometry, Path
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from std_msgs.msg import String
        from visualization_msgs.msg import MarkerArray

        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node, self.frame, self.base_frame = node, frame, base_frame
        self.path = node.create_publisher(Path, "/plan", latched)
        self.markers = node.create_publisher(MarkerArray, "/cognitive_map", latched)
        self.estimate = node.create_publisher(Odometry, "/clomp/estimate", 10)
        self.state = node.create_publisher(String, "/clomp/state", QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self._state: str | None = None
        self._plans = 0
        self.plans_published = 0

    def _stamp(self) -> Any:
        return self.node.get_clock().now().to_msg()

    def publish_state(self, state: str) -> None:
        """Publish ``state`` if it changed."""
        from std_msgs.msg import String

        if state != self._state:
            self._state = state
            self.state.publish(String(data=state))

    def publish_path(self, path: list[list[float]]) -> None:
        """A plan's path ``[[x, y, theta], …]`` (odom frame) on ``/plan``."""
        self.path.publish(make_path(path, self._stamp(), self.frame))
        self.plans_published += 1

    def publish(self, sup: Any) -> None:
        """After a supervisor's step: its state, its estimate, and its newest plan and map."""
        self.publish_state(sup.state.value)
        stamp = self._stamp()
        self.estimate.publish(make_odometry(sup.pose, stamp, self.frame, self.base_frame))
        if len(sup.plans) != self._plans:
            self._plans = len(sup.plans)
            if sup.plans:
                rec = sup.plans[-1]
                self.publish_path(plan_fields(rec.result, rec.origin)["path"])
                self.markers.publish(map_markers(rec.result, rec.origin, stamp, self.frame))

    def reset(self) -> None:
        """A new supervisor: its plans count from 0."""
        self._plans = 0


class PublishingLog:
    """A run log that also publishes each ``plan`` record's path on ``/plan`` (the dry run's plans)."""

    def __init__(self, log: Any, outputs: NodeOutputs) -> None:
        self._log, self._outputs = log, outputs

    def write(self, event: str, **fields: Any) -> None:
        self._log.write(event, **fields)
        if event == "plan" and "path" in fields:
            self._outputs.publish_path(fields["path"])


class GoalInbox:
    """Goals on ``/goal_pose`` (``geometry_msgs/PoseStamped`` in ``frame``): the newest one not taken."""

    def __init__(self, node: Any, frame: str, topic: str = "/goal_pose") -> None:
        from geometry_msgs.msg import PoseStamped

        self.node, self.frame = node, frame
        self._cond = threading.Condition()
        self._goal: Pose | None = None
        self.received = 0
        self._sub = node.create_subscription(PoseStamped, topic, self._on_goal, 10)

    def _on_goal(self, msg: Any) -> None:
        from types import SimpleNamespace

        try:
            pose = odometry_pose(SimpleNamespace(header=msg.header, pose=SimpleNamespace(pose=msg.pose)), self.frame)
        except ValueError as exc:
            self.node.get_logger().error(f"goal ignored: {str(exc).replace('Odometry', 'goal')}")
            return
        with self._cond:
            self._goal = pose
            self.received += 1
            self._cond.notify_all()
        self.node.get_logger().info(f"new goal ({pose.x:.3f}, {pose.y:.3f}) in {self.frame}")

    def take(self, timeout: float = 0.0) -> Pose | None:
        """The newest goal not taken yet, waiting up to ``timeout`` s for one."""
        with self._cond:
            if self._goal is None and timeout > 0:
                self._cond.wait(timeout)
            goal, self._goal = self._goal, None
            return goal


def supervise(robot: RosRobot, make: Callable[[tuple[float, float]], Any], goal: tuple[float, float] | None,
              outputs: NodeOutputs, inbox: GoalInbox, hold: Callable[[Any], None],
              max_time: float | None = None) -> Any:
    """Drive to ``goal`` (robot frame now; None: wait for one on ``/goal_pose``) with the
    supervisors ``make(goal)`` builds, a new goal preempting the current one; the last
    supervisor's report. The wheels are stopped on every way out."""
    t_end = math.inf if max_time is None else time.monotonic() + max_time
    robot.wait_ready()
    outputs.publish_state("IDLE" if goal is not None else "WAITING_FOR_GOAL")
    sup = None
    try:
        while goal is None:
            target = inbox.take(timeout=0.1)
            robot.odometry()  # raises RobotFault once a sensor fell silent
            if target is not None:
                goal = _robot_frame(robot, target)
            elif time.monotonic() >= t_end:
                return None
        while True:
            sup = make(goal)
            hold(sup)
            outputs.reset()
            target = _loop(sup, robot, outputs, inbox, t_end)
            if target is None:
                return sup.report()
            goal = _robot_frame(robot, target)
    finally:
        try:
            robot.stop()
        except Exception:  # noqa: BLE001 - the supervisor recorded it when it could not stop
            pass


def _robot_frame(robot: RosRobot, goal: Pose) -> tuple[float, float]:
    here = robot.odometry() or Pose(0.0, 0.0, 0.0)
    g = relative(here, goal)
    return g.x, g.y


def _loop(sup: Any, robot: RosRobot, outputs: NodeOutputs, inbox: GoalInbox, t_end: float) -> Pose | None:
    """Tick ``sup`` to its end (None) or until a new goal comes (the goal)."""
    tick = sup.model.tick
    while not sup.terminal:
        t = time.monotonic()
        if t >= t_end:
            sup.abort("time limit reached")
            break
        target = inbox.take()
        if target is not None:
            if robot.config.use_odom:
                sup.abort("preempted by a new goal on /goal_pose")
                outputs.publish(sup)
                return target
            robot.node.get_logger().error("goal on /goal_pose ignored: goals in the odom frame need /odom")
        sup.step()
        outputs.publish(sup)
        if sup.terminal:
            break
        time.sleep(max(0.0, t + tick / 10 - time.monotonic()))
        robot.wait_scan(t + tick)
    outputs.publish(sup)
    return None
