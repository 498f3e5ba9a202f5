"""``clomp run``: run the supervisor on the hardware robot (RPLIDAR A1 + Pololu Maestro).

Every scan, plan, task change and motor command goes to a JSON-lines run log, flushed
record by record (``--log FILE``, default a timestamped file in ./clomp-runs/). The
wheels are stopped on every way out: the goal, a fault, the time limit, an exception,
Ctrl-C or SIGTERM. Exit status (the convention of every clomp command): 0 goal reached,
1 halted safely without reaching it (goal unreachable, --max-time, an unexpected
error), 2 bad input or usage (a port path that does not exist), 3 a device fault (a
device that does not answer, is unhealthy, falls silent, sends garbage or vanishes),
130 interrupted.

``--dry-run`` reads the LiDAR and plans on every scan — the robot standing still, the
goal where it is — logging and printing each plan, and sends no motion (the wheels are
held at neutral). It ends at ``--max-time`` (exit 0) or on Ctrl-C (130), or on a device fault (3).

``--imu PORT`` adds a BNO08x IMU in UART-RVC mode: the heading comes from it (its offset
measured while the robot stands), the distance from the wheels, the corrections from the
scans. An IMU that is unplugged, falls silent for 0.2 s, sends garbage or reports a turn
faster than the wheels can make is a device fault (exit 3, wheels stopped), never a silent
fallback to the wheels. Without ``--imu`` the run is as it was.

``--drive-delay S`` tells the estimator how long after a command the body follows it (the
drive's latency and half its ramp to speed; default 0.1 s, a hobby-servo drive's order:
:data:`~clomp.runtime.supervision.config.DRIVE_DELAY`): it dead-reckons on the commands that
late, with or without ``--imu`` (without one, the robot's own dead reckoning on the commands as
sent is then not used). Taken as 0 (``--drive-delay 0``: as before), every start's lead of the
commands over the body was learnt from the scans as a wrong wheel scale.

``--calibration FILE`` tells the estimator the drive's noise terms (a JSON object or a TOML
table of ``specs/noise_presets.json``'s terms, e.g. ``wheel_bias = 0.005``; a term left out is
0; :mod:`clomp.runtime.backends.calibration`): its wheel prior is sized to them instead of the
worst case's, so a well-calibrated robot truly at its goal can vouch for it. A told error
source the estimator does not model (a wandering bias, slip events, pushes) keeps its bound
wide. The told latency and ramp set the drive delay unless ``--drive-delay`` is given. A file
that is missing, not JSON/TOML, has an unknown key, or a value that is NaN or negative is a
usage error (exit 2). ``clomp emulate world --calibration-out FILE`` writes the emulated world's.

On a terminal, one status line updates while the robot runs (state, task, estimated
distance to the goal and its bound, LiDAR revolutions, LiDAR/IMU health); it is not drawn
into a pipe or a file.

Without hardware, ``clomp emulate world --scenario overtaking`` serves a simulated world
on three pseudo-terminals to point ``--lidar``, ``--motors`` and ``--imu`` at.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import sys
import threading
import time
from pathlib import Path
from collections.abc import Callable
from typing import Any

from clomp.planner.noise import preset_names
from clomp.runtime.cli._args import seed_arg
from clomp.runtime.cli.plan import add_planner_options, configurator_from_args, parse_goal
from clomp.runtime.cli import EXIT_DEVICE_FAULT, EXIT_INTERRUPTED, EXIT_NOT_REACHED, EXIT_OK, CliError
from clomp.runtime.cli._common import add_mover_options, load_scene, output_path, path_kind, scene_movers
from clomp.runtime.cli._emulate_faults import add_imu_fault_options, imu_fault_from, say_fault_came
from clomp.runtime.cli._signals import interrupts_raise
from clomp.runtime.cli._status import StatusLine

__all__ = ["register", "add_emulate_world", "default_log_path", "operate", "open_runlog", "ready_kernels"]

def _missing_path(spec: str | None) -> bool:
    """True for a port named by a path that does not exist (a typo, not a device fault)."""
    return bool(spec) and "://" not in str(spec) and not Path(str(spec)).exists()


def register(sub: Any) -> None:
    """Add ``run`` to the command line."""
    p = sub.add_parser("run", help="run the planner and supervisor on the robot (LiDAR + Maestro serial ports)",
                       description=__doc__)
    p.add_argument("--lidar", required=True, metavar="PORT", help="RPLIDAR A1 serial port (path or pyserial URL)")
    p.add_argument("--motors", metavar="PORT", help="Pololu Maestro serial port (optional with --dry-run)")
    p.add_argument("--imu", metavar="PORT",
                   help="BNO08x IMU (UART-RVC mode) serial port: the heading from it, fused with the wheels and scans")
    p.add_argument("--goal", required=True, help="goal X,Y in metres in the robot's frame at start (x forward, y left)")
    p.add_argument("--dry-run", action="store_true",
                   help="plan on every LiDAR scan and log the plans, but send no motion (wheels held stopped)")
    p.add_argument("--log", metavar="FILE", help="run log (JSON lines); default clomp-runs/run-<time>.jsonl")
    p.add_argument("--max-time", type=float, metavar="S", help="halt after S seconds")
    p.add_argument("--no-odometry", action="store_true",
                   help="the backend reports no odometry (the supervisor dead-reckons itself)")
    p.add_argument("--time-scale", type=float, default=1.0, metavar="K",
                   help="run the controller's clock K times faster than wall time; only for an emulated "
                        "world running at the same scale (default 1)")
    p.add_argument("--drive-delay", type=float, default=None, metavar="S",
                   help="how long after a command the wheels move the body (latency plus half the ramp to speed; "
                        "default 0.1 s); the estimator dead-reckons on the commands that late")
    p.add_argument("--calibration", metavar="FILE",
                   help="the drive's noise terms (JSON, or TOML for a .toml name): the estimator's wheel prior is "
                        "sized to them instead of the worst case's (clomp emulate world --calibration-out writes one)")
    d = p.add_argument_group("devices")
    d.add_argument("--lidar-baud", type=int, default=115200, help="LiDAR baud rate (default 115200)")
    d.add_argument("--lidar-motor", choices=("dtr", "none"), default="dtr",
                   help="how the LiDAR's motor is switched: DTR line (A1 USB adapter) or not at all")
    d.add_argument("--motor-baud", type=int, default=115200, help="Maestro baud rate (default 115200)")
    d.add_argument("--protocol", choices=("compact", "pololu"), default="compact", help="Maestro serial protocol")
    d.add_argument("--device-number", type=int, default=12, help="Maestro device number (Pololu protocol, default 12)")
    d.add_argument("--left-channel", type=int, default=0, help="left wheel servo channel (default 0)")
    d.add_argument("--right-channel", type=int, default=1, help="right wheel servo channel (default 1)")
    d.add_argument("--left-sign", type=int, choices=(1, -1), default=1, help="left servo direction (default 1)")
    d.add_argument("--right-sign", type=int, choices=(1, -1), default=-1, help="right servo direction (default -1: mirrored)")
    d.add_argument("--left-gain", type=float, default=1.0, help="left pulse span gain (default 1)")
    d.add_argument("--right-gain", type=float, default=1.0, help="right pulse span gain (default 1)")
    d.add_argument("--neutral-us", type=float, default=1500.0, help="stop pulse width in µs (default 1500)")
    d.add_argument("--span-us", type=float, default=100.0, help="pulse offset at full speed in µs (default 100)")
    d.add_argument("--multiple-targets", action="store_true", help="use Set Multiple Targets (Mini Maestro)")
    d.add_argument("--watchdog", type=float, default=0.3, metavar="S",
                   help="stop the wheels when no command came for S seconds (default 0.3; 0 disables)")
    add_planner_options(p)
    add_mover_options(p, movers=False)
    p.set_defaults(func=run)


def default_log_path(folder: str | Path = "clomp-runs") -> Path:
    """A new timestamped log file name in ``folder`` (not yet existing)."""
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    base = Path(folder) / f"run-{stamp}.jsonl"
    path, k = base, 1
    while path.exists():
        k += 1
        path = base.with_name(f"run-{stamp}-{k}.jsonl")
    return path


class _SharedLog:
    """One run log written from the control loop and the LiDAR reader thread.

    ``drop`` names events this writer leaves out: the supervisor's ``motor`` records are
    dropped because the hardware robot logs every command it actually sends.
    """

    def __init__(self, log: Any, lock: threading.Lock, drop: frozenset[str] = frozenset()) -> None:
        self._log, self._lock, self._drop = log, lock, drop

    def write(self, event: str, **fields: Any) -> None:
        if event in self._drop:
            return
        with self._lock:
            self._log.write(event, **fields)


def _config(args: argparse.Namespace) -> Any:
    from clomp.runtime.devices.maestro import WheelConfig
    from clomp.runtime.backends.hardware import HardwareConfig

    if args.motors is None and not args.dry_run:
        raise CliError("--motors PORT is required (or --dry-run to only read the LiDAR and plan)")
    if args.max_time is not None and not (math.isfinite(args.max_time) and args.max_time > 0):
        raise CliError(f"--max-time must be a positive number of seconds, got {args.max_time}")
    if not (math.isfinite(args.time_scale) and args.time_scale > 0):
        raise CliError(f"--time-scale must be a positive number, got {args.time_scale}")
    if not 0 <= args.device_number <= 127:
        raise CliError("--device-number must be in 0..127")
    if not (math.isfinite(args.watchdog) and args.watchdog >= 0):
        raise CliError("--watchdog must be a number of seconds >= 0")
    delay = _supervisor_delay(args)  # None: the told calibration's latency and ramp (> 0)
    try:
        return HardwareConfig(
            lidar_baudrate=args.lidar_baud,
            motor_control=args.lidar_motor,
            maestro_baudrate=args.motor_baud,
            protocol=args.protocol,
            device_number=args.device_number,
            left=WheelConfig(args.left_channel, args.left_sign, args.left_gain),
            right=WheelConfig(args.right_channel, args.right_sign, args.right_gain),
            neutral_us=args.neutral_us,
            span_us=args.span_us,
            multiple_targets=args.multiple_targets,
            watchdog_timeout=args.watchdog or None,
            dry_run=args.dry_run,
            # the estimator reckons the commands itself, late by the delay (the command odometry cannot know it)
            odometry=not args.no_odometry and (args.dry_run or delay == 0),
        )
    except ValueError as exc:
        raise CliError(str(exc)) from None


def _drive_delay(args: argparse.Namespace) -> float:
    """``--drive-delay`` (s), its default :data:`~clomp.runtime.supervision.config.DRIVE_DELAY`."""
    from clomp.runtime.supervision.config import DRIVE_DELAY

    delay = DRIVE_DELAY if getattr(args, "drive_delay", None) is None else float(args.drive_delay)
    if not (math.isfinite(delay) and 0 <= delay <= 2):
        raise CliError(f"--drive-delay must be a number of seconds in [0, 2], got {args.drive_delay}")
    return delay


def _told(args: argparse.Namespace) -> Any:
    """The noise terms ``--calibration FILE`` tells (a NoiseTerms), None without it; CliError
    (exit 2) for a file that cannot be used. Read once: the result is kept on ``args``."""
    from clomp.runtime.backends.calibration import CalibrationError, load_calibration

    path = getattr(args, "calibration", None)
    if path is None:
        return None
    cached = getattr(args, "_told_calibration", None)
    if cached is not None:
        return cached
    try:
        args._told_calibration = load_calibration(path)
    except CalibrationError as exc:
        raise CliError(f"--calibration: {exc}") from None
    return args._told_calibration


def _supervisor_delay(args: argparse.Namespace) -> float | None:
    """The drive delay the supervisor is told: ``--drive-delay``'s, or None (the told calibration's
    latency and ramp) when a calibration is given without it."""
    if _told(args) is not None and getattr(args, "drive_delay", None) is None:
        return None
    return _drive_delay(args)


def _say(text: str) -> None:
    print(f"clomp run: {text}", file=sys.stderr, flush=True)


def _wheels(robot: Any) -> str:
    if robot is None or robot.wheels_stopped:
        return "wheels stopped"
    return ("could NOT command the wheels to stop: the motor controller is unreachable "
            "(its serial timeout must stop them; check the robot)")


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp run``, its threads favoured by the scheduler where allowed
    (:mod:`clomp.runtime.realtime`: the stream watch and the control loop are real-time)."""
    from clomp.runtime.realtime import favoured

    with favoured() as scheduling:
        return _run(args, scheduling)


