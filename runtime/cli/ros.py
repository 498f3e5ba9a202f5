"""``clomp ros``: the planner and supervisor as a ROS 2 node, and the execution world as one.

``clomp ros node`` is ``clomp run`` with ROS 2 topics for devices: it reads ``/scan``
(``sensor_msgs/LaserScan``), ``/odom`` (``nav_msgs/Odometry``) and ``/imu``
(``sensor_msgs/Imu``, optional), drives to ``--goal X,Y`` (robot frame at start) or to
goals on ``/goal_pose`` (``geometry_msgs/PoseStamped``, odom frame), publishes
``/cmd_vel``, ``/plan``, ``/cognitive_map``, ``/clomp/estimate`` and ``/clomp/state``,
and writes the run log of ``clomp run`` (``clomp replay`` and ``clomp convert`` read it).
The robot model and the planner's budget are ROS parameters (``-p NAME:=VALUE``; the
paper's robot by default). A zero Twist goes out on every way out, and when ``/scan`` or
``/odom`` falls silent (``--sensor-timeout``, default 0.5 s) or carries garbage. Exit
status as ``clomp run``. ``--dry-run`` plans on every scan (robot standing, goal where it
is) and commands nothing; it ends at ``--max-time``, on Ctrl-C or when the scans stop (3).

``clomp ros sim`` serves a scenario (or a layout of a family) of the execution world
with a noise preset and seed: ``/scan``, ``/odom``, ``/imu``, ``/ground_truth``, and it
drives by ``/cmd_vel``. Together: ``clomp ros sim --scenario overtaking &`` then
``clomp ros node --goal 1,0``. A world that moves (a moving family's layout, a scenario
with ``movers``) needs ``clomp ros node --moving`` (WAIT and REVERSE; the sim prints it).
ROS 2 needs ``pip install 'clomp[ros2]'``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any

from clomp.planner.noise import preset_names
from clomp.runtime.cli import EXIT_NOT_REACHED, CliError
from clomp.runtime.cli._signals import interrupts_raise
from clomp.runtime.cli._common import add_mover_options, scene_movers
from clomp.runtime.cli.plan import add_planner_options, parse_goal

__all__ = ["register", "make_supervisor", "parse_parameter", "run_loop"]


def register(sub: Any) -> None:
    """Add ``ros node`` and ``ros sim`` to the command line."""
    p = sub.add_parser("ros", help="the planner as a ROS 2 node (clomp ros node) and a simulated ROS 2 robot (clomp ros sim)",
                       description=__doc__)
    ros = p.add_subparsers(dest="ros_command", metavar="{node,sim}")
    p.set_defaults(func=lambda args: _usage(p))
    n = ros.add_parser("node", help="run the planner and supervisor on ROS 2 topics", description=__doc__)
    n.add_argument("--goal", help="goal X,Y in metres in the robot's frame at start (default: wait for /goal_pose)")
    n.add_argument("--dry-run", action="store_true", help="plan on every scan and publish the plans, command nothing")
    n.add_argument("--log", metavar="FILE", help="run log (JSON lines); default clomp-runs/run-<time>.jsonl")
    n.add_argument("--max-time", type=float, metavar="S", help="halt after S seconds")
    n.add_argument("--lidar-offset", metavar="X,Y,THETA", help="the LiDAR's pose on the base, m, m, rad (parameter lidar_offset)")
    n.add_argument("--sensor-timeout", type=float, metavar="S", help="stop when /scan or /odom is silent S s (default 0.5)")
    n.add_argument("--no-odom", action="store_true", help="no /odom: dead-reckon from the commanded speeds (parameter use_odom)")
    n.add_argument("--no-imu", action="store_true", help="ignore /imu (parameter use_imu)")
    n.add_argument("--calibration", metavar="FILE",
                   help="the drive's noise terms (JSON, or TOML for a .toml name; parameter calibration): the "
                        "estimator's wheel prior is sized to them instead of the worst case's (as clomp run's)")
    n.add_argument("-p", "--param", action="append", default=[], metavar="NAME:=VALUE",
                   help="set a node parameter, e.g. -p body_length:=0.3 (repeatable; see docs/run.md for the list)")
    add_planner_options(n)
    add_mover_options(n, movers=False)
    n.set_defaults(func=_node)
    s = ros.add_parser("sim", help="the execution world as a ROS 2 robot (/scan, /odom, /imu; drives by /cmd_vel)",
                       description=__doc__)
    where = s.add_mutually_exclusive_group()
    where.add_argument("--scenario", help="scenario name or file (default overtaking)")
    where.add_argument("--layout", metavar="FAMILY", help="a layout of this family (with --seed and --index)")
    s.add_argument("--index", type=int, default=0, help="which layout of the family (default 0)")
    s.add_argument("--noise", choices=preset_names(), default="paper",
                   help="noise preset (default paper; harsh carries the error sources the estimator does not model)")
    s.add_argument("--seed", type=int, default=0, help="seed of the noise (and the layout) (default 0)")
    s.add_argument("--scan-rate", type=float, default=5.5, metavar="HZ", help="LiDAR revolutions a second, 5.5-10 (default 5.5)")
    s.add_argument("--rays", type=int, default=360, help="LiDAR samples a revolution, 360-720 (default 360)")
    s.add_argument("--cmd-timeout", type=float, default=0.5, metavar="S", help="stop the wheels when /cmd_vel is S s old (default 0.5)")
    s.add_argument("--max-time", type=float, metavar="S", help="stop after S seconds (default: run until Ctrl-C)")
    s.add_argument("--calibration-out", metavar="FILE",
                   help="write the world's drive calibration (its noise terms; TOML for a .toml name, JSON otherwise) "
                        "and print the clomp ros node command with --calibration FILE")
    s.set_defaults(func=_sim)


def _usage(p: argparse.ArgumentParser) -> int:
    p.print_help()
    return 2


def _need_ros() -> None:
    from clomp.runtime.ros.session import ros_missing

    why = ros_missing()
    if why is not None:
        raise CliError(why)


def parse_parameter(text: str, defaults: dict[str, Any]) -> tuple[str, Any]:
    """``"body_length:=0.3"`` → ``("body_length", 0.3)``, typed as the parameter's default.

    >>> parse_parameter("max_states:=80", {"max_states": 50})
    ('max_states', 80)
    >>> parse_parameter("lidar_offset:=[0.1, 0, 3.14]", {"lidar_offset": [0.0, 0.0, 0.0]})
    ('lidar_offset', [0.1, 0.0, 3.14])
    """
    name, sep, raw = text.partition(":=")
    name, raw = name.strip(), raw.strip()
    if not sep or name not in defaults:
        raise CliError(f"-p {text!r}: expected NAME:=VALUE with NAME one of {', '.join(defaults)}")
    kind = defaults[name]
    try:
        if isinstance(kind, bool):
            if raw.lower() not in ("true", "false"):
                raise ValueError(raw)
            return name, raw.lower() == "true"
        if isinstance(kind, int):
            return name, int(raw)
        if isinstance(kind, float):
            return name, float(raw)
        if isinstance(kind, list):
            return name, [float(v) for v in raw.strip("[]").split(",")]
    except ValueError:
        raise CliError(f"-p {text!r}: {name} takes a value like {kind!r}") from None
    return name, raw


def _overrides(args: argparse.Namespace) -> dict[str, Any]:
    from clomp.runtime.records.bags import BagError, parse_offset
    from clomp.runtime.ros.node import PARAMETERS

    out: dict[str, Any] = {"horizon": float(args.horizon), "max_states": int(args.max_states),
                           "step_length": float(args.step_length)}
    if args.lidar_offset is not None:
        try:
            out["lidar_offset"] = list(parse_offset(args.lidar_offset))
        except BagError as exc:
            raise CliError(str(exc)) from None
    if args.sensor_timeout is not None:
        out["sensor_timeout"] = float(args.sensor_timeout)
    if args.no_odom:
        out["use_odom"] = False
    if args.no_imu:
        out["use_imu"] = False
    if args.moving:
        out["moving"] = True
    if args.calibration is not None:
        out["calibration"] = str(args.calibration)
    for text in args.param:
        name, value = parse_parameter(text, PARAMETERS)
        out[name] = value
    return out


def _node(args: argparse.Namespace) -> int:
    from clomp.runtime.clock import WallClock
    from clomp.runtime.cli.run import _dry_run, _SharedLog, open_runlog, operate
    from clomp.runtime.ros.node import GoalInbox, NodeOutputs, PublishingLog, configure, supervise
    from clomp.runtime.ros.robot import CalibratedRosRobot, RosRobot
    from clomp.runtime.ros.session import RosSession

    goal = parse_goal(args.goal) if args.goal else None
    if args.dry_run and goal is None:
        raise CliError("--dry-run needs --goal X,Y (the goal it plans to from every scan)")
    if args.max_time is not None and not (math.isfinite(args.max_time) and args.max_time > 0):
        raise CliError(f"--max-time must be a positive number of seconds, got {args.max_time}")
    overrides = _overrides(args)
    _told(str(overrides.get("calibration", "")))  # a bad file is a usage error before ROS starts
    _need_ros()
    session = RosSession("clomp", overrides)
    robots: list[RosRobot] = []
    try:
        try:
            conf, rc, values = configure(session.node, dry_run=args.dry_run)
        except ValueError as exc:
            raise CliError(str(exc)) from None
        told = _told(str(values.get("calibration", "")))  # the parameter, as the node took it
        runlog, path = open_runlog(args.log)
        log = _SharedLog(runlog, threading.Lock())  # the executor's thread writes faults and drops
        log.write("run", argv=sys.argv[1:], ros=True, dry_run=args.dry_run, goal=None if goal is None else list(goal),
                  max_time=args.max_time, config=rc.to_dict(), parameters=values,
                  monotonic=time.monotonic(), wall=time.time(), **({} if told is None else {"calibration": told.to_dict()}))
        outputs = NodeOutputs(session.node, rc.odom_frame, rc.base_frame)
        inbox = GoalInbox(session.node, rc.odom_frame)

        def open_robot() -> RosRobot:
            if told is None:
                robots.append(RosRobot(session.node, conf.robot.wheel_base, rc, log=log))
            else:
                robots.append(CalibratedRosRobot(session.node, conf.robot.wheel_base, rc, log=log, calibration=told))
            return robots[-1]

        def work(robot: RosRobot, hold: Any) -> Any:
            if args.dry_run:
                assert goal is not None
                robot.wait_ready()
                return _dry_run(robot, conf, goal, WallClock(), PublishingLog(log, outputs), args.max_time, path,
                                say=lambda text: print(f"clomp ros node: {text}", file=sys.stderr, flush=True))
            report = supervise(robot, lambda g: make_supervisor(robot, g, conf, log), goal, outputs, inbox, hold, args.max_time)
            if report is None:
                log.write("stop", reason="no goal came on /goal_pose", status="NOT_STARTED")
                print(f"clomp ros node: no goal came on /goal_pose in {args.max_time:g} s (log: {path})", file=sys.stderr)
                return EXIT_NOT_REACHED
            return report

        return operate(open_robot, work, runlog, log, path, name="ros node")
    finally:
        for robot in robots:
            session.flush(robot._cmd_pub)  # the last zero Twist reaches the base before the node goes
        session.close()


def _told(path: str) -> Any:
    """The noise terms the calibration file at ``path`` tells (a NoiseTerms), None for ``""``;
    CliError (exit 2) naming what is wrong with the file."""
    from clomp.runtime.backends.calibration import CalibrationError, load_calibration

    if not path:
        return None
    try:
        return load_calibration(path)
    except CalibrationError as exc:
        raise CliError(f"calibration: {exc}") from None


def make_supervisor(robot: Any, goal: tuple[float, float], conf: Any, log: Any = None) -> Any:
    """The supervisor of ``clomp run`` for the node (the one place the node builds one): in a
    world that moves (``conf`` plans with WAIT and REVERSE: the ``moving`` parameter) it runs them.

    >>> from clomp.planner import Configurator, load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> make_supervisor(SimRobot(load_scenario("open"), seed=0), (1.0, 0.0), Configurator()).state.value
    'IDLE'
    >>> make_supervisor(SimRobot(load_scenario("open"), seed=0), (1.0, 0.0), Configurator(recovery=True)).config.moving
    True
    """
    from clomp.runtime.supervision import Supervisor, SupervisorConfig

    return Supervisor(robot, goal, conf, log=log, config=SupervisorConfig(moving=conf.recovery))


def _scene(args: argparse.Namespace) -> tuple[Any, tuple[Any, ...]]:
    """The scene ``--layout`` or ``--scenario`` names and its movers (a moving family's, or the
    scenario file's ``movers``)."""
    from clomp.planner.scenarios import ScenarioError, load_scenario

    if args.layout is not None:
        from clomp.runtime.experiment.layouts import make_layout

        try:
            lay = make_layout(args.layout, args.seed, args.index)
        except ValueError as exc:
            raise CliError(str(exc)) from None
        return lay.scene, lay.movers
    try:
        scene = load_scenario(args.scenario or "overtaking")
    except (OSError, ScenarioError, ValueError) as exc:
        raise CliError(f"cannot load scenario {args.scenario!r}: {exc}") from None
    return scene, scene_movers(scene)


def _sim(args: argparse.Namespace) -> int:
    _need_ros()
    from clomp.planner.robot_model import RobotModel
    from clomp.runtime.backends.world import make_world_robot
    from clomp.runtime.ros.session import RosSession
    from clomp.runtime.ros.sim import SimNode

    scene, movers = _scene(args)
    model = RobotModel()
    try:
        world = make_world_robot(scene, args.noise, seed=args.seed, robot=model, scan_rate=args.scan_rate, rays=args.rays,
                                 movers=movers)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    if args.max_time is not None and not (math.isfinite(args.max_time) and args.max_time > 0):
        raise CliError(f"--max-time must be a positive number of seconds, got {args.max_time}")
    told = ""
    if args.calibration_out is not None:
        told = f" --calibration {_write_told(args.calibration_out, world, args.noise)}"
    with RosSession("clomp_sim") as session:
        try:
            sim = SimNode(session.node, world, model.wheel_base, cmd_timeout=args.cmd_timeout)
        except ValueError as exc:
            raise CliError(str(exc)) from None
        gx, gy = scene.goal_in_robot_frame()
        print(f"sim: {scene.name}, noise {args.noise}, seed {args.seed}", flush=True)
        print(f"run: clomp ros node --goal {gx:g},{gy:g}{' --moving' if movers else ''}{told}", flush=True)
        end = math.inf if args.max_time is None else time.monotonic() + args.max_time
        with interrupts_raise():
            try:
                while time.monotonic() < end and session.error is None and sim.error is None:
                    time.sleep(0.1)
            except KeyboardInterrupt:
                pass
            finally:
                sim.close()
            s = sim.summary()
            x, y, th = s["pose"]
            print(f"robot at ({x:.3f}, {y:.3f}, {math.degrees(th):.0f}°), {s['goal_distance']:.3f} m from the goal, "
                  f"{s['collisions']} collision(s)", flush=True)
    if session.error is not None or sim.error is not None:
        raise CliError(f"the sim failed: {session.error or sim.error}")
    return 0


def _write_told(path: str, world: Any, noise: str) -> str:
    """``--calibration-out FILE``: the world's noise terms as a calibration file; its path."""
    from clomp.planner.noise import NoiseTerms
    from clomp.runtime.backends.calibration import write_calibration
    from clomp.runtime.cli._common import output_path

    try:
        return str(write_calibration(output_path(path, "--calibration-out"), NoiseTerms(**world.calibration()),
                                     f"clomp ros sim --noise {noise}"))
    except OSError as exc:
        raise CliError(f"cannot write the calibration {path}: {exc}") from None


def run_loop(scenario: str, noise: str = "harsh", seed: int = 0, *, layout: bool = False, max_time: float = 120.0,
             log: str | os.PathLike[str] | None = None, node_args: tuple[str, ...] = (), scan_rate: float = 5.5,
             told: bool = False) -> dict[str, Any]:
    """The whole loop in this process: ``clomp ros sim``'s world on ``scenario`` (a layout of
    that family when ``layout``) and the ``clomp ros node`` command driving it to the
    scenario's goal over DDS, each with its own rclpy context; the exit status, how far the
    robot truly ended from the goal, its collisions (the tests, bench/ros_latency.py and
    docs/ros2.md use it). ``told``: the node is told the world's calibration (its noise terms,
    written beside the log as ``<log>.calibration.json`` and passed as ``--calibration``), as a
    user tells theirs; otherwise it is told nothing (the worst case's prior). Keep DDS on this
    host first (:func:`clomp.runtime.ros.session.localhost_only`)."""
    from clomp.planner.robot_model import RobotModel
    from clomp.planner.scenarios import load_scenario
    from clomp.runtime.backends.world import make_world_robot
    from clomp.runtime.cli import main
    from clomp.runtime.ros.session import RosSession
    from clomp.runtime.ros.sim import SimNode

    if layout:
        from clomp.runtime.experiment.layouts import make_layout

        lay = make_layout(scenario, seed)
        scene, movers = lay.scene, lay.movers
    else:
        scene = load_scenario(scenario)
        movers = scene_movers(scene)
    model = RobotModel()
    world = make_world_robot(scene, noise, seed=seed, robot=model, scan_rate=scan_rate, movers=movers)
    if movers and "--moving" not in node_args:  # a world that moves: the node plans and runs WAIT and REVERSE
        node_args = (*node_args, "--moving")
    gx, gy = scene.goal_in_robot_frame()
    log_path = Path(log) if log is not None else Path("clomp-runs") / f"ros-{scene.name}-{noise}-{seed}.jsonl"
    if told:
        from clomp.planner.noise import NoiseTerms
        from clomp.runtime.backends.calibration import write_calibration

        told_at = write_calibration(log_path.with_name(log_path.name + ".calibration.json"),
                                    NoiseTerms(**world.calibration()), f"clomp ros sim --noise {noise}")
        node_args = (*node_args, "--calibration", str(told_at))
    with RosSession("clomp_sim") as session:
        sim = SimNode(session.node, world, model.wheel_base)
        t0 = time.monotonic()
        code = main(["ros", "node", "--goal", f"{gx!r},{gy!r}", "--max-time", f"{max_time:g}", "--log", str(log_path),
                     *node_args])
        took = time.monotonic() - t0
        out = sim.summary()
        sim.close()
    return {"scenario": scene.name, "noise": noise, "seed": seed, "exit": code, "time_s": took, "log": str(log_path),
            "told": told, **out}
