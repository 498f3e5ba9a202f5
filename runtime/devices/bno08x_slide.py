"""How far a kick slid the robot, from a BNO08x's RVC reports alone: :class:`SlideWatch`.

A push (issue #36) is a kick — tens to hundreds of m/s² for a report or three — followed by
a *slide*: the body coasts on its wheels' grip, decelerated at about the traction's
``mu*g`` (7-8 m/s²) against the kick, until it moves with its wheels again. RVC mode gives
no linear velocity, but each report carries the horizontal acceleration (the device
mounted level: gravity on z alone), so the slide's deceleration ``a`` and its duration
``T`` (from the reports' indices: a lost report does not shorten it) give the slide's
length ``a*T**2/2``, and the kick's direction in the body frame gives where it went. The
estimate, which predicted the wheels' motion alone, is then moved by that much (session 7's
finding: the scans of ``overtaking`` cannot place a kicked robot, so without this the
estimate stayed 0.2 m off while the robot drove on).

The first reports after the kick are hidden under its peak (a report holds the largest
acceleration of the last 30 ms) and the slide's last value lingers as long; so ``T`` counts
from the kick's first report to the slide's last, less ``hold`` reports.

>>> w = SlideWatch()
>>> reports = [(0.0, 0.0)] * 3 + [(0.0, 170.0)] * 3 + [(0.0, -7.8)] * 21 + [(0.0, 0.0)] * 3
>>> out = [w.feed(i, ax, ay, 0.0) for i, (ax, ay) in enumerate(reports)]
>>> s = [o for o in out if o is not None][0]
>>> round(s.distance, 3), round(s.bearing, 3), s.stopped
(0.189, 1.571, False)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Slide", "SlideWatch"]


@dataclass(frozen=True)
class Slide:
    """A kick's slide as the IMU measured it. ``distance`` (m): how far the body slid beyond
    what its wheels drove; ``bearing`` (rad): the kick's direction in the body frame at the
    kick (0 ahead, counter-clockwise); ``turned`` (rad): the IMU's yaw change from the kick
    to the slide's end (so a consumer finds the heading the kick came at); ``duration`` (s);
    ``sd`` (m): how far the displacement may be off (one standard deviation); ``stopped``:
    the slide ended in a second shock (an obstacle stopped it: shorter than measured is
    possible, so ``sd`` is wider); ``peak`` (m/s²): the kick's."""

    distance: float
    bearing: float
    turned: float
    duration: float
    sd: float
    stopped: bool
    peak: float


class SlideWatch:
    """Fed every report in order (:meth:`feed`), returns a :class:`Slide` when one ends.

    ``kick`` (m/s²): a report at least this strong is a kick (as
    :class:`~clomp.runtime.estimation.doubt.Doubt`'s); ``least`` (m/s²): a slide's report
    is at least this strong and points against the kick; ``rate`` (Hz): the reports';
    ``hold``: reports a value lingers beyond its own (the device's 30 ms peak, less the
    report itself); ``share`` and ``floor`` (m): the displacement's sd, ``share`` of it
    plus ``floor`` (twice that after a stop); ``longest`` (s): a slide longer than this is
    not a kick's (given up, None); ``farthest`` (m): a slide measured longer than this is not
    believed (see :meth:`_end`)."""

    def __init__(self, *, kick: float = 30.0, least: float = 3.0, rate: float = 100.0, hold: int = 2,
                 share: float = 0.25, floor: float = 0.02, longest: float = 1.0, farthest: float = 0.8) -> None:
        self.kick, self.least, self.rate, self.hold = float(kick), float(least), float(rate), int(hold)
        self.share, self.floor, self.longest, self.farthest = float(share), float(floor), float(longest), float(farthest)
        self._index = 0  # the last report's index, unwrapped (a lost report leaves a gap)
        self._seen = False
        self._kick: tuple[int, float, float, float, float] | None = None  # (index, ax, ay, |a|, yaw)
        self._slide: list[tuple[int, float]] = []  # (index, |a|) of the slide's reports
        self._last_yaw = 0.0

    def feed(self, index: int, ax: float, ay: float, yaw: float) -> Slide | None:
        """One report: its index (0-255, wrapping), horizontal acceleration (m/s², body frame)
        and yaw (rad, continuous). The slide that ended with it, else None."""
        i = self._unwrap(index)
        a = math.hypot(ax, ay)
        self._last_yaw = yaw
        k = self._kick
        if k is None:
            if a >= self.kick:
                self._kick, self._slide = (i, ax, ay, a, yaw), []
            return None
        if a >= self.kick and not self._slide and i - k[0] <= self.hold:
            if a > k[3]:  # the kick's own reports: its largest
                self._kick = (k[0], ax, ay, a, k[4])
            return None
        against = ax * k[1] + ay * k[2] < 0.0
        if a >= self.kick and self._slide:  # a second shock ends it: an obstacle stopped the slide
            return self._end(stopped=True)
        if a >= self.least and against:
            self._slide.append((i, a))
            if (i - k[0]) / self.rate > self.longest:
                self._kick = None
            return None
        if i - k[0] <= self.hold:  # still under the kick's hold
            return None
        return self._end(stopped=False)

    def _unwrap(self, index: int) -> int:
        if not self._seen:
            self._seen, self._index = True, int(index)
            return self._index
        self._index += (int(index) - self._index) % 256
        return self._index

    def _end(self, stopped: bool) -> Slide | None:
        k, slide = self._kick, self._slide
        self._kick, self._slide = None, []
        if k is None or not slide:
            return None  # a shock with no slide after it (a collision, a bump): nothing measured
        accel = sorted(a for _i, a in slide)[len(slide) // 2]
        t = max(0.0, (slide[-1][0] - k[0] + 1 - self.hold) / self.rate)
        d = accel * t * t / 2.0
        sd = (self.share * d + self.floor) * (2.0 if stopped else 1.0)
        if d > self.farthest:
            # longer than a push slides a robot (#36: 0.1-0.5 m; beyond 0.8 m a kick of 3.5 m/s
            # at 7.8 m/s²): what held the acceleration against the kick was more than a coast
            # (a body dragging it, a long contact). Where it went is not known: the estimate is
            # not moved, its doubt opened by the whole length (over ptys, ``overtaking`` seed 7: a
            # 0.26 m push measured 1.32 m, the estimate moved by it, ended truly 0.55 m off)
            return Slide(0.0, math.atan2(k[2], k[1]), self._last_yaw - k[4], t, max(sd, d), stopped, k[3])
        return Slide(d, math.atan2(k[2], k[1]), self._last_yaw - k[4], t, sd, stopped, k[3])
