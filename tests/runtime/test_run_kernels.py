"""``clomp run`` (and ``clomp ros node``) load the compiled kernels before any device opens.

On an empty numba cache the first plan compiled for about 70 s inside the control loop,
holding the GIL, and the emulated LiDAR's watch declared the sensor silent: a device fault
caused by the install, not the robot. :func:`clomp.runtime.cli.run.ready_kernels` runs first."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import pytest

import clomp.runtime.experiment.warmup as warmup
from clomp.runtime.cli.run import operate, ready_kernels


class _Log:
    def __init__(self) -> None:
        self.closed = False

    def write(self, event: str, **fields: Any) -> None:
        pass

    def close(self) -> None:
        self.closed = True


class _Robot:
    def __init__(self, order: list[str]) -> None:
        self.order = order

    def close(self) -> None:
        self.order.append("close")


def test_operate_loads_the_kernels_before_the_robot_opens(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    order: list[str] = []
    monkeypatch.setattr(warmup, "warm_kernels", lambda specs, seconds=10.0: order.append("warm") or [])

    def open_robot() -> _Robot:
        order.append("open")
        return _Robot(order)

    def work(robot: Any, hold: Any) -> int:
        order.append("work")
        return 0

    runlog = _Log()
    assert operate(open_robot, work, runlog, runlog, tmp_path / "log.jsonl") == 0
    assert order == ["warm", "open", "work", "close"]
    assert runlog.closed


def test_the_warm_up_is_a_planning_run_of_the_execution_world(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[Any] = []
    monkeypatch.setattr(warmup, "warm_kernels", lambda specs, seconds=10.0: seen.extend(specs) or [])
    ready_kernels(stream=io.StringIO())
    assert [s.condition for s in seen] == ["planning"]


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_terminal_sees_a_line_while_the_kernels_load_and_it_is_cleared() -> None:
    tty = _Tty()
    ready_kernels(warm=lambda: None, stream=tty)
    text = tty.getvalue()
    assert "compiled kernels" in text and text.endswith("\x1b[2K\r")
    piped = io.StringIO()
    ready_kernels(warm=lambda: None, stream=piped)
    assert piped.getvalue() == ""