def _run(args: argparse.Namespace, scheduling: str) -> int:
    from clomp.runtime.backends.hardware import CalibratedHardwareRobot, HardwareRobot
    from clomp.runtime.supervision import Supervisor, SupervisorConfig

    goal = parse_goal(args.goal)
    told = _told(args)
    config = _config(args)
    conf = configurator_from_args(args)
    runlog, path = open_runlog(args.log)
    lock = threading.Lock()
    log = _SharedLog(runlog, lock)
    clock = _clock(args.time_scale)
    log.write("run", argv=sys.argv[1:], lidar=args.lidar, motors=args.motors, imu=args.imu, dry_run=args.dry_run,
              goal=list(goal), max_time=args.max_time, time_scale=args.time_scale,
              config=config.to_dict(), monotonic=time.monotonic(), wall=time.time(), scheduling=scheduling,
              **({"moving": True} if args.moving else {}), **({} if told is None else {"calibration": told.to_dict()}))

    def work(robot: Any, hold: Callable[[Any], None]) -> Any:
        if args.dry_run:
            _say("dry run: planning on every scan, the wheels are held stopped")
            return _dry_run(robot, conf, goal, clock, log, args.max_time, path)
        sup = Supervisor(robot, goal, conf, clock=clock, log=_SharedLog(runlog, lock, frozenset({"motor"})),
                         config=SupervisorConfig(moving=args.moving, drive_delay=_supervisor_delay(args)))
        hold(sup)
        with StatusLine(sup, robot):
            return sup.run(max_time=args.max_time)

    def open_robot() -> Any:
        options: dict[str, Any] = {"model": conf.robot, "log": log, "clock": clock, "imu_port": args.imu}
        if told is None:
            return HardwareRobot(args.lidar, args.motors, config, **options)
        return CalibratedHardwareRobot(args.lidar, args.motors, config, calibration=told, **options)

    return operate(open_robot,
                   work, runlog, log, path,
                   usage_fault=lambda: _missing_path(args.lidar) or _missing_path(args.motors) or _missing_path(args.imu))


