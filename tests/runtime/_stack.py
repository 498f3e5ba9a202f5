"""The whole hardware stack in simulated time, for tests: drivers, hardware robot and supervisor
against the device emulators and a scenario's world, with no pty and no wall clock.

The devices are the emulator logic on :class:`SimLine` and time is a :class:`LockstepClock`:
it flows only while the supervisor sleeps between ticks, so planning costs no simulated time
(an idealisation: the real-time cost is what the pty tests of test_run_cli.py measure) and a
run's outcome does not depend on how busy the machine is. ``hook(t, run)`` is called in the
supervisor's thread after each of its sleeps, at simulated time ``t``: a test injects a fault
there (unplug a device, raise as a signal handler would) at a chosen moment. ``imu=True``
adds the world's IMU on a third line (ticked with the LiDAR; its reader has read all it sent
before the supervisor wakes), as ``clomp run --imu``.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from clomp.planner import Configurator
from clomp.runtime.devices.maestro_emulator import MaestroEmulator
from clomp.runtime.backends.emulated import EmulatedWorld
from clomp.runtime.backends.hardware import CalibratedHardwareRobot, HardwareConfig, HardwareRobot
from clomp.runtime.supervision import Supervisor, SupervisorConfig, SupervisorReport
from tests.runtime._simline import LockstepClock, SimLine

__all__ = ["NEUTRAL", "StackRun", "at", "driving", "run_stack", "wheels_stopped_at"]

NEUTRAL = 6000  # 1500 µs in quarter-µs


@dataclass
class StackRun:
    world: EmulatedWorld
    clock: LockstepClock
    robot: HardwareRobot | None = None
    supervisor: Supervisor | None = None
    report: SupervisorReport | None = None
    elapsed: float = 0.0  # simulated seconds
    started: float = 0.0  # the simulated time the supervisor's run began
    raised: BaseException | None = None  # what the supervisor's run raised
    notes: dict[str, Any] = field(default_factory=dict)  # what a hook wants to remember
    lines: dict[str, SimLine] = field(default_factory=dict)  # "lidar", "maestro" (and "imu")
    closed_at: float | None = None  # the simulated time the robot's close() returned


class _HookedClock:
    """The supervisor's view of the lockstep clock: after each sleep, ``hook`` runs."""

    def __init__(self, clock: LockstepClock, hook: Callable[[float], None]) -> None:
        self._clock, self._hook = clock, hook

    def now(self) -> float:
        return self._clock.now()

    def sleep(self, seconds: float) -> None:
        self._clock.sleep(seconds)
        self._hook(self._clock.now())


def run_stack(scenario: Any, *, max_time: float = 80.0, seed: int = 0, conf: Configurator | None = None,
              hook: Callable[[float, StackRun], None] | None = None, clock: LockstepClock | None = None,
              imu: bool = False, supervisor: SupervisorConfig | None = None, calibration: Any = None,
              hardware: HardwareConfig | None = None, **world_options: Any) -> StackRun:
    """Plan and execute ``scenario``'s goal through the real drivers, in simulated time (the
    world's noise drawn from ``seed``: the same run every time). Whatever the supervisor's
    ``run`` raises (a KeyboardInterrupt a hook raised, say) is kept in ``raised``, with
    ``report`` left None, as clomp run would catch it. ``supervisor``: the supervisor's settings
    (``SupervisorConfig(moving=True)`` with ``movers=`` in ``world_options``: a world that moves).
    ``calibration`` (a NoiseTerms): the robot is told it, as ``clomp run --calibration`` tells it;
    ``hardware``: the hardware robot's settings (default: the Maestro driver's watchdog off)."""
    clock, lock = clock or LockstepClock(100.0), threading.RLock()
    world = EmulatedWorld(scenario, clock=clock, seed=seed, **world_options)  # not started: no pty, no thread
    run = StackRun(world, clock)
    # the IMU is ticked with the LiDAR, in its line's thread: the world is advanced at the same
    # instants however the readers' threads interleave (the same run every time)
    lidar_line = SimLine(world.lidar, clock, lock=lock, name="sim-lidar", lockstep=True,
                         also=(world.imu,) if imu else ())
    motor_line = SimLine(world.maestro, clock, lock=lock, name="sim-maestro")
    imu_line = SimLine(world.imu, clock, lock=lock, name="sim-imu", follow=True) if imu else None
    run.lines.update(lidar=lidar_line, maestro=motor_line, **({"imu": imu_line} if imu_line is not None else {}))
    # the Maestro driver's watchdog: off, as in test_hardware_deadlines.py
    config = hardware or HardwareConfig(watchdog_timeout=None)
    conf = conf or Configurator()
    t0 = run.started = clock.now()
    sup_clock: Any = clock if hook is None else _HookedClock(clock, lambda t: hook(t, run))
    try:
        options: dict[str, Any] = {"model": conf.robot, "clock": clock, "imu_port": imu_line}
        with (HardwareRobot(lidar_line, motor_line, config, **options) if calibration is None else
              CalibratedHardwareRobot(lidar_line, motor_line, config, calibration=calibration, **options)) as robot:
            run.robot = robot
            # a tripped robot's reader reads no more (nor a failed IMU's)
            clock.free_when = lambda: robot.fault is not None or (robot.imu is not None and robot.imu.fault is not None)
            run.supervisor = Supervisor(robot, world.scene.goal_in_robot_frame(), conf, clock=sup_clock,
                                        **({"config": supervisor} if supervisor is not None else {}))
            try:
                run.report = run.supervisor.run(max_time=max_time)
            except BaseException as exc:  # noqa: BLE001 -- the test inspects it
                run.raised = exc
            finally:
                run.elapsed = clock.now() - t0
                clock.release()  # let the reader thread's timeouts run out as it closes
        run.closed_at = clock.now()
    finally:
        clock.release()
    return run


def wheels_stopped_at(maestro: MaestroEmulator, t0: float) -> float:
    """The first time (the emulator's clock) at or after ``t0`` when both wheels had been
    commanded to neutral; fails if they were commanded to move again after that."""
    targets: dict[int, int | None] = {0: None, 1: None}
    stop_at = None
    for t, ch, target in list(maestro.events):
        if ch not in targets:
            continue
        targets[ch] = target
        halted = all(v in (0, NEUTRAL) for v in targets.values())
        if t >= t0 and halted and stop_at is None:
            stop_at = t
        elif stop_at is not None and not halted:
            raise AssertionError(f"the wheels were commanded to move again at {t - t0:.3f} s")
    if stop_at is None:
        raise AssertionError("the wheels were never commanded to stop")
    return stop_at


def driving(run: StackRun) -> bool:
    """Whether the wheels have been commanded to move in this run."""
    return any(ch in (0, 1) and t not in (0, NEUTRAL) for _, ch, t in run.world.maestro.events)


def at(t_fault: float, act: Callable[[StackRun], None]) -> Callable[[float, StackRun], None]:
    """A hook that calls ``act(run)`` once, at the first wake-up at or after ``t_fault`` s of
    the run, and remembers that moment in ``run.notes["t_fault"]``."""
    def hook(t: float, run: StackRun) -> None:
        t0 = run.notes.setdefault("t0", t)
        if "t_fault" not in run.notes and t - t0 >= t_fault:
            assert driving(run), "the fault is meant to come while the wheels turn"
            run.notes["t_fault"] = t
            act(run)
    return hook
