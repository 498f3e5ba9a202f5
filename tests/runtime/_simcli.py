"""``clomp run`` itself (``cli.main(["run", ...])``, in this process) on the whole hardware stack
in simulated time: the real drivers, hardware robot, supervisor, signal handling, run log,
messages and exit status, against the device emulators on :class:`SimLine` and a
:class:`LockstepClock` (as tests/runtime/_stack.py runs the stack without the CLI).

Nothing waits on the wall clock: time flows only while the supervisor (or the dry run, waiting
for a scan) sleeps, so a run's outcome does not depend on how busy the machine is. What the
pty tests over real processes measured as "the wheels stopped after the fault" is here timed on
the emulators' own (simulated) clock.

For example (in a test given ``monkeypatch``)::

    run = simulate_cli(monkeypatch, "open", hook=at(3.0, lambda run: run.world.maestro.vanish()))
    assert cli.main(["run", *PORTS, "--goal", "1,0", "--log", "run.jsonl"]) == 3  # a device fault
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest

import clomp.runtime.backends.hardware as hardware
import clomp.runtime.cli.run as run_cli
import clomp.runtime.records.runlog as runlog
import clomp.runtime.supervision as supervision
from clomp.runtime.backends.calibration import ToldCalibration
from clomp.runtime.backends.emulated import EmulatedWorld
from tests.runtime._simline import LockstepClock, SimLine
from tests.runtime._stack import StackRun, _HookedClock

__all__ = ["LIDAR", "MOTORS", "PORTS", "record_supervisors", "simulate_cli"]

LIDAR, MOTORS = "sim-lidar", "sim-maestro"
#: the device options every simulated ``clomp run`` takes: the two lines, and the Maestro driver's
#: watchdog off (its thread sleeps in wall time; off as in test_hardware_deadlines.py and _stack.py)
PORTS = ("--lidar", LIDAR, "--motors", MOTORS, "--watchdog", "0")
_WAIT = 0.01  # simulated seconds a scan's waiter sleeps at a time


def simulate_cli(monkeypatch: pytest.MonkeyPatch, scenario: Any, *, seed: int = 0,
                 hook: Callable[[float, StackRun], None] | None = None, **world_options: Any) -> StackRun:
    """Make the next ``clomp run`` in this process open :data:`LIDAR` and :data:`MOTORS` as
    lines to ``scenario``'s emulated world in simulated time; returns the run's record
    (``world``, ``clock``, ``lines``, and ``robot``, ``started``, ``elapsed``, ``closed_at``
    once it ran). ``hook(t, run)`` runs after each of the run's sleeps, at simulated time ``t``
    (see :func:`tests.runtime._stack.at`), in the thread ``clomp run`` runs in."""
    clock = LockstepClock(100.0)
    world = EmulatedWorld(scenario, clock=clock, seed=seed, **world_options)  # not started: no pty
    run = StackRun(world, clock)
    lock = threading.RLock()
    run.lines.update(lidar=SimLine(world.lidar, clock, lock=lock, name=LIDAR, lockstep=True),
                     maestro=SimLine(world.maestro, clock, lock=lock, name=MOTORS))
    ports = {LIDAR: run.lines["lidar"], MOTORS: run.lines["maestro"]}
    run_clock: Any = clock if hook is None else _HookedClock(clock, lambda t: hook(t, run))

    class SimHardwareRobot(hardware.HardwareRobot):
        """The hardware robot on the simulated lines; waiting for a scan lets simulated time flow."""

        def __init__(self, lidar_port: Any, motor_port: Any, *args: Any, **kwargs: Any) -> None:
            run.started = clock.now()
            super().__init__(ports.get(lidar_port, lidar_port), ports.get(motor_port, motor_port), *args, **kwargs)
            run.robot = self
            clock.free_when = lambda: self.fault is not None  # a tripped robot's reader reads no more

        def read_scan(self, timeout: float | None = None) -> Any:
            waited = 0.0
            while True:
                frame = super().read_scan(timeout=0.0)
                if frame is not None or (timeout is not None and waited >= timeout):
                    return frame
                run_clock.sleep(_WAIT)
                waited += _WAIT

        def close(self) -> None:
            run.elapsed = clock.now() - run.started
            clock.release()  # let the reader thread's timeouts run out as it closes
            super().close()
            run.closed_at = clock.now()

    class SimCalibratedHardwareRobot(ToldCalibration, SimHardwareRobot):
        """The same, told its drive's calibration (``clomp run --calibration``)."""

        def __init__(self, lidar_port: Any, motor_port: Any, config: Any = None, *, calibration: Any,
                     **kwargs: Any) -> None:
            self.tell(calibration)
            super().__init__(lidar_port, motor_port, config, **kwargs)

    class SimRunLog(runlog.RunLog):
        """The run log on simulated time: a record's ``t`` is simulated seconds since the log
        opened (``run.notes["log_t0"]`` on the run's clock)."""

        def __init__(self, dest: Any, clock_: Any = None) -> None:
            super().__init__(dest, clock_ or clock)
            run.notes["log_t0"] = self._t0

    monkeypatch.setattr(hardware, "HardwareRobot", SimHardwareRobot)
    monkeypatch.setattr(hardware, "CalibratedHardwareRobot", SimCalibratedHardwareRobot)
    monkeypatch.setattr(runlog, "RunLog", SimRunLog)
    monkeypatch.setattr(run_cli, "_clock", lambda time_scale: run_clock)
    # the kernels' warm-up is a run of the execution world of its own (tests/runtime/
    # test_run_kernels.py); here it would only run the tests' patched planners once more
    monkeypatch.setattr(run_cli, "ready_kernels", lambda: 0.0)
    return run


def record_supervisors(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every :class:`~clomp.runtime.supervision.Supervisor` made until the test ends, in order
    (``clomp run``'s, to read the prior and the config it was given)."""
    made: list[Any] = []

    class Recorded(supervision.Supervisor):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(supervision, "Supervisor", Recorded)
    return made