def _clock(time_scale: float) -> Any:
    """The run's one clock: wall time, or ``time_scale`` times faster (a test puts the run on
    simulated time here: tests/runtime/_simcli.py)."""
    from clomp.runtime.clock import ScaledClock, WallClock

    return WallClock() if time_scale == 1.0 else ScaledClock(time_scale)


def open_runlog(name: str | None) -> tuple[Any, Path]:
    """The run log at ``name`` (default: a new timestamped file in ./clomp-runs/), its path printed."""
    from clomp.runtime.records.runlog import RunLog

    path = Path(name) if name else default_log_path()
    if path_kind(path, "--log") != "missing":
        output_path(path, "--log")  # no FIFO (its open would block), device or read-only file
    try:
        runlog = RunLog(path)
    except OSError as exc:
        raise CliError(f"cannot write the run log {path}: {exc}") from None
    print(f"log: {path}", flush=True)
    return runlog, path


def operate(open_robot: Callable[[], Any], work: Callable[[Any, Callable[[Any], None]], Any], runlog: Any, log: Any,
            path: Path, *, usage_fault: Callable[[], bool] = lambda: False, name: str = "run") -> int:
    """Open a robot, run ``work(robot, hold)`` on it, and stop and close it on every way out:
    the exit status of ``clomp run`` (and ``clomp ros node``). ``work`` returns an exit
    status or a supervisor's report, and hands ``hold`` the supervisor it runs (so that
    Ctrl-C and an exception halt it); a robot that cannot be opened is a device fault (a
    usage error when ``usage_fault()`` says the user named something that does not exist)."""
    from clomp.runtime.interface import RobotFault

    def say(text: str) -> None:
        print(f"clomp {name}: {text}", file=sys.stderr, flush=True)

    robot = None
    held: list[Any] = []
    try:
        with interrupts_raise() as signalled:
            try:
                try:
                    ready_kernels()
                    robot = open_robot()
                except RobotFault as exc:
                    return _not_started(exc, log, usage_fault(), path)
                report = work(robot, held.append)
                if isinstance(report, int):
                    return report
            except KeyboardInterrupt:
                sup = held[-1] if held else None
                return _interrupted(f"interrupted by {signalled() or 'KeyboardInterrupt'}", sup, robot, log, path, say)
            except CliError:
                raise
            except Exception as exc:  # anything unexpected: halt, say why in one line
                return _halted(exc, held[-1] if held else None, robot, log, path, say)
            finally:
                if robot is not None:
                    robot.close()
    finally:
        runlog.close()
    return _finished(report, robot, path, say)


