"""A named IMU fault at a chosen moment of an emulated world's time (``clomp emulate world --imu-fault``).

What a user would do to a BNO08x mid-run, laid over the world's IMU emulator
(:class:`~clomp.runtime.devices.bno08x_emulator.Bno08xEmulator`) when the world's clock
reaches ``at`` seconds (world time: it runs only while a program drives the robot, so it
counts from ``clomp run``'s start):

- ``silent``: no report any more (the device hangs, its TX wire comes loose);
- ``unplug``: the pty closes (the USB adapter pulled out);
- ``garbage``: random bytes at the line rate instead of reports (wrong baud rate, noise);
- ``wrong-yaw``: the reported yaw jumps by ``jump`` rad and stays off (a reset, a mount knocked);
- ``spin``: the reported yaw starts to turn at ``spin`` rad/s of world time while the body
  does not (a gyro gone bad).

The fault is applied from the IMU's heading source (:meth:`ImuFault.heading`, called at each
report the device makes), so it comes at the report due at ``at``, the same in simulated
time and over ptys; it records the moment (``world_time``, ``device_time``) and where the
robot was (``pose``), for what a tool says afterwards (how long until the wheels stopped,
how far the robot went after it).

>>> f = ImuFault("wrong-yaw", at=2.0)
>>> f.heading(0.1, 1.0, None), f.applied
(0.1, False)
>>> round(f.heading(0.1, 2.0, None), 4), f.applied, f.world_time
(1.6708, True, 2.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from clomp.formal.model import Pose

__all__ = ["IMU_FAULTS", "ImuFault", "fault_summary", "wheels_stopped_at"]

IMU_FAULTS = ("silent", "unplug", "garbage", "wrong-yaw", "spin")
"""The fault names ``--imu-fault`` takes."""


@dataclass
class ImuFault:
    """One IMU fault: ``kind`` (one of :data:`IMU_FAULTS`) at ``at`` s of world time; ``jump``
    (rad) the yaw's step for ``wrong-yaw``, ``spin`` (rad/s) its false turn rate for ``spin``.
    ``clock`` (the devices' clock, optional) timestamps the moment in ``device_time``."""

    kind: str
    at: float
    jump: float = math.pi / 2
    spin: float = math.radians(30.0)
    clock: Any = None
    world_time: float | None = field(default=None, init=False)
    device_time: float | None = field(default=None, init=False)
    pose: Pose | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        if self.kind not in IMU_FAULTS:
            raise ValueError(f"unknown IMU fault {self.kind!r}; known: {', '.join(IMU_FAULTS)}")
        if not (math.isfinite(self.at) and self.at >= 0):
            raise ValueError(f"the fault's time must be a number of seconds >= 0, got {self.at!r}")
        if not (math.isfinite(self.jump) and math.isfinite(self.spin)):
            raise ValueError("the yaw's jump and spin rate must be finite")

    @property
    def applied(self) -> bool:
        """Whether the fault has come."""
        return self.world_time is not None

    def heading(self, theta: float, now: float, imu: Any, pose: Pose | None = None) -> float:
        """The heading the IMU measures at world time ``now`` when the true one is ``theta``
        (rad); at the first call at or after ``at`` the fault comes (a device fault is switched
        on in ``imu``, the emulator; ``pose``, the robot's true pose then, is kept)."""
        if now < self.at:
            return theta
        if self.world_time is None:
            self.world_time, self.pose = now, pose
            self.device_time = None if self.clock is None else float(self.clock())
            if self.kind == "silent":
                imu.inject(silent=True)
            elif self.kind == "garbage":
                imu.inject(garbage_only=True)
            elif self.kind == "unplug":
                imu.vanish()
        if self.kind == "wrong-yaw":
            return theta + self.jump
        if self.kind == "spin":
            return theta + self.spin * (now - self.world_time)
        return theta

    def describe(self) -> str:
        """One phrase, e.g. ``wrong-yaw (+90°) at 5 s of world time``."""
        extra = {"wrong-yaw": f" ({math.degrees(self.jump):+.0f}°)",
                 "spin": f" ({math.degrees(self.spin):+.0f}°/s)"}.get(self.kind, "")
        return f"{self.kind}{extra} at {self.at:g} s of world time"


def wheels_stopped_at(events: list[tuple[float, int, int]], channels: tuple[int, int], since: float,
                      neutral: int = 6000) -> float | None:
    """The device time at or after ``since`` from which both wheel ``channels`` stayed commanded
    at rest (target ``neutral`` quarter-µs or 0: no pulse), from a Maestro emulator's ``events``
    (``(time, channel, target)``); None when they were still commanded to move at the end.

    >>> ev = [(1.0, 0, 6400), (1.0, 1, 5600), (2.5, 0, 6000), (2.5, 1, 6000)]
    >>> wheels_stopped_at(ev, (0, 1), 2.0), wheels_stopped_at(ev, (0, 1), 3.0), wheels_stopped_at(ev[:2], (0, 1), 2.0)
    (2.5, 3.0, None)
    """
    targets: dict[int, int] = {ch: 0 for ch in channels}
    rest_since: float | None = -math.inf  # at rest (no pulse) before the first command
    for t, ch, target in events:
        if ch not in targets:
            continue
        targets[ch] = target
        if not all(v in (0, neutral) for v in targets.values()):
            rest_since = None
        elif rest_since is None:
            rest_since = t
    return None if rest_since is None else max(rest_since, since)


def fault_summary(world: Any) -> str:
    """What became of an emulated world's IMU fault, for its end-of-run line ('' without one), e.g.
    ``; IMU fault silent at 5 s of world time came at 5.00 s: wheels commanded to stop 0.23 s
    (world) after it, the robot moved 0.021 m after it, wheel speeds now (0, 0) m/s``."""
    fault: ImuFault | None = getattr(world, "imu_fault", None)
    if fault is None:
        return ""
    if not fault.applied or fault.device_time is None:
        return f"; IMU fault {fault.describe()}: never came (the world did not reach that time)"
    m = world.maestro
    stop = wheels_stopped_at(list(m.events), (m.left.channel, m.right.channel), fault.device_time, round(m.neutral_us * 4))
    when = "still commanded to move" if stop is None else \
        f"commanded to stop {(stop - fault.device_time) * world.time_scale:.2f} s (world) after it"
    pose = world.pose
    moved = "" if fault.pose is None else f", the robot moved {math.hypot(pose.x - fault.pose.x, pose.y - fault.pose.y):.3f} m after it"
    speeds = getattr(world.sim, "wheel_speeds", world.sim.commanded)
    return (f"; IMU fault {fault.describe()} came at {fault.world_time:.2f} s: wheels {when}{moved}, "
            f"wheel speeds now ({speeds[0]:.3g}, {speeds[1]:.3g}) m/s")
