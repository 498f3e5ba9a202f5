"""Fault injection: a robot wrapper that makes a working backend misbehave on demand.

For testing a supervisor (or any controller on the :class:`~clomp.runtime.interface.Robot`
interface) against the faults a real robot has: wrap a backend, then set ``fault`` (now,
or from the backend's time ``at`` on). The wrapped backend must keep its own clock
(``now()``/``sleep()``, as :class:`clomp.runtime.backends.sim.SimRobot` does) for ``at`` to apply.

>>> from clomp.planner import load_scenario
>>> from clomp.runtime.backends.sim import SimRobot
>>> robot = FaultyRobot(SimRobot(load_scenario("open"), seed=0), "silent", at=2.0)
>>> robot.read_scan() is not None   # before 2 s of simulated time: a normal scan
True
"""

from __future__ import annotations

import numpy as np

from clomp.formal.model import Pose
from clomp.runtime.interface import Robot, RobotFault, ScanFrame

__all__ = ["FAULTS", "FaultyRobot"]

#: the faults :class:`FaultyRobot` can inject, and what each does
FAULTS: dict[str, str] = {
    "silent": "the LiDAR returns no scan any more",
    "nan": "scans carry a non-finite coordinate",
    "device": "reading the LiDAR raises RobotFault (unplugged)",
    "motor": "commanding the wheels raises RobotFault (controller gone)",
    "port": "commanding the wheels raises OSError (a raw serial error, not a RobotFault)",
    "phantom": "scans show a wall right in front of the body",
    "interrupt": "reading the LiDAR raises KeyboardInterrupt (Ctrl-C)",
}


class FaultyRobot:
    """Wraps a :class:`Robot`; from time ``at`` on (or at once), misbehaves as ``fault``.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> robot = FaultyRobot(SimRobot(load_scenario("open"), seed=0), "device")
    >>> try:
    ...     robot.read_scan()
    ... except RobotFault as exc:
    ...     print(exc)
    LiDAR unplugged
    """

    def __init__(self, robot: Robot, fault: str | None = None, at: float | None = None) -> None:
        if fault is not None and fault not in FAULTS:
            raise ValueError(f"unknown fault {fault!r}; known: {', '.join(FAULTS)}")
        self.robot = robot
        self.fault = fault
        self.at = at

    def _active(self, kind: str) -> bool:
        if self.fault != kind:
            return False
        return self.at is None or self.now() >= self.at

    def read_scan(self, timeout: float | None = None) -> ScanFrame | None:
        """The wrapped robot's scan, or the injected fault."""
        if self._active("interrupt"):
            raise KeyboardInterrupt
        if self._active("device"):
            raise RobotFault("LiDAR unplugged")
        frame = self.robot.read_scan(timeout)
        if self._active("silent"):
            return None
        if frame is None:
            return None
        if self._active("nan"):
            pts = frame.points.copy()
            if len(pts):
                pts[len(pts) // 2, 1] = np.nan
            else:
                pts = np.array([[np.nan, 0.0]])
            return ScanFrame(pts, frame.timestamp)
        if self._active("phantom"):
            ys = np.arange(-0.2, 0.201, 0.01)
            return ScanFrame(np.r_[frame.points, np.c_[np.full(len(ys), 0.12), ys]], frame.timestamp)
        return frame

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command the wrapped robot, or raise the injected motor fault."""
        if self._active("motor"):
            raise RobotFault("motor controller gone")
        if self._active("port"):
            raise OSError("serial port gone")
        self.robot.set_wheel_speeds(left, right)

    def stop(self) -> None:
        """Stop the wrapped robot (faults never prevent a stop: that is the fail-safe's job)."""
        self.robot.stop()

    def odometry(self) -> Pose | None:
        """The wrapped robot's odometry."""
        return self.robot.odometry()

    def close(self) -> None:
        """Close the wrapped robot."""
        self.robot.close()

    def now(self) -> float:
        """The wrapped robot's clock."""
        return self.robot.now()  # type: ignore[attr-defined, no-any-return]

    def sleep(self, seconds: float) -> None:
        """Advance the wrapped robot's clock."""
        self.robot.sleep(seconds)  # type: ignore[attr-defined]
