"""The robot interface: the only thing the supervisor sees of a robot.

Every backend (the simulated robot, the hardware robot over serial ports, a replay)
implements :class:`Robot`. Wheel speeds are linear speeds of the wheel contact points
in metres per second (positive drives forward); poses are in the odometry frame the
backend chose at start-up (x forward, y left, theta counter-clockwise).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable


from formal.model import Pose
from runtime.devices.frame import ScanFrame

__all__ = ["ScanFrame", "Robot", "RobotFault"]


class RobotFault(RuntimeError):
    """A backend cannot go on: a device vanished, a sensor fell silent, a bad reply."""


@runtime_checkable
class Robot(Protocol):
    """What a robot backend offers the supervisor."""

    def read_scan(self, timeout: float | None = None) -> ScanFrame | None:
        """The newest full scan not returned before, or None if none arrived in ``timeout`` s."""
        ...

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command the wheels (m/s). Must be called at least every control tick."""
        ...

    def stop(self) -> None:
        """Stop the wheels now. Safe to call at any time, repeatedly, also after a fault."""
        ...

    def odometry(self) -> Pose | None:
        """The pose estimate of the backend, or None when it has no odometry."""
        ...

    def close(self) -> None:
        """Stop and release the devices."""
        ...