def ready_kernels(warm: Callable[[], object] | None = None, stream: Any = None) -> float:
    """Load (or, on an empty cache, compile) the planner's, the matcher's and the plan
    check's compiled kernels before any device opens; returns the seconds it took.

    Why: numba compiles a kernel on its first call and holds the GIL while it does. On a
    fresh install the first plan of ``clomp run`` compiled for about 70 s inside the control
    loop, the LiDAR's reader thread starved, and the run ended as a silent-sensor fault
    (measured on the emulated robot). Here it happens before the wheels can move: about 1 s
    from a warm cache, about 35 s once after an install. On a terminal a line says so while
    it runs (and is cleared); a redirected stream gets nothing.

    >>> ready_kernels(warm=lambda: None) >= 0.0
    True
    """
    from clomp.runtime.experiment.runspec import RunSpec
    from clomp.runtime.experiment.warmup import warm_kernels

    out = sys.stderr if stream is None else stream
    tty = bool(getattr(out, "isatty", lambda: False)())
    if tty:
        print("clomp: loading the compiled kernels (compiled once after an install, about 35 s)…",
              end="\r", file=out, flush=True)
    start = time.monotonic()
    if warm is None:
        warm_kernels([RunSpec("overtaking", 0, 0, "planning", "paper")])
    else:
        warm()
    if tty:
        print("\x1b[2K", end="\r", file=out, flush=True)
    return time.monotonic() - start


