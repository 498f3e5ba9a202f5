"""``clomp ros node`` and ``clomp ros sim`` with real rclpy, over DDS on this host only.

The module fixture sets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, FASTDDS_BUILTIN_TRANSPORTS=SHM
and a private ROS_DOMAIN_ID before any rclpy context exists. A test base (:class:`Base`)
plays the robot: it publishes /scan and /odom (its odometry integrates the /cmd_vel it
receives), and records every /cmd_vel. Every wait is for an event, bounded.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rclpy", reason="ROS 2 (rclpy) is not installed: pip install 'clomp[ros2]'")

from clomp.formal.geometry import dead_reckon  # noqa: E402
from clomp.formal.model import Pose  # noqa: E402
from clomp.runtime.clock import ManualClock  # noqa: E402
from clomp.runtime.ros.convert import make_odometry, yaw_quaternion  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
BAG = REPO.parent / "shared" / "data" / "bags" / "laser-scan-matcher-demo.bag"
KEYS = ("ROS_AUTOMATIC_DISCOVERY_RANGE", "FASTDDS_BUILTIN_TRANSPORTS", "ROS_DOMAIN_ID")


@pytest.fixture(scope="module", autouse=True)
def localhost_dds() -> Any:
    """DDS on this host only, in a domain of this test session (set before rclpy.init)."""
    from clomp.runtime.ros.session import localhost_only

    old = {k: os.environ.get(k) for k in KEYS}
    localhost_only(20 + os.getpid() % 70)
    yield os.environ["ROS_DOMAIN_ID"]
    for k, v in old.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def wait_for(what: Any, timeout: float, why: str) -> None:
    end = time.monotonic() + timeout
    while not what():
        if time.monotonic() > end:
            pytest.fail(f"timed out after {timeout:g} s waiting for {why}")
        time.sleep(0.02)


class Base:
    """A kinematic robot base on ROS topics (its own context): /scan from ``ranges()`` at
    ``rate`` Hz, /odom from the /cmd_vel it integrates, every /cmd_vel recorded."""

    def __init__(self, start: Pose | None = None, rate: float = 10.0, odom: bool = True) -> None:
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import LaserScan

        from clomp.runtime.ros.session import RosSession

        self.session = RosSession("test_base")
        node = self.session.node
        self.pose, self.twist = start or Pose(0.0, 0.0, 0.0), (0.0, 0.0)
        self.cmds: list[tuple[float, float, float]] = []  # (monotonic, v, w)
        self.scanning, self.odometry, self.nan_odometry = True, odom, False
        self.scan = self.open_scan
        self.lock = threading.Lock()
        self.scan_pub = node.create_publisher(LaserScan, "/scan", qos_profile_sensor_data)
        self.odom_pub = node.create_publisher(Odometry, "/odom", 10)
        node.create_subscription(Twist, "/cmd_vel", self._cmd, 10)
        self._t = time.monotonic()
        node.create_timer(1.0 / rate, self._tick)

    @staticmethod
    def open_scan(msg: Any) -> None:
        """A 360° scan that sees nothing."""
        msg.angle_min, msg.angle_increment = -math.pi, 2 * math.pi / 360
        msg.angle_max = msg.angle_min + 359 * msg.angle_increment
        msg.range_min, msg.range_max = 0.05, 12.0
        msg.ranges = [math.inf] * 360

    def _cmd(self, msg: Any) -> None:
        with self.lock:
            self.twist = (msg.linear.x, msg.angular.z)
            self.cmds.append((time.monotonic(), msg.linear.x, msg.angular.z))

    def _tick(self) -> None:
        from sensor_msgs.msg import LaserScan

        now = time.monotonic()
        with self.lock:
            v, w = self.twist
            self.pose = dead_reckon(self.pose, v - w * 0.075, v + w * 0.075, 0.15, now - self._t)
            self._t = now
        stamp = self.session.node.get_clock().now().to_msg()
        if self.odometry:
            odom = make_odometry(self.pose, stamp, "odom", "base_link")
            if self.nan_odometry:
                odom.pose.pose.position.x = math.nan
            self.odom_pub.publish(odom)
        if self.scanning:
            msg = LaserScan()
            msg.header.stamp, msg.header.frame_id = stamp, "laser"
            self.scan(msg)
            self.scan_pub.publish(msg)

    def moving(self) -> bool:
        with self.lock:
            return any(v != 0.0 or w != 0.0 for _, v, w in self.cmds)

    def last_cmd(self) -> tuple[float, float] | None:
        with self.lock:
            return (self.cmds[-1][1], self.cmds[-1][2]) if self.cmds else None

    def close(self) -> None:
        self.session.close()


class NodeThread:
    """``clomp ros node ARGS`` run in a thread of this process; its exit status in ``code``."""

    def __init__(self, *args: str) -> None:
        from clomp.runtime.cli import main

        self.code: int | None = None
        self.thread = threading.Thread(target=lambda: setattr(self, "code", main(["ros", "node", *args])), daemon=True)
        self.thread.start()

    def join(self, timeout: float) -> int:
        self.thread.join(timeout)
        assert not self.thread.is_alive(), f"clomp ros node still running after {timeout:g} s"
        assert self.code is not None
        return self.code


def records(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.fixture
def base() -> Any:
    b = Base()
    yield b
    b.close()


# -- the whole loop ----------------------------------------------------------------------------
def test_node_and_sim_reach_the_goal(tmp_path: Path) -> None:
    from clomp.planner.noise import NoiseTerms
    from clomp.runtime.cli.ros import run_loop

    # doorway: walls the scans can match. The node is told the sim's calibration (``paper``: error
    # sources the filter models, so no shared match floor), as a user tells theirs: its bound is
    # sized to the drive, not the worst case's. Whether the settled bound at the goal vouches for
    # 0.1 m still depends on how many revolutions the node matched in real time, so what holds at
    # any load is asserted: the node was told, the robot truly reaches the goal, and it says
    # GOAL_REACHED (exit 0) only when it is truly there, GOAL_UNCONFIRMED (exit 1) with the
    # distance and its bound otherwise. Measured (session 14, load 7.7-9.3 on 2 cores): told, 3 of 3
    # runs exit 0 with bounds of 0.009-0.010 m, truly 0.015-0.046 m off; told nothing, 1 of 3
    # (bounds 0.046, 0.141, 0.133 m), truly 0.004-0.025 m off
    r = run_loop("doorway", "paper", 0, max_time=90, log=tmp_path / "run.jsonl", told=True)
    log = records(tmp_path / "run.jsonl")
    why = [x for x in log if x["event"] in ("fault", "stop", "ros")]  # what the node said, when it fails
    assert log[0]["event"] == "run" and log[0]["calibration"] == NoiseTerms.preset("paper").to_dict(), log[0]
    assert r["told"] and r["goal_distance"] < 0.1, (r, why)
    assert r["collisions"] == 0
    stop = log[-1]
    assert stop["event"] == "stop", (r, why)
    assert (r["exit"], stop["status"]) in ((0, "GOAL_REACHED"), (1, "GOAL_UNCONFIRMED")), (r, why)
    if r["exit"] == 1:
        assert "bound" in stop["reason"] and math.isfinite(stop["bound"]), stop
    from clomp.runtime.cli import main

    assert main(["replay", str(tmp_path / "run.jsonl")]) == 0  # the run log is clomp run's
    pytest.importorskip("mcap")
    assert main(["convert", str(tmp_path / "run.jsonl"), "-o", str(tmp_path / "run.mcap")]) == 0


# -- fail-safe -------------------------------------------------------------------------------------
def test_a_silent_scan_stops_the_robot(base: Base, tmp_path: Path) -> None:
    node = NodeThread("--goal", "2,0", "--max-time", "60", "--log", str(tmp_path / "run.jsonl"))
    wait_for(base.moving, 30, "the node to drive")
    base.scanning = False
    code = node.join(15)
    assert code == 3
    assert base.last_cmd() == (0.0, 0.0)
    faults = [r["reason"] for r in records(tmp_path / "run.jsonl") if r["event"] == "fault"]
    assert any("scan silent" in f for f in faults), faults


def test_a_nan_odometry_pose_is_a_sensor_fault(base: Base, tmp_path: Path) -> None:
    node = NodeThread("--goal", "2,0", "--max-time", "60", "--log", str(tmp_path / "run.jsonl"))
    wait_for(base.moving, 30, "the node to drive")
    base.nan_odometry = True
    assert node.join(15) == 3
    assert base.last_cmd() == (0.0, 0.0)
    faults = [r["reason"] for r in records(tmp_path / "run.jsonl") if r["event"] == "fault"]
    assert any("/odom carries garbage" in f and "not finite" in f for f in faults), faults


def test_ctrl_c_publishes_a_zero_twist_before_exit(base: Base, tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "clomp", "ros", "node", "--goal", "2,0", "--max-time", "120",
                             "--log", str(tmp_path / "run.jsonl")], env=env, cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(base.moving, 60, "the node to drive")
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=20)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert base.last_cmd() == (0.0, 0.0)
    assert "interrupted by SIGINT" in err
    assert records(tmp_path / "run.jsonl")[-1]["status"] == "HALTED"


# -- goals -----------------------------------------------------------------------------------------
def test_a_goal_on_goal_pose_in_the_odom_frame(tmp_path: Path) -> None:
    from geometry_msgs.msg import PoseStamped
    from std_msgs.msg import String
    from rclpy.qos import DurabilityPolicy, QoSProfile

    base = Base(start=Pose(0.3, -0.2, 0.5))
    try:
        states: list[str] = []
        node_ = base.session.node
        node_.create_subscription(String, "/clomp/state", lambda m: states.append(m.data),
                                  QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        goal_pub = node_.create_publisher(PoseStamped, "/goal_pose", 10)
        from nav_msgs.msg import Odometry
        from visualization_msgs.msg import Marker, MarkerArray

        maps: list[Any] = []
        estimates: list[Any] = []
        node_.create_subscription(MarkerArray, "/cognitive_map", maps.append,
                                  QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        node_.create_subscription(Odometry, "/clomp/estimate", estimates.append, 10)
        node = NodeThread("--max-time", "60", "--log", str(tmp_path / "run.jsonl"))
        wait_for(lambda: "WAITING_FOR_GOAL" in states, 30, "the node to wait for a goal")
        goal = PoseStamped()
        goal.header.frame_id = "odom"
        goal.pose.position.x, goal.pose.position.y = 0.9, 0.1
        goal.pose.orientation.z, goal.pose.orientation.w = yaw_quaternion(0.0)[2:]
        goal_pub.publish(goal)
        code = node.join(60)  # the test base shows no surface: the estimate may not vouch for the goal
        assert code in (0, 1)
        assert math.hypot(base.pose.x - 0.9, base.pose.y - 0.1) < 0.1, base.pose
        assert base.last_cmd() == (0.0, 0.0)
        assert "EXECUTING" in states and states[-1] == ("GOAL_REACHED" if code == 0 else "GOAL_UNCONFIRMED")
        wait_for(lambda: bool(maps), 10, "a cognitive map")
        markers = maps[-1].markers
        assert markers[0].action == Marker.DELETEALL
        plan = [m for m in markers if m.ns == "plan"]
        labels = [m.text for m in markers if m.ns == "labels"]
        assert len(plan) == 1 and plan[0].type == Marker.LINE_STRIP and len(plan[0].points) >= 2
        assert labels and all(t.startswith("q") for t in labels) and any("(goal)" in t for t in labels)
        assert plan[0].header.frame_id == "odom" and estimates and estimates[-1].header.frame_id == "odom"
        end = estimates[-1].pose.pose.position
        assert math.hypot(end.x - base.pose.x, end.y - base.pose.y) < 0.05  # the estimate, in the odom frame
    finally:
        base.close()


# -- scans of other LiDARs, malformed input ----------------------------------------------------------------
def _hokuyo(msg: Any, reverse: bool = False) -> None:
    """A 240° field of view in 681 beams (the bag's Hokuyo), a wall 0.5 m ahead from y=-0.2 to 0.3."""
    n, half = 681, math.radians(120)
    inc = 2 * half / (n - 1)
    a = -half + inc * np.arange(n)
    with np.errstate(divide="ignore"):
        r = np.where(np.abs(0.5 * np.tan(a)) <= 0.3, 0.5 / np.cos(a), np.inf)
    r = np.where((0.5 * np.tan(a) >= -0.2) & (np.cos(a) > 0), r, np.inf)
    if reverse:  # clockwise: from +120° down
        a, r, inc = a[::-1], r[::-1], -inc
    msg.angle_min, msg.angle_max, msg.angle_increment = float(a[0]), float(a[-1]), float(inc)
    msg.range_min, msg.range_max = 0.02, 5.6
    msg.ranges = [float(v) for v in r]


@pytest.mark.parametrize("reverse", [False, True], ids=["counter-clockwise", "clockwise"])
def test_a_240_degree_681_beam_scan_is_planned_on(base: Base, tmp_path: Path, reverse: bool) -> None:
    from clomp.planner import Configurator

    base.scan = lambda msg: _hokuyo(msg, reverse)
    node = NodeThread("--goal", "1,0", "--dry-run", "--max-time", "4", "--log", str(tmp_path / "run.jsonl"))
    assert node.join(30) == 0
    log = records(tmp_path / "run.jsonl")
    scans = [np.asarray(r["points"]) for r in log if r["event"] == "scan"]
    plans = [r for r in log if r["event"] == "plan"]
    assert scans and len(plans) == len(scans)
    pts = scans[-1]
    a = np.linspace(-math.radians(120), math.radians(120), 681)
    y = 0.5 * np.tan(a)
    seen = (np.cos(a) > 0) & (y >= -0.2) & (y <= 0.3)
    wall = np.c_[np.full(seen.sum(), 0.5), y[seen]]  # where each beam meets the wall, by geometry
    order = np.argsort(pts[:, 1])
    assert pts.shape == wall.shape and np.allclose(pts[order], wall, atol=1e-5)
    expected = Configurator().plan(wall, (1.0, 0.0))
    assert plans[-1]["tasks"] == [s.task.value for s in expected.steps]
    assert plans[-1]["reached_goal"] == expected.reached_goal
    assert base.cmds == []  # a dry run commands nothing


def test_malformed_input_is_logged_and_dropped_not_a_crash(base: Base, tmp_path: Path) -> None:
    from sensor_msgs.msg import LaserScan

    node = NodeThread("--goal", "1,0", "--max-time", "60", "--log", str(tmp_path / "run.jsonl"))
    wait_for(base.moving, 30, "the node to drive")
    stamp = base.session.node.get_clock().now().to_msg()

    def bad(edit: Any) -> None:
        msg = LaserScan()
        msg.header.stamp = stamp
        Base.open_scan(msg)
        edit(msg)
        base.scan_pub.publish(msg)

    bad(lambda m: setattr(m, "ranges", [math.nan] * 360))  # NaN readings: no return, the scan is used
    bad(lambda m: setattr(m, "angle_increment", 0.0))
    bad(lambda m: setattr(m, "ranges", [1.0] * 100))
    odom = make_odometry(base.pose, stamp, "map", "base_link")
    base.odom_pub.publish(odom)
    assert node.join(60) in (0, 1)  # and it still ends at the goal (vouched for or not: the base shows no surface)
    errors = [r.get("error") or r["warning"] for r in records(tmp_path / "run.jsonl") if r["event"] == "ros"]
    text = "\n".join(errors)
    assert "angle_increment is 0" in text
    assert "has 100 ranges but its angles" in text and "make 360" in text
    assert "Odometry in frame 'map', expected 'odom'" in text
    assert "NaN" in text


# -- the recorded bag -----------------------------------------------------------------------------------
def test_the_recorded_bag_played_into_a_dry_run(tmp_path: Path) -> None:
    """Every scan of the bag (ROS 1, a Hokuyo) played on /scan: a plan for each, nothing commanded."""
    if not BAG.is_file():
        pytest.skip(f"recorded bag not found at {BAG}")
    pytest.importorskip("rosbags")
    from nav_msgs.msg import Path as PathMsg
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from sensor_msgs.msg import LaserScan

    from clomp.runtime.records.bags import LaserScanTopic

    base = Base()
    base.scanning = base.odometry = False
    plans: list[Any] = []
    base.session.node.create_subscription(PathMsg, "/plan", plans.append,
                                          QoSProfile(depth=50, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    try:
        with LaserScanTopic(BAG) as topic:
            scans = list(topic)[:40]
        node = NodeThread("--goal", "1,0", "--dry-run", "--log", str(tmp_path / "run.jsonl"))
        wait_for(lambda: base.scan_pub.get_subscription_count() > 0 and base.session.node.count_publishers("/plan") > 0,
                 30, "the node to subscribe to /scan and offer /plan")
        def laserscan(s: Any) -> Any:
            msg = LaserScan()
            msg.header.stamp = base.session.node.get_clock().now().to_msg()
            msg.header.frame_id = s.frame_id
            msg.angle_min, msg.angle_increment = s.angle_min, s.angle_increment
            msg.angle_max = s.angle_min + s.angle_increment * (len(s.ranges) - 1)
            msg.range_min, msg.range_max = s.range_min, s.range_max
            msg.ranges = s.ranges.astype(float).tolist()
            return msg

        # the first scan until the node has it (a best-effort message sent while DDS still
        # matches the two ends is lost), then every scan after the plan of the one before
        end = time.monotonic() + 30
        while not plans and time.monotonic() < end:
            base.scan_pub.publish(laserscan(scans[0]))
            time.sleep(0.3)
        for k, s in enumerate(scans[1:]):
            seen = len(plans)
            base.scan_pub.publish(laserscan(s))
            wait_for(lambda seen=seen: len(plans) > seen, 20, f"the plan of scan {k + 1}")
        assert node.join(20) == 3  # the scans stopped with the bag: a silent sensor
        log = records(tmp_path / "run.jsonl")
        n_scans = sum(r["event"] == "scan" for r in log)
        assert sum(r["event"] == "plan" for r in log) == n_scans == len(plans) >= len(scans)
        assert not any(r["event"] == "plan" and "error" in r for r in log)
        assert base.cmds == []
    finally:
        base.close()


def _manual_monotonic(monkeypatch: pytest.MonkeyPatch, module: Any) -> ManualClock:
    """``module``'s ``time.monotonic`` on a :class:`ManualClock` that stands still unless the
    test moves it: a window the test means to land in (a round on time, a command still fresh)
    cannot be missed because the machine held this thread up between two calls."""
    import types

    clock = ManualClock(1000.0)
    fake = types.SimpleNamespace(**{k: getattr(time, k) for k in dir(time) if not k.startswith("_")})
    fake.monotonic = clock.now
    monkeypatch.setattr(module, "time", fake)
    return clock


def test_the_watchdog_does_not_trip_in_a_round_that_came_late(monkeypatch: pytest.MonkeyPatch) -> None:
    """A watchdog round held up (the control thread had the GIL, the machine was busy) finds
    the last scan old while newer ones wait in the executor's queue: it must not trip then,
    only when it runs on time and the scan is still old."""
    import rclpy
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    import clomp.runtime.ros.robot as robot_module
    from clomp.runtime.ros.robot import RosRobot, RosRobotConfig

    clock = _manual_monotonic(monkeypatch, robot_module)
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = Node("watchdog_test", context=context)  # not spun: the test calls the watchdog itself
        robot = RosRobot(node, 0.15, RosRobotConfig(use_odom=False))
        robot._armed = True
        now = clock.now()
        robot._scan_at = now - 1.0
        robot._watched = now - 1.0  # the last round was a second ago: this one is late
        robot._watch()
        assert robot.fault is None
        robot._watch()  # on time now, and still no scan
        assert robot.fault is not None and "scan silent" in robot.fault
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


@pytest.fixture
def idle_node() -> Any:
    """A node that is not spun: the test calls its callbacks itself."""
    import rclpy
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = Node("idle_test", context=context)
    yield node
    node.destroy_node()
    rclpy.shutdown(context=context)


def test_odometry_time_going_backwards_is_a_sensor_fault(idle_node: Any) -> None:
    from builtin_interfaces.msg import Time

    from clomp.runtime.ros.robot import RosRobot, RosRobotConfig

    robot = RosRobot(idle_node, 0.15, RosRobotConfig())
    robot._on_odom(make_odometry(Pose(0.0, 0.0, 0.0), Time(sec=100, nanosec=0), "odom", "base_link"))
    assert robot.fault is None and robot.odometry() == Pose(0.0, 0.0, 0.0)
    robot._on_odom(make_odometry(Pose(0.01, 0.0, 0.0), Time(sec=99, nanosec=0), "odom", "base_link"))
    assert robot.fault is not None and "odom time went backwards" in robot.fault


def test_the_sim_stops_the_wheels_when_commands_go_stale(idle_node: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    from geometry_msgs.msg import Twist

    from clomp.planner import load_scenario
    from clomp.runtime.backends.world import make_world_robot
    import clomp.runtime.ros.sim as sim_module
    from clomp.runtime.ros.sim import SimNode

    clock = _manual_monotonic(monkeypatch, sim_module)
    world = make_world_robot(load_scenario("open"), "ideal", seed=0)
    sim = SimNode(idle_node, world, 0.15, cmd_timeout=0.5)
    cmd = Twist()
    cmd.linear.x = 0.1
    sim._on_cmd(cmd)
    sim._step()
    assert world.commanded == (0.1, 0.1) and sim.stale_stops == 0
    sim._last_cmd = clock.now() - 0.6  # the last command is older than cmd_timeout
    sim._step()
    assert world.commanded == (0.0, 0.0) and sim.stale_stops == 1


def _bound_after_driving(node: Any, twist_covariance: list[float] | None, steps: int = 30) -> float:
    """The bound the supervisor vouches with (Sensing.position_bound at vouch_sigmas) after
    ``steps`` odometry messages of 1 cm forward each 0.1 s, through a RosRobot's /odom callback."""
    from builtin_interfaces.msg import Time

    from clomp.planner.robot_model import RobotModel
    from clomp.runtime.ros.robot import RosRobot, RosRobotConfig
    from clomp.runtime.supervision.config import SupervisorConfig
    from clomp.runtime.supervision.sensing import Sensing

    robot = RosRobot(node, 0.15, RosRobotConfig(use_imu=False))
    cfg = SupervisorConfig()
    sensing = Sensing(robot, RobotModel(), cfg)
    for i in range(steps + 1):
        stamp = Time(sec=100 + i // 10, nanosec=(i % 10) * 100_000_000)
        robot._on_odom(make_odometry(Pose(0.01 * i, 0.0, 0.0), stamp, "odom", "base_link", (0.1, 0.0),
                                     twist_covariance=twist_covariance))
        if i == 0:
            sensing.start(0.0)
        else:
            sensing.update_pose(0.1 * i, (0.1, 0.1))
    assert robot.fault is None
    bound = sensing.position_bound(cfg.vouch_sigmas)
    robot.close()
    assert bound is not None
    return bound


def test_a_large_odometry_covariance_widens_the_bound_the_supervisor_vouches_with(idle_node: Any) -> None:
    """A base that says its speed is good to 0.2 m/s only: the estimate may not vouch for
    better than that after 0.3 m; all zeros (unknown): the estimator's own noise."""
    own = _bound_after_driving(idle_node, None)
    assert _bound_after_driving(idle_node, [0.0] * 36) == own
    big = [0.0] * 36
    big[0], big[7], big[35] = 0.2**2, 0.2**2, 0.3**2
    wide = _bound_after_driving(idle_node, big)
    assert wide >= 2.45 * math.sqrt(30 * (0.2 * 0.1) ** 2) * 0.999
    assert wide > 3 * own


def test_ros_sim_writes_its_calibration_and_the_node_command_takes_it(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """``clomp ros sim --calibration-out FILE`` writes the world's terms (``harsh``: its note says
    the shared match floor stays on) and prints ``clomp ros node … --calibration FILE``."""
    from clomp.planner.noise import NoiseTerms
    from clomp.runtime.backends.calibration import load_calibration
    from clomp.runtime.cli import main

    out = tmp_path / "sim.json"
    assert main(["ros", "sim", "--scenario", "open", "--noise", "harsh", "--max-time", "0.2",
                 "--calibration-out", str(out)]) == 0
    run = [line for line in capsys.readouterr().out.splitlines() if line.startswith("run: ")]
    assert run and run[0].endswith(f"--calibration {out}"), run
    assert load_calibration(out) == NoiseTerms.preset("harsh")
    assert "shared match floor on" in json.loads(out.read_text())["note"]
