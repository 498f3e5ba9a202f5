"""Faults while driving, through the whole hardware stack in simulated time: how soon the
wheels are commanded to stop, measured on the simulated clock.

The same faults over ptys in real time (test_run_cli.py) show the end-to-end behaviour of
``clomp run`` (exit codes, log records, messages); a wall-clock bound there would measure the
machine's scheduler as much as the software. Here time flows only while the supervisor sleeps
(tests/runtime/_stack.py), so the figure is the software's own: a fault met inside a tick
stops the wheels in that same tick (0 s of simulated time), one met between ticks at the
next command (within one tick, 0.1 s).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from clomp.planner import Configurator
from clomp.runtime.supervision import SupervisorState
from clomp.runtime.supervision.states import Event
from tests.runtime._simline import LockstepClock
from tests.runtime._stack import StackRun, at, driving, run_stack, wheels_stopped_at

TICK = 0.1  # the supervisor's control period (RobotModel.tick)
T_FAULT = 3.0  # simulated seconds into the run: the robot is driving its first straight (it stands
# the first ten revolutions, about 1.8 s at 5.5 Hz, to seed its map)


def test_ctrl_c_between_ticks_stops_the_wheels_at_once() -> None:
    def interrupt(run: StackRun) -> None:
        raise KeyboardInterrupt("interrupted by SIGINT")

    run = run_stack("overtaking", hook=at(T_FAULT, interrupt))
    assert isinstance(run.raised, KeyboardInterrupt)
    t_fault = run.notes["t_fault"]
    assert wheels_stopped_at(run.world.maestro, t_fault) - t_fault == 0.0  # in the same instant, before any wait
    assert run.world.maestro.speeds == (0.0, 0.0)


def test_ctrl_c_inside_a_tick_halts_the_supervisor_with_the_wheels_stopped() -> None:
    def arm(run: StackRun) -> None:
        assert run.robot is not None

        def interrupted(*a: Any, **k: Any) -> None:
            run.notes["raised_at"] = run.clock.now()
            raise KeyboardInterrupt("interrupted by SIGINT")

        run.robot.set_wheel_speeds = interrupted  # type: ignore[method-assign]

    run = run_stack("overtaking", hook=at(T_FAULT, arm))
    assert isinstance(run.raised, KeyboardInterrupt)
    sup = run.supervisor
    assert sup is not None and sup.state is SupervisorState.HALTED and "SIGINT" in sup.reason
    raised_at = run.notes["raised_at"]
    assert wheels_stopped_at(run.world.maestro, raised_at) - raised_at == 0.0
    assert raised_at - run.notes["t_fault"] <= TICK


def test_the_motor_controller_vanishing_is_detected_at_the_next_command() -> None:
    run = run_stack("overtaking", hook=at(T_FAULT, lambda run: run.world.maestro.vanish()))
    assert run.raised is None and run.report is not None
    assert run.report.state is SupervisorState.HALTED
    assert run.robot is not None and run.robot.fault is not None and "motor controller" in run.robot.fault
    fault = next(tr for tr in run.report.transitions if tr.event is Event.FAULT)
    # the transitions' times are the supervisor's (seconds since its start)
    t_fault = run.notes["t_fault"] - run.notes["t0"]
    assert 0.0 <= fault.time - t_fault <= TICK + 1e-9, (fault.time, t_fault)


def test_an_exception_inside_planning_halts_with_the_wheels_stopped(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = LockstepClock(100.0)
    raised: list[float] = []

    def broken_plan(self: Any, scan: Any, goal: Any) -> Any:
        raised.append(clock.now())
        raise RuntimeError("boom in the planner")

    monkeypatch.setattr(Configurator, "plan", broken_plan)
    run = run_stack("overtaking", clock=clock)
    assert run.report is not None and run.report.state is SupervisorState.HALTED
    assert "boom in the planner" in run.report.reason and "RuntimeError" in run.report.reason
    assert raised and wheels_stopped_at(run.world.maestro, raised[0]) - raised[0] == 0.0
    assert not driving(run)  # no plan, no task: the wheels were never commanded to move


def test_a_stalled_lidar_stops_the_wheels_and_never_holds_the_way_out() -> None:
    """The LiDAR's process stops (nothing more arrives, a write blocks until it resumes, as
    on a pty whose other end is stopped): the silence trips the robot, the wheels stop within
    0.3 s, and close() returns within 1 s of the stall, leaving the STOP it writes to the LiDAR
    blocked behind it; ``clomp run`` then exits 3."""
    from clomp.runtime.cli import EXIT_DEVICE_FAULT
    from clomp.runtime.cli.run import _finished

    from clomp.runtime.backends.hardware import CLOSE_BUDGET

    # close() waits at most CLOSE_BUDGET s of wall time for what is left (simulated time stands still meanwhile)
    assert 0.3 + CLOSE_BUDGET <= 1.0
    run = run_stack("overtaking", hook=at(T_FAULT, lambda run: run.lines["lidar"].stall()))
    line = run.lines["lidar"]
    try:
        t_fault = run.notes["t_fault"]
        assert run.robot is not None and run.robot.fault is not None and "fell silent" in run.robot.fault
        assert wheels_stopped_at(run.world.maestro, t_fault) - t_fault <= 0.3
        assert run.closed_at is not None and run.closed_at - t_fault <= 1.0, run.closed_at - t_fault
        assert line.blocked == 1  # the way out did not wait for the stalled LiDAR
        assert run.report is not None and run.report.state is SupervisorState.HALTED
        assert _finished(run.report, run.robot, Path("run.jsonl"), lambda text: None) == EXIT_DEVICE_FAULT
    finally:
        line.resume()
