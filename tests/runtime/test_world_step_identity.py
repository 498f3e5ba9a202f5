"""Issue #41's cheaper physics step holds the world bit for bit.

The step reads the body's pose and velocity from chipmunk directly and steps the space
without pymunk's wrapper when nothing is queued (:mod:`clomp.runtime.backends._pymunk_fast`),
reads the body's pose once after pymunk's step, a static world's contacts are
recorded without building a closure each step, and the LiDAR draws a step's beam and range
noise in one call. A world built with frozen copies of the code they replaced
(:class:`_FrozenWorld`) must give the same trajectory, revolutions, gyro, shocks and
contacts, in a static world and one with movers, at every noise preset.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pymunk
import pytest

from clomp.planner.scenarios import load_scenario
from clomp.runtime.backends import _dynamics, _lidar, world
from clomp.runtime.backends.world import WorldRobot, _to_robot, make_world_robot
from clomp.runtime.devices.frame import ScanFrame


def _frozen_advance(self: WorldRobot, dt: float) -> None:
    """WorldRobot._advance as it was before issue #41's step."""
    if self._t >= self._next_push:
        self._random_push()
    v, w = self._drive.step(self._t, dt)
    body, control = self._body, self._control
    th = body.angle
    world._set_velocity(control, (v * math.cos(th), v * math.sin(th)))
    world._set_angular_velocity(control, w)
    world._set_position(control, body.position)
    if self.movers is not None:
        self.movers.step(self._t, dt, self._xyth(), self.body.front_offset, (v * math.cos(th), v * math.sin(th), w))
    self._space.step(dt)
    if self._gyro is not None:
        self._gyro.step((body.angle - th) / dt, dt)
    if self._shock is not None:
        vel = body.velocity
        after = (float(vel.x), float(vel.y))
        self._shock.step(self._velocity, after, dt)
        self._velocity = after
    self._t += dt
    _frozen_contacts_update(self._contacts, self._t, body, self.movers)
    pose = self._xyth()
    self.trajectory.append((self._t, *pose))
    frame = self._lidar.step(self._t, pose)
    if frame is not None:
        if self.told_mount != (0.0, 0.0, 0.0):
            frame = ScanFrame(_to_robot(frame.points, self.told_mount), frame.timestamp, point_times=frame.point_times)
        self._latest, self._delivered = frame, False


def _frozen_contacts_update(self: _dynamics.Contacts, t: float, body: pymunk.Body, movers: Any = None) -> None:
    """Contacts.update as it was before issue #41's static fast path."""
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
    if movers is not None:
        if split["static"] >= -0.5:
            self.static_trace.append((t, max(0.0, split["static"])))
        if split["moving"] >= -0.5:
            self.moving_trace.append((t, max(0.0, split["moving"]), caused))
    if where is not None:
        self.trace.append((t, max(0.0, deepest)))
        if not self.touching and t - self._ended >= _dynamics._CONTACT_GAP:
            self.collisions += 1
            self.contacts.append(_dynamics.WorldContact(t, *where))
        self.touching = True
    elif self.touching:
        self.touching = False
        self._ended = t


def _frozen_measure(self: _lidar.Lidar, i0: int, i1: int, t: float, pose: tuple[float, float, float]) -> None:
    """Lidar._measure as it was before issue #41 (three draws a step)."""
    n, k = self.noise, i1 - i0
    angle = self._rng.standard_normal(k) if n.angle_sd else None
    x, y, th = self.origin(pose)
    rng = self._rng.standard_normal(k) if n.range_sd else None
    drop = self._rng.random(k) if n.dropout else None
    if self.streaming is None:
        self._raw.append((x, y, th, k, angle, rng, drop, t))
        return
    nominal = self.angles[i0:i1]
    beam = nominal + n.angle_sd * angle if angle is not None else nominal
    noise = n.range_sd * rng if rng is not None else None
    kept = drop >= n.dropout if drop is not None else None
    batch: tuple[Any, ...] = (x, y, th + beam, nominal, noise, kept, t)
    dist = self.cast_at(x, y, th + beam, t)
    if noise is not None:
        dist = dist + noise
    self.streaming.append((nominal, np.where(self._returned(dist, kept), dist, np.inf), t, i0 == 0))
    self._pending.append(batch + (dist,))


class _FrozenLidar(_lidar.Lidar):
    _measure = _frozen_measure


def _frozen_xyth(self: WorldRobot) -> tuple[float, float, float]:
    """WorldRobot._xyth as it was before issue #41 (pymunk's properties, not chipmunk's reads)."""
    p = self._body.position
    return float(p.x), float(p.y), float(self._body.angle)


class _FrozenWorld(WorldRobot):
    _advance = _frozen_advance
    _xyth = _frozen_xyth


def _drive(w: WorldRobot, stream: bool) -> list[Any]:
    """Drive ``w`` into the overtaking layout's obstacle and about; everything it reports."""
    out: list[Any] = []
    for k in range(60):
        w.set_wheel_speeds(0.12, 0.12) if k < 40 else w.set_wheel_speeds(-0.08, 0.08)
        w.sleep(0.1)
        frame = w.read_scan(timeout=0.0)
        if frame is not None:
            times = frame.point_times
            out.append((frame.timestamp, frame.points.tobytes(), None if times is None else times.tobytes()))
        out.append((w.rotation(), w.peak_acceleration(), w.peak_acceleration_vector()))
        if stream and k >= 20:
            out.append([(a.tobytes(), r.tobytes(), t, first) for a, r, t, first in w.stream()])
    return out + [w.trajectory, w.contact_traces(), w.contacts, w.collisions, w.pushes]


@pytest.mark.parametrize("noise", ["ideal", "paper", "harsh"])
@pytest.mark.parametrize("moving", [False, True])
def test_the_world_steps_as_before_bit_for_bit(noise: str, moving: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    movers = [{"kind": "person", "path": [[0.0, 0.9, -0.5], [4.0, 0.9, 0.5]], "stays": False}] if moving else None
    scene = load_scenario("overtaking")
    reports = []
    for frozen in (False, True):
        if frozen:
            monkeypatch.setattr(world, "Lidar", _FrozenLidar)
        cls = _FrozenWorld if frozen else WorldRobot
        w = cls(scene, noise=world.WorldNoise.preset(noise), seed=7, movers=movers)
        reports.append(_drive(w, stream=moving))
    assert reports[0] == reports[1]
    assert reports[0][-2] >= 1 or moving  # the run meets the obstacle: contacts are compared, not only their absence


def test_the_world_the_test_drives_meets_its_obstacle() -> None:
    w = make_world_robot(load_scenario("overtaking"), "paper", seed=7)
    assert _drive(w, stream=False)[-2] >= 1