def _not_started(exc: Exception, log: Any, usage: bool, path: Path) -> int:
    """The robot could not be started: a port path that does not exist (``usage``) is a usage
    error (CliError), anything else a device fault."""
    log.write("fault", reason=str(exc), source="start")
    log.write("stop", reason=str(exc), status="NOT_STARTED")
    if usage:
        raise CliError(f"{exc} (log: {path})") from None
    print(f"clomp: error: {exc} (log: {path})", file=sys.stderr, flush=True)
    return EXIT_DEVICE_FAULT


def _interrupted(reason: str, sup: Any, robot: Any, log: Any, path: Path, say: Callable[[str], None]) -> int:
    """Ctrl-C or SIGTERM: the supervisor aborts (or the log says the run never started)."""
    if sup is not None and not sup.terminal:
        sup.abort(reason)
    elif sup is None:
        log.write("stop", reason=reason, status="NOT_STARTED")
    say(f"{reason}: {_wheels(robot)} (log: {path})")
    return EXIT_INTERRUPTED


def _halted(exc: Exception, sup: Any, robot: Any, log: Any, path: Path, say: Callable[[str], None]) -> int:
    """An unexpected error: halt and say why in one line (a device fault for a RobotFault)."""
    from clomp.runtime.interface import RobotFault

    reason = f"{type(exc).__name__}: {exc}"
    if sup is not None and not sup.terminal:
        sup.fault(reason)
    else:
        log.write("fault", reason=reason, source="run")
        log.write("stop", reason=reason, status="HALTED")
    say(f"halted: {reason}; {_wheels(robot)} (log: {path})")
    return EXIT_DEVICE_FAULT if isinstance(exc, RobotFault) else EXIT_NOT_REACHED


def _finished(report: Any, robot: Any, path: Path, say: Callable[[str], None]) -> int:
    """Say how the supervisor's run ended; its exit status."""
    from clomp.runtime.supervision import SupervisorState

    state = report.state
    summary = f"{len(report.plans)} plans, {len(report.tasks)} tasks, {report.time_s:.1f} s"
    if state is SupervisorState.GOAL_REACHED:
        print(f"goal reached: {report.reason} ({summary})", flush=True)
        return EXIT_OK
    if state is SupervisorState.GOAL_UNCONFIRMED:  # at the goal by the estimate, which cannot vouch for it
        say(f"goal unconfirmed: {report.reason}; {_wheels(robot)} ({summary}; log: {path})")
    elif state is SupervisorState.UNREACHABLE:
        say(f"goal unreachable: {report.reason}; {_wheels(robot)} ({summary}; log: {path})")
    else:
        say(f"halted: {report.reason}; {_wheels(robot)} ({summary}; log: {path})")
    if robot is not None and robot.fault is not None:
        return EXIT_DEVICE_FAULT  # the devices tripped the robot (the supervisor halted on it)
    return EXIT_NOT_REACHED


