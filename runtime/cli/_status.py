"""``clomp run``'s status line: what the run does, one line on a terminal, updated in place.

State, task, the estimated distance to the goal with its bound (the 95 % bound of the
estimate's position the supervisor vouches with,
:meth:`~clomp.runtime.supervision.sensing.Sensing.position_bound`), LiDAR revolutions, and the LiDAR's and IMU's health. Drawn only
when standard error is a terminal (:func:`~clomp.runtime.cli._progress.enabled_for`): in a
pipe, a file or a test's captured output ``clomp run`` prints exactly what it printed
before. The line is cleared before the run's final line.

>>> status_text("EXECUTING", "STRAIGHT", 0.42, 0.03, 17, "ok", None)
'EXECUTING  STRAIGHT  goal 0.42 m ± 0.03  17 rev  lidar ok'
"""

from __future__ import annotations

import math
import sys
import threading
from typing import IO, Any

from clomp.runtime.cli._progress import enabled_for

__all__ = ["StatusLine", "status_text"]


def status_text(state: str, task: str | None, dist: float, bound: float | None, revolutions: int,
                lidar: str, imu: str | None) -> str:
    """The status line's text (``imu`` None: no IMU)."""
    parts = [state, task or "-", f"goal {dist:.2f} m" + ("" if bound is None else f" ± {bound:.2f}"),
             f"{revolutions} rev", f"lidar {lidar}"]
    if imu is not None:
        parts.append(f"imu {imu}")
    return "  ".join(parts)


def _snapshot(sup: Any, robot: Any) -> str:
    """The supervisor's and the robot's state now, read from another thread (for display only)."""
    gx, gy = sup.goal_in_robot_frame()
    bound = sup.sensing.position_bound(sup.config.vouch_sigmas)
    task = getattr(getattr(sup, "_task", None), "kind", None)
    fault = robot.fault
    imu = getattr(robot, "imu", None)
    imu_health = None if imu is None else ("fault" if imu.fault is not None else "ok")
    lidar_health = "fault" if fault is not None and "LiDAR" in fault else "ok"
    return status_text(sup.state.value, None if task is None else task.value, math.hypot(gx, gy), bound,
                       robot.scans, lidar_health, imu_health)


class StatusLine:
    """A thread redrawing the status line every ``period`` s while a run lasts (a no-op when
    ``stream`` is not a terminal). Use as a context manager around ``Supervisor.run``."""

    def __init__(self, sup: Any, robot: Any, *, stream: IO[str] | None = None, period: float = 0.25,
                 enabled: bool | None = None) -> None:
        self.sup, self.robot, self.period = sup, robot, period
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled_for(self.stream) if enabled is None else enabled
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _draw(self, text: str) -> None:
        self.stream.write("\r\x1b[2K" + text)
        self.stream.flush()

    def _loop(self) -> None:
        while not self._stop.wait(self.period):
            try:
                self._draw(_snapshot(self.sup, self.robot))
            except Exception:  # noqa: BLE001 - a display must never end the run
                continue

    def __enter__(self) -> StatusLine:
        if self.enabled:
            self._thread = threading.Thread(target=self._loop, name="status-line", daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._thread is None:
            return
        self._stop.set()
        self._thread.join(timeout=1.0)
        self._draw("")  # cleared: the final line stands alone
