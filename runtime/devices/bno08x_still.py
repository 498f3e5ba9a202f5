"""An IMU that turns while the wheels stand is wrong: :class:`StillWatch`.

A BNO08x's yaw drifts by about 0.5°/min standing still; the execution world's harsh preset
gives its IMU a drift of 0.05 rad/s (one standard deviation). A yaw that turns at tens of
degrees a second while the wheels have been commanded still — a gyro gone bad, a
forged stream, a device that keeps "turning" after a reset — is not a heading any consumer
should follow: the estimator would learn it as the IMU's offset while the robot stands, and
believe the robot turns when it drives (issue #36: "an IMU that disagrees wildly is a device
fault, never a silent fallback"). The driver's rate check
(:class:`~clomp.runtime.devices.bno08x.Bno08xRvc`'s ``max_rate``) catches a jump or a turn
faster than the wheels can make; this one a plausible turn rate at the wrong time.

Time is counted in reports (10 ms each, from their indices: a lost report counts, a host
that read late does not): ``settle`` s after the first report made once the wheels were
commanded still (its timestamp at or after the command's: a reader running late still
holds reports made while the body moved; the body stops meanwhile: the drive's latency,
its deceleration), the yaw of that report is the window's base; from then on the yaw may
differ from it by at most ``max_rate`` × the window's span + ``slack``. The wheels
commanded to move end the window.

>>> w = StillWatch(max_rate=0.25, slack=0.05, settle=0.3)
>>> w.command(still=True, at=0.0)
>>> w.feed(250, 2.0, -0.05) is None                             # made before the command: not counted
True
>>> [w.feed(i, 0.0, i / 100) for i in range(40)][-1] is None
True
>>> out = [w.feed(40 + i, 0.01 * i, 0.4 + i / 100) for i in range(60)]   # 1 rad/s while standing
>>> next(k for k, o in enumerate(out) if o is not None), out[-1] is not None
(11, True)
>>> w.command(still=False, at=1.0); w.feed(100, 3.0, 1.0) is None      # driving: no judgement
True
"""

from __future__ import annotations

import math

from clomp.runtime.devices.bno08x_codec import REPORT_RATE

__all__ = ["StillWatch"]


class StillWatch:
    """Judges the yaw while the wheels stand (see the module); ``max_rate`` rad/s, ``slack``
    rad, ``settle`` s. Not thread-safe: the driver calls it under its lock."""

    def __init__(self, max_rate: float = 0.25, slack: float = 0.05, settle: float = 0.3) -> None:
        if not (max_rate > 0 and slack >= 0 and settle >= 0):
            raise ValueError("max_rate must be positive, slack and settle not negative")
        self.max_rate, self.slack, self.settle = max_rate, slack, settle
        self.still = False
        self._since = -math.inf  # when the wheels were commanded still (the driver's clock)
        self._last: int | None = None  # the index of the last report fed in this stand
        self._span = 0  # reports since the first one of this stand
        self._base: tuple[int, float] | None = None  # (reports since the stand's first, yaw) at the window's start

    def command(self, still: bool, at: float) -> None:
        """The wheels were commanded still (True) or to move (False) at ``at`` (the driver's clock)."""
        if still and not self.still:
            self._last, self._span, self._base, self._since = None, 0, None, at
        self.still = still

    def feed(self, index: int, yaw: float, timestamp: float) -> str | None:
        """One report (its index, its yaw followed through the wrap, rad, when it was made on
        the driver's clock); why the yaw is wrong (turned ... in ... s while the wheels
        stood), or None."""
        if not self.still or (self._last is None and timestamp < self._since):
            return None
        if self._last is not None:
            self._span += (index - self._last) % 256
        self._last = index
        if self._base is None:
            if self._span >= self.settle * REPORT_RATE - 1e-9:
                self._base = (self._span, yaw)
            return None
        dt = (self._span - self._base[0]) / REPORT_RATE
        turned = abs(yaw - self._base[1])
        if turned > self.max_rate * dt + self.slack:
            return (f"turned {turned:.2f} rad in {dt:.2f} s while the wheels stood (at most "
                    f"{self.max_rate:.2f} rad/s of drift, {self.slack:.2f} rad of noise)")
        return None