def _dry_run(robot: Any, conf: Any, goal: tuple[float, float], clock: Any, log: Any,
             max_time: float | None, path: Path, say: Callable[[str], None] = _say) -> int:
    """Plan on every scan without moving: one ``scan`` and one ``plan`` record per scan."""
    from clomp.formal.model import Pose
    from clomp.planner import PlanningError, ScanError
    from clomp.runtime.records.runlog import plan_fields
    from clomp.runtime.interface import RobotFault

    t0 = clock.now()
    n = 0
    while max_time is None or clock.now() - t0 < max_time:
        try:
            robot.stop()  # keep the wheels at neutral (and the Maestro's watchdog fed)
            frame = robot.read_scan(timeout=1.0)
        except RobotFault as exc:
            log.write("fault", reason=str(exc), source="dry-run")
            log.write("stop", reason=str(exc), status="HALTED")
            say(f"halted: {exc}; {_wheels(robot)} (log: {path})")
            return EXIT_DEVICE_FAULT
        if frame is None:
            continue
        log.write("scan", points=frame.points, goal=list(goal), pose=[0.0, 0.0, 0.0])
        try:
            r = conf.plan(frame.points, goal)
        except (PlanningError, ScanError) as exc:
            log.write("plan", error=str(exc))
            print(f"scan {n + 1}: cannot plan: {exc}", flush=True)
            n += 1
            continue
        n += 1
        tasks = [s.task.value for s in r.steps]
        log.write("plan", **plan_fields(r, Pose(0.0, 0.0, 0.0)))  # the robot stands still: odometry = start
        print(f"scan {n}: {'goal' if r.reached_goal else 'partial' if tasks else 'no move'}  {r.n_states} states  "
              f"{r.planning_time_s * 1e3:.2f} ms  [{' '.join(t[0] for t in tasks)}]", flush=True)
    log.write("stop", reason="dry run: time limit", status="DRY_RUN")
    print(f"dry run: {n} scans planned (log: {path})", flush=True)
    return 0


# -- clomp emulate world ----------------------------------------------------------------------------
def add_emulate_world(devices: Any) -> None:
    """Add ``world`` to ``clomp emulate``'s device subparsers: both emulators over a simulated world."""
    w = devices.add_parser(
        "world",
        help="a simulated robot in a scenario behind an emulated LiDAR, Maestro and IMU",
        description="Serve a scenario's world on three pseudo-terminals: the LiDAR sees the simulated robot's "
        "surroundings, the Maestro drives its wheels, the IMU (BNO08x, UART-RVC) reports its heading with the "
        "noise preset's errors. Prints the three paths and a clomp run command, runs until "
        "Ctrl-C, then prints where the robot ended and whether it touched anything.",
    )
    w.add_argument("--scenario", default="overtaking", help="scenario name or file (default overtaking)")
    w.add_argument("--seed", type=seed_arg, help="seed of the simulated robot's noise")
    w.add_argument("--noise", choices=preset_names(), default=None,
                   help="run the execution world with this noise preset (default: the older simulated robot "
                        "with the scenario's noise)")
    w.add_argument("--noise-scale", type=float, default=1.0, help="factor on every term of --noise (default 1)")
    w.add_argument("--time-scale", type=float, default=1.0, metavar="K",
                   help="run the world K times faster than real time (pass the same to clomp run)")
    w.add_argument("--serial-timeout", type=float, metavar="S",
                   help="the Maestro's own fail-safe: wheels home after S s without a byte (default off, as on a new board)")
    w.add_argument("--mover", action="append", default=[], metavar="JSON",
                   help="a body that moves or appears (a person, a box, a door that closes), as in a scenario file's "
                        "'movers', added to the scenario's own; a world with movers runs the execution world "
                        "(--noise paper unless given) and prints the clomp run command with --moving; repeatable")
    w.add_argument("--calibration-out", metavar="FILE",
                   help="write the world's drive calibration (its noise terms; TOML for a .toml name, JSON otherwise) "
                        "and print the clomp run command with --calibration FILE; needs --noise (or --mover)")
    add_imu_fault_options(w)
    w.set_defaults(func=_run_world)


