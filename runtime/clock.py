"""Clocks: where the runtime's time comes from — the one clock module.

A :class:`Clock` has ``now()`` (seconds, monotonic) and ``sleep(seconds)``. Hardware runs
on :class:`WallClock`; an emulated world running faster than real time on
:class:`ScaledClock`; simulated robots keep their own time (they are clocks themselves:
``sleep`` advances the simulation), and :class:`ManualClock` is a clock that moves only
when told, for tests and tools that step time by hand. The supervisor, the robots and the
emulated world take a :class:`Clock`; a device (:mod:`clomp.runtime.devices`, which imports
nothing from above) takes only a monotonic source ``() -> float``, the one
:func:`device_time` gives for a robot's clock — devices read time and never let it pass.

>>> c = ManualClock()
>>> c.sleep(0.25); c.now()
0.25
>>> isinstance(WallClock(), Clock)
True
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Protocol, runtime_checkable

__all__ = ["Clock", "ManualClock", "ScaledClock", "WallClock", "clock_for", "device_seconds", "device_time",
           "device_to_clock"]


@runtime_checkable
class Clock(Protocol):
    """Where the supervisor's time comes from: wall time on hardware, simulated time in sim.

    >>> isinstance(ManualClock(), Clock), isinstance(object(), Clock)
    (True, False)
    """

    def now(self) -> float:
        """Seconds, monotonic."""
        ...

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` pass."""
        ...


class WallClock:
    """Real time (``time.monotonic`` / ``time.sleep``), for hardware backends.

    >>> c = WallClock(); t = c.now(); c.sleep(0); c.now() >= t
    True
    """

    def now(self) -> float:
        """Seconds since an arbitrary origin."""
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        """Sleep ``seconds`` of wall time."""
        if seconds > 0:
            time.sleep(seconds)


class ScaledClock:
    """A clock running ``scale`` times faster than wall time (``scale`` = 1: wall time).

    >>> ScaledClock(10.0).scale
    10.0
    """

    def __init__(self, scale: float = 1.0) -> None:
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f"time scale must be a positive number, got {scale!r}")
        self.scale = float(scale)
        self._origin = time.monotonic()

    def now(self) -> float:
        """Scaled seconds since the clock was made."""
        return (time.monotonic() - self._origin) * self.scale

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` of scaled time pass."""
        if seconds > 0:
            time.sleep(seconds / self.scale)

    def from_monotonic(self, t: float) -> float:
        """This clock's time at the ``time.monotonic`` reading ``t`` (a device's timestamp).

        >>> c = ScaledClock(2.0); round(c.from_monotonic(c._origin + 1.5), 9)
        3.0
        """
        return (t - self._origin) * self.scale


class ManualClock:
    """A clock that advances only by :meth:`sleep` (or :meth:`advance`): time under test control.

    >>> c = ManualClock(start=1.0); c.advance(0.5); c.now()
    1.5
    """

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def now(self) -> float:
        """The current manual time."""
        return self._t

    def sleep(self, seconds: float) -> None:
        """Advance by ``seconds`` (negative values are ignored), immediately."""
        if seconds > 0:
            self._t += seconds

    def advance(self, seconds: float) -> None:
        """Same as :meth:`sleep`."""
        self.sleep(seconds)


def device_to_clock(clock: Clock) -> Callable[[float], float]:
    """The map from a device's timestamp (on :func:`device_time`) to ``clock``'s time: the
    identity, but for a :class:`ScaledClock`, whose devices stamp wall time while its own runs
    ``scale`` times faster from its origin (a scan stamped in wall time is, to a supervisor on
    scaled time, from another clock).

    >>> c = ScaledClock(2.0); round(device_to_clock(c)(c._origin + 1.0), 9), device_to_clock(WallClock())(7.0)
    (2.0, 7.0)
    """
    return clock.from_monotonic if isinstance(clock, ScaledClock) else _same


def device_seconds(clock: Clock) -> float:
    """How many of ``clock``'s seconds one second of device time is: a :class:`ScaledClock`'s
    ``scale`` (its world, and the rates the devices measure, run that much faster), else 1.

    >>> device_seconds(ScaledClock(2.0)), device_seconds(WallClock()), device_seconds(ManualClock())
    (2.0, 1.0, 1.0)
    """
    return clock.scale if isinstance(clock, ScaledClock) else 1.0


def _same(t: float) -> float:
    return t


def clock_for(robot: object, clock: Clock | None = None) -> Clock:
    """``clock`` if given; else the robot itself when it keeps (simulated) time; else wall time.

    >>> c = ManualClock(); clock_for(object(), c) is c
    True
    >>> type(clock_for(object())).__name__
    'WallClock'
    """
    if clock is not None:
        return clock
    return robot if isinstance(robot, Clock) else WallClock()


def device_time(clock: Clock) -> Callable[[], float]:
    """The monotonic source (``() -> float``) the devices of a robot on ``clock`` read.

    Devices take a plain source, not a :class:`Clock` (see :mod:`clomp.runtime.devices`):
    they read time for deadlines and timestamps and never let it pass. A clock on wall
    time (:class:`WallClock`, and :class:`ScaledClock`, which scales the world, not a serial
    line's or a thread's delays) gives ``time.monotonic`` itself; any other clock (a test's
    simulated time) its own ``now``, so the devices' deadlines run on that time.

    >>> device_time(WallClock()) is time.monotonic, device_time(ScaledClock(2.0)) is time.monotonic
    (True, True)
    >>> c = ManualClock(5.0); device_time(c)()
    5.0
    """
    return time.monotonic if isinstance(clock, (WallClock, ScaledClock)) else clock.now
