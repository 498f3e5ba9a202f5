"""The world robot's dynamics: the wheel drive (latency, bias, per-tick error, acceleration
limit, slip, drift) and the body's contacts, as :mod:`clomp.runtime.backends.world` describes
them. A contact that begins ``_CONTACT_GAP`` s or more after the previous one ended is a new
collision.

>>> import numpy as np
>>> from clomp.planner.noise import NoiseTerms
>>> from clomp.runtime.backends._world_body import BodySpec
>>> d = Drive(NoiseTerms(), BodySpec(), np.random.default_rng(0), control_tick=0.1)
>>> d.command(0.0, (0.1, 0.1)); d.step(0.0, 0.05)      # the wheels ramp up at 1 m/s²
(0.05, 0.0)
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import pymunk

from clomp.planner.noise import NoiseTerms
from clomp.runtime.backends._world_body import BodySpec

__all__ = ["Contacts", "Drive", "WorldContact"]

_CONTACT_GAP = 0.5  # a contact beginning this long after the previous ended is a new collision


class Drive:
    """The wheels: latency, bias, per-tick error, acceleration limit, slip and drift (see the module).

    Draws from ``rng`` when built (each wheel's bias, then the drift) and at every control
    tick while it drives, in the order the world always drew them.
    """

    def __init__(self, noise: NoiseTerms, body: BodySpec, rng: np.random.Generator, *, control_tick: float) -> None:
        self.noise, self.body, self._rng, self.control_tick = noise, body, rng, control_tick
        bias = 1.0 + noise.wheel_bias * rng.standard_normal(2)
        self.drift = noise.drift * float(rng.standard_normal())
        self.bias = (float(bias[0]), float(bias[1]))
        self.commanded = (0.0, 0.0)
        self.wheels = (0.0, 0.0)
        self._pending: deque[tuple[float, tuple[float, float]]] = deque()
        self._applied = (0.0, 0.0)
        self._tick_err = (1.0, 1.0)
        self._tick_slip = (0.0, 0.0)
        self._next_draw = 0.0

    def command(self, t: float, cmd: tuple[float, float]) -> None:
        """Wheel speeds commanded at ``t``; they take effect after the latency."""
        self.commanded = cmd
        self._pending.append((t + self.noise.latency, cmd))

    def _draw(self, t: float) -> None:
        """A control tick's draws: each wheel's speed error and slip."""
        n = self.noise
        err = 1.0 + n.wheel_sd * self._rng.standard_normal(2) if n.wheel_sd else np.ones(2)
        slip = np.minimum(np.abs(n.slip * self._rng.standard_normal(2)), 0.9) if n.slip else np.zeros(2)
        self._tick_err = (float(err[0]), float(err[1]))
        self._tick_slip = (float(slip[0]), float(slip[1]))
        self._next_draw = t + self.control_tick

    def step(self, t: float, dt: float) -> tuple[float, float]:
        """The body's speed (m/s) and turn rate (rad/s) over the step from ``t`` to ``t + dt``."""
        while self._pending and self._pending[0][0] <= t + 1e-12:
            self._applied = self._pending.popleft()[1]
        if t >= self._next_draw - 1e-12:
            self._draw(t)
        # per wheel, in Python floats (the same IEEE operations as the arrays they replace, faster)
        (cl, cr), (bl, br) = self._applied, self.bias
        el, er = self._tick_err
        sl, sr = self._tick_slip
        wl, wr = self.wheels
        limit = self.body.wheel_accel * dt
        tl = cl * bl * el if cl != 0.0 else 0.0
        tr = cr * br * er if cr != 0.0 else 0.0
        wl = wl + min(max(tl - wl, -limit), limit)
        wr = wr + min(max(tr - wr, -limit), limit)
        self.wheels = (wl, wr)
        gl, gr = wl * (1.0 - sl), wr * (1.0 - sr)
        v = (gl + gr) / 2
        w = (gr - gl) / self.body.wheel_base
        if wl != 0.0 or wr != 0.0:
            w += self.drift
        return v, w


@dataclass(frozen=True, slots=True)
class WorldContact:
    """One counted collision: when (simulated s) and where (world frame) it began.

    >>> WorldContact(1.5, 0.2, 0.0).time
    1.5
    """

    time: float
    x: float
    y: float


class Contacts:
    """The body's contacts with the obstacles: the trace, the collisions counted, whether
    it touches now (see the module)."""

    def __init__(self) -> None:
        self.collisions = 0
        self.contacts: list[WorldContact] = []
        self.trace: list[tuple[float, float]] = []
        self.touching = False
        self._ended = -math.inf

    def update(self, t: float, body: pymunk.Body) -> None:
        """Record the step ending at ``t``: the deepest penetration and a new collision."""
        deepest = -1.0
        where: tuple[float, float] | None = None

        def visit(arb: pymunk.Arbiter) -> None:
            nonlocal deepest, where
            for p in arb.contact_point_set.points:
                if -p.distance > deepest:
                    deepest = -p.distance
                    where = (float(p.point_a.x), float(p.point_a.y))

        body.each_arbiter(visit)
        if where is not None:
            self.trace.append((t, max(0.0, deepest)))
            if not self.touching and t - self._ended >= _CONTACT_GAP:
                self.collisions += 1
                self.contacts.append(WorldContact(t, *where))
            self.touching = True
        elif self.touching:
            self.touching = False
            self._ended = t
