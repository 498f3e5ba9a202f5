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
from clomp.runtime.backends._movers import Movers
from clomp.runtime.backends._world_body import BodySpec

__all__ = ["Contacts", "Drive", "WorldContact", "WorldPush", "push_speed", "term_stream"]

_CONTACT_GAP = 0.5  # a contact beginning this long after the previous ended is a new collision


def term_stream(seed: int | None, term: str) -> np.random.Generator:
    """The random generator of one noise term the estimator does not model: seeded from the
    run's ``seed`` and the term's name, apart from every other draw of the world (fresh
    entropy when ``seed`` is None).

    >>> float(term_stream(0, "push_rate").random()) == float(term_stream(0, "push_rate").random())
    True
    """
    key = int.from_bytes(term.encode()[:8].ljust(8, b"\0"), "little")
    return np.random.default_rng(None if seed is None else [int(seed), key])


class Drive:
    """The wheels: latency, bias, per-tick error, acceleration limit, slip and drift (see the module).

    Draws from ``rng`` when built (each wheel's bias, then the drift) and at every control
    tick while it drives, in the order the world always drew them. The terms the estimator
    does not model draw from ``extra`` (a generator of their own, so the others' draws are
    the same with and without them), every control tick: the bias's random walk
    (``bias_walk``, relative per √s; the bias stays within 0.5–1.5) and, while the wheels are
    commanded, the start of a slip event (``slip_rate`` a second): for ``slip_duration`` s
    the wheels spin and the body does not move (recorded in :attr:`slips`). Each of the two
    draws from its own stream (:func:`term_stream` of ``seed``).
    """

    def __init__(self, noise: NoiseTerms, body: BodySpec, rng: np.random.Generator, *, control_tick: float,
                 seed: int | None = None) -> None:
        self.noise, self.body, self._rng, self.control_tick = noise, body, rng, control_tick
        bias = 1.0 + noise.wheel_bias * rng.standard_normal(2)
        self.drift = noise.drift * float(rng.standard_normal())
        self.bias = (float(bias[0]), float(bias[1]))
        self._walk = term_stream(seed, "bias_walk")
        self._slip = term_stream(seed, "slip_rate")
        self.slips: list[tuple[float, float]] = []  # (start, end) s of each slip event
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
        if n.bias_walk or n.slip_rate:
            self._unmodelled(t)

    def _unmodelled(self, t: float) -> None:
        """A control tick's draws of the terms the estimator does not model (see the class)."""
        n, tick = self.noise, self.control_tick
        if n.bias_walk:
            step = n.bias_walk * math.sqrt(tick) * self._walk.standard_normal(2)
            self.bias = (min(max(self.bias[0] + float(step[0]), 0.5), 1.5),
                         min(max(self.bias[1] + float(step[1]), 0.5), 1.5))
        if n.slip_rate and self._applied != (0.0, 0.0) and not self.slipping(t):
            if self._slip.random() < -math.expm1(-n.slip_rate * tick):
                self.slips.append((t, t + n.slip_duration))

    def slipping(self, t: float) -> bool:
        """Whether a slip event holds the body at ``t``."""
        return bool(self.slips) and self.slips[-1][0] <= t < self.slips[-1][1]

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
        if self.slips and self.slipping(t):
            return 0.0, 0.0  # the wheels spin on the spot: no grip
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


@dataclass(frozen=True, slots=True)
class WorldPush:
    """One external push: when (simulated s), how far it slides the body (m, on open floor)
    and which way (rad, world frame).

    >>> WorldPush(3.0, 0.2, 0.0).distance
    0.2
    """

    time: float
    distance: float
    direction: float


def push_speed(distance: float, body: BodySpec) -> float:
    """The kick (m/s) that slides the body ``distance`` m before its wheels' grip (traction
    ``mu·g``) stops it.

    >>> round(push_speed(0.2, BodySpec()), 3)
    1.772
    """
    return math.sqrt(2.0 * body.traction * 9.81 * max(0.0, distance))


class Contacts:
    """The body's contacts with the obstacles: the trace, the collisions counted, whether
    it touches now (see the module)."""

    def __init__(self) -> None:
        self.collisions = 0
        self.contacts: list[WorldContact] = []
        self.trace: list[tuple[float, float]] = []
        self.touching = False
        self._ended = -math.inf
        # with moving bodies (issue #42): the samples apart, static and moving; a moving
        # sample carries who hit whom (True: the robot drove into the body)
        self.static_trace: list[tuple[float, float]] = []
        self.moving_trace: list[tuple[float, float, bool]] = []
        self._deepest: float = -1.0  # the step being recorded (a static world's): its deepest contact
        self._where: tuple[float, float] | None = None

    def update(self, t: float, body: pymunk.Body, movers: Movers | None = None) -> None:
        """Record the step ending at ``t``: the deepest penetration and a new collision
        (with ``movers``, the static and the moving contacts apart as well)."""
        if movers is None:  # every step of a static world: no closure and no split to build
            self._deepest, self._where = -1.0, None
            body.each_arbiter(self._visit)
            self._count(t, self._deepest, self._where)
            return
        deepest = -1.0
        where: tuple[float, float] | None = None
        split = {"static": -1.0, "moving": -1.0}
        caused = False

        def visit(arb: pymunk.Arbiter) -> None:
            nonlocal deepest, where, caused
            for p in arb.contact_point_set.points:
                if -p.distance > deepest:
                    deepest = -p.distance
                    where = (float(p.point_a.x), float(p.point_a.y))
            if movers is not None and arb.contact_point_set.points:
                d = max(-p.distance for p in arb.contact_point_set.points)
                who = movers.robot_caused(arb, body)
                key = "static" if who is None else "moving"
                split[key] = max(split[key], d)
                caused = caused or bool(who)

        body.each_arbiter(visit)
        if split["static"] >= -0.5:
            self.static_trace.append((t, max(0.0, split["static"])))
        if split["moving"] >= -0.5:
            self.moving_trace.append((t, max(0.0, split["moving"]), caused))
        self._count(t, deepest, where)

    def _visit(self, arb: pymunk.Arbiter) -> None:
        """The deepest contact point of the step so far, and where (a static world's step)."""
        for p in arb.contact_point_set.points:
            if -p.distance > self._deepest:
                self._deepest = -p.distance
                self._where = (float(p.point_a.x), float(p.point_a.y))

    def _count(self, t: float, deepest: float, where: tuple[float, float] | None) -> None:
        """The step's trace sample and a new collision, from its deepest contact (``where``: None, none)."""
        if where is not None:
            self.trace.append((t, max(0.0, deepest)))
            if not self.touching and t - self._ended >= _CONTACT_GAP:
                self.collisions += 1
                self.contacts.append(WorldContact(t, *where))
            self.touching = True
        elif self.touching:
            self.touching = False
            self._ended = t