def _run_world(args: argparse.Namespace) -> int:
    from clomp.planner.scenarios import ScenarioError
    from clomp.runtime.realtime import favour_this_thread
    from clomp.runtime.backends.emulated import EmulatedWorld
    from clomp.runtime.backends.imu_fault import fault_summary

    if args.serial_timeout is not None and not (math.isfinite(args.serial_timeout) and args.serial_timeout > 0):
        raise CliError(f"--serial-timeout must be a positive number of seconds, got {args.serial_timeout}")
    scene = load_scene(args.scenario)
    movers = scene_movers(scene, args.mover)
    try:
        from clomp.runtime.backends.world import WorldNoise

        preset = args.noise or ("paper" if movers else None)  # bodies that move live in the execution world
        noise = None if preset is None else WorldNoise.preset(preset, args.noise_scale)
        world = EmulatedWorld(scene, seed=args.seed, time_scale=args.time_scale, noise=noise,
                              serial_timeout=args.serial_timeout, movers=movers, imu_fault=imu_fault_from(args))
    except (OSError, ScenarioError, ValueError) as exc:
        raise CliError(f"cannot simulate scenario {args.scenario!r}: {exc}") from None
    _write_calibration(world, args, preset)
    favour_this_thread(realtime=True)  # before the world's threads start: they inherit it
    try:
        world.start()
    except OSError as exc:
        raise CliError(f"cannot open the pseudo-terminals: {exc}") from None
    with interrupts_raise():  # a second Ctrl-C while it stops is ignored: the summary still comes
        try:
            _serve_world(world, args)
        except KeyboardInterrupt:
            pass
        finally:
            world.stop()
        p = world.pose
        print(f"robot at ({p.x:.3f}, {p.y:.3f}, {math.degrees(p.theta):.0f}°), {world.goal_distance:.3f} m from the goal, "
              f"{world.collisions} collision(s){_disturbances(world)}{fault_summary(world)}", flush=True)
    if world.error is not None:
        raise CliError(f"the emulated world failed: {world.error}")
    return 0


def _write_calibration(world: Any, args: argparse.Namespace, preset: str | None) -> None:
    """``--calibration-out FILE``: the world's noise terms, for ``clomp run --calibration``."""
    from clomp.runtime.backends.calibration import write_calibration

    if args.calibration_out is None:
        return
    if world.calibration is None:
        raise CliError("--calibration-out needs the execution world (--noise PRESET): the older simulated robot "
                       "has no calibration to tell")
    source = f"clomp emulate world --noise {preset}" + (f" --noise-scale {args.noise_scale:g}" if args.noise_scale != 1 else "")
    try:
        write_calibration(output_path(Path(args.calibration_out), "--calibration-out"), world.calibration, source)
    except OSError as exc:
        raise CliError(f"cannot write the calibration {args.calibration_out}: {exc}") from None


def _disturbances(world: Any) -> str:
    """The world's pushes and slip events for the summary line ('' when it had none), e.g.
    ``, pushed 0.18 m at 12.3 s, 1 slip event(s)``: the truth a run's doubt may answer."""
    slip_events = getattr(world, "slips", [])
    pushes = "".join(f", pushed {d:.2f} m at {t:.1f} s" for t, d in getattr(world, "pushes", []))
    slips = f", {len(slip_events)} slip event(s)" if slip_events else ""
    return pushes + slips


def _serve_world(world: Any, args: argparse.Namespace) -> None:
    """Print both ports and the command to run, then serve until Ctrl-C or a device stops."""
    gx, gy = world.scene.goal_in_robot_frame()
    print(f"lidar: {world.lidar_port}", flush=True)
    print(f"motors: {world.motor_port}", flush=True)
    print(f"imu: {world.imu_port}", flush=True)
    scale = f" --time-scale {args.time_scale:g}" if args.time_scale != 1.0 else ""
    moving = " --moving" if world.movers else ""
    told = f" --calibration {args.calibration_out}" if args.calibration_out else ""
    if told:
        print(f"calibration: {args.calibration_out}", flush=True)
    print(f"run: clomp run --lidar {world.lidar_port} --motors {world.motor_port} --imu {world.imu_port} "
          f"--goal {gx:g},{gy:g}{scale}{moving}{told}", flush=True)
    said: list[bool] = []
    while world.lidar.running and world.maestro.running and world.error is None:
        say_fault_came(world, said)
        time.sleep(0.1)
