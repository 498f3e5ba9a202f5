"""The world robot's rate gyro: the body's true turn rate, measured as a MEMS gyro does.

The paper's robot measured its rotation while driving (the average horizontal optic flow
of its camera, the error signal of its straight task); a yaw-rate gyro is the usual
sensor for the same quantity. Per run the gyro draws a scale error (``rate_scale``,
relative) and a zero-rate offset (``rate_bias``, rad/s); every physics step it adds white
noise of ``rate_sd`` rad/√s (angle random walk). It integrates what it measures, so a
reader sees the heading turned since start-up, as a gyro driver reports it.

The scale error is the IMU's: a constant gain, which the estimator learns as one of its
states. ``rate_asymmetry`` is one it does not model: per run the gain turning clockwise
differs from the gain turning counter-clockwise by ``rate_asymmetry`` × N(0, 1) (a MEMS
gyro's scale-factor asymmetry), so no one gain fits both directions.

Its draws come from a generator of their own (seeded from the run's seed), so the
drive's and the LiDAR's draws are the same with and without it; the asymmetry is drawn
from another (so the other terms' draws are the same with and without it).

>>> g = RateGyro(sd=0.0, bias=0.0, scale=0.0, seed=0)
>>> for _ in range(100):
...     g.step(0.5, 0.01)                  # 1 s at 0.5 rad/s
>>> round(g.angle, 6)
0.5
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["RateGyro", "ShockSensor", "WINDOW"]

_BLOCK = 1024  # white-noise draws taken at once (one draw per physics step)
WINDOW = 0.01
"""Seconds an acceleration *vector* (:meth:`ShockSensor.read_vector`) is averaged over: one
physics step of the execution world, one 100 Hz report of a BNO08x."""


class RateGyro:
    """A yaw-rate gyro with a per-run scale error and offset and white noise (see the module)."""

    def __init__(self, *, sd: float, bias: float, scale: float, seed: int | None, asymmetry: float = 0.0) -> None:
        self._rng = np.random.default_rng(None if seed is None else [int(seed), 0x6779726F])
        self.sd = float(sd)
        self.offset = float(bias) * float(self._rng.standard_normal())
        self.gain = 1.0 + float(scale) * float(self._rng.standard_normal())
        self.asymmetry = 0.0  # the counter-clockwise gain less the clockwise one, relative
        if asymmetry:
            rng = np.random.default_rng(None if seed is None else [int(seed), 0x61737931])  # its own stream
            self.asymmetry = float(asymmetry) * float(rng.standard_normal())
        # the gains turning counter-clockwise and clockwise (both ``gain`` without asymmetry)
        self._ccw = self.gain * (1.0 + self.asymmetry / 2) if self.asymmetry else self.gain
        self._cw = self.gain * (1.0 - self.asymmetry / 2) if self.asymmetry else self.gain
        self.angle = 0.0
        self._noise = np.zeros(0)
        self._k = 0

    def step(self, rate: float, dt: float) -> None:
        """Integrate over ``dt`` s while the body turns at ``rate`` rad/s (the truth)."""
        walk = 0.0
        if self.sd:
            if self._k >= len(self._noise):
                self._noise, self._k = self._rng.standard_normal(_BLOCK), 0
            walk = self.sd * math.sqrt(dt) * float(self._noise[self._k])
            self._k += 1
        self.angle += ((self._ccw if rate > 0 else self._cw) * rate + self.offset) * dt + walk


class ShockSensor:
    """The IMU's accelerometer read as a shock sensor: the largest horizontal acceleration of
    the body (m/s², the change of its velocity over a physics step) since the last
    :meth:`read`, plus the sensor's noise (``sd`` × |N(0, 1)|, from a stream of its own).

    A differential drive accelerates its body at most at its wheels' limit (1 m/s²) plus
    the centripetal v·ω; a kick, a collision or a body that stops dead while its wheels spin
    (a slip event) shows as several times that (docs/closed-loop.md, *Shocks*).

    >>> s = ShockSensor(sd=0.0, seed=0)
    >>> s.step((0.0, 0.0), (0.01, 0.0), 0.01); s.step((0.01, 0.0), (1.01, 0.0), 0.01)
    >>> s.read(), s.read()                  # a kick of 1 m/s within a step, then nothing
    (100.0, 0.0)
    """

    def __init__(self, *, sd: float, seed: int | None) -> None:
        self._rng = np.random.default_rng(None if seed is None else [int(seed), 0x73686B])  # "shk": its own stream
        self.sd = float(sd)
        self.peak = 0.0
        self._vector = (0.0, 0.0)  # the largest acceleration since read_vector (world frame, m/s²)
        self._vector_peak = 0.0
        self._window: tuple[float, float] | None = None  # the velocity the averaging window began with
        self._window_dt = 0.0

    def step(self, before: tuple[float, float], after: tuple[float, float], dt: float) -> None:
        """The body's velocity (world frame, m/s) went from ``before`` to ``after`` over ``dt`` s."""
        ax, ay = (after[0] - before[0]) / dt, (after[1] - before[1]) / dt
        a = math.hypot(after[0] - before[0], after[1] - before[1]) / dt
        if a > self.peak:
            self.peak = a
        # the vector: averaged over at least WINDOW s, as a report's accelerometer reading is:
        # a world advanced in slivers (an emulator catching up 2 ms at a time) must not divide
        # a velocity step by a sliver's length
        start = before if self._window is None else self._window
        self._window_dt += dt
        if self._window_dt >= WINDOW - 1e-12:
            ax, ay = (after[0] - start[0]) / self._window_dt, (after[1] - start[1]) / self._window_dt
            a = math.hypot(ax, ay)
            if a > self._vector_peak:
                self._vector, self._vector_peak = (ax, ay), a
            self._window, self._window_dt = None, 0.0
        else:
            self._window = start

    def read(self) -> float:
        """The peak since the last read (m/s²), and start a new one."""
        out = self.peak + (self.sd * abs(float(self._rng.standard_normal())) if self.sd else 0.0)
        self.peak = 0.0
        return round(out, 6)

    def read_vector(self) -> tuple[float, float]:
        """The largest acceleration since the last call as a vector (world frame, m/s², no
        noise), each averaged over :data:`WINDOW` s of steps (one physics step of the world;
        one 100 Hz report), and start a new one; apart from :meth:`read`, so an emulated IMU
        and the world's own reader do not take each other's peaks.

        >>> s = ShockSensor(sd=0.0, seed=0)
        >>> s.step((0.0, 0.0), (0.0, -0.5), 0.01); s.read_vector(), s.read_vector()
        ((0.0, -50.0), (0.0, 0.0))
        >>> for _ in range(5): s.step((0.0, 0.0), (0.0, 0.0), 0.001)     # half a window: nothing yet
        >>> s.step((0.0, 0.0), (0.01, 0.0), 0.001); s.read_vector()       # a step of 1 cm/s in a sliver
        (0.0, 0.0)
        >>> for _ in range(4): s.step((0.01, 0.0), (0.01, 0.0), 0.001)
        >>> [round(v, 6) for v in s.read_vector()]                        # over the window: 1 m/s², not 10
        [1.0, 0.0]
        """
        out, self._vector, self._vector_peak = self._vector, (0.0, 0.0), 0.0
        return out
