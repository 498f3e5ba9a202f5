"""The reference plan check: :func:`check_plan_reference`, the plain array form of
:func:`clomp.runtime.supervision.plancheck.check_plan`'s geometry.

It is the check as first written (the legs × points arrays of every remaining task at
once, on the scan's points near the plan's bounding box), kept unchanged so the tests can
hold the fast path of :mod:`clomp.runtime.supervision.plancheck` to it: both must give the same
verdict, reason and task on any scan (a Hypothesis test). The supervisor never calls it.

>>> from clomp.formal.model import Disturbance, State, TaskKind
>>> g = Disturbance.goal(1.0, 0.0)
>>> step = State(1, TaskKind.STRAIGHT, g, None, Pose(0.0, 0.0), Pose(0.5, 0.0), distance=0.5)
>>> o = Pose(0.0, 0.0, 0.0)
>>> wall = np.c_[np.full(21, 0.4), np.linspace(-0.2, 0.2, 21)]
>>> check_plan_reference([step], o, o, wall, RobotModel()).reason
'task 1 (STRAIGHT) now meets an obstacle after 0.29 of 0.50 m'
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np

from clomp.formal.geometry import relative
from clomp.formal.model import Pose, State, TaskKind
from clomp.planner.perception import Obstacles
from clomp.planner.robot_model import RobotModel
from clomp.runtime.supervision.checkgeometry import _ends_off, _Leg, _legs, _waived_turn
from clomp.runtime.supervision.plancheck import CheckResult, _verdict

__all__ = ["check_plan_reference"]


def check_plan_reference(states: list[State], origin: Pose, pose: Pose, seen: Obstacles | np.ndarray,
                         robot: RobotModel, *, tolerance: tuple[float, float] = (0.08, 0.3), running: bool = False,
                         allowance: float = 0.0) -> CheckResult:
    """:func:`clomp.runtime.supervision.plancheck.check_plan`'s verdict, computed the plain way."""
    t0 = time.perf_counter()
    if not states:
        return CheckResult(True, "nothing left to check", 0, time.perf_counter() - t0)
    legs = _legs(states, relative(pose, origin), running)
    live = [g for g in legs if g.amount > 1e-3]
    z = _near(_points(seen, robot), live, robot)
    blocked: dict[int, float] = {}
    if z.size:
        straights = [g for g in live if g.kind is TaskKind.STRAIGHT]
        if straights:
            for g, d in zip(straights, _straight_contacts(z, straights, robot, allowance)):
                if d < g.amount - tolerance[0]:
                    blocked[g.k] = d
        turns = [g for g in live if g.kind is not TaskKind.STRAIGHT and g.k < min(blocked, default=len(legs))]
        if turns:
            for g, turned in zip(turns, _turn_contacts(z, turns, robot, allowance)):
                if turned < g.amount - tolerance[1]:
                    blocked[g.k] = turned
    offs = [_ends_off(g, tolerance) if g.amount > 1e-3 else None for g in legs]
    return _verdict(legs, blocked, len(states), offs, t0)


@functools.lru_cache(maxsize=16)
def _swept_radius(robot: RobotModel) -> float:
    return robot.swept_radius


def _points(seen: Obstacles | np.ndarray, robot: RobotModel) -> np.ndarray:
    """The scan's points within the sensor's range as complex x + iy (robot frame now)."""
    if isinstance(seen, Obstacles):
        pts = seen.points
    else:
        pts = np.asarray(seen, dtype=float).reshape(-1, 2)
        r2 = pts[:, 0] * pts[:, 0] + pts[:, 1] * pts[:, 1]
        pts = pts[(r2 <= robot.sensor_range * robot.sensor_range) & (r2 > 1e-6)]
    z: np.ndarray = pts[:, 0] + 1j * pts[:, 1]
    return z


def _near(z: np.ndarray, legs: list[_Leg], robot: RobotModel) -> np.ndarray:
    """The points within the body's reach of the box spanned by the legs' starts and ends
    (the rest cannot touch it): the array operations after it see a fraction of the scan."""
    if not z.size or not legs:
        return z
    xs = [p[0] for g in legs for p in (g.start, g.reached)]
    ys = [p[1] for g in legs for p in (g.start, g.reached)]
    reach = _swept_radius(robot) + 0.01
    x, y = z.real, z.imag
    keep = (x >= min(xs) - reach) & (x <= max(xs) + reach) & (y >= min(ys) - reach) & (y <= max(ys) + reach)
    out: np.ndarray = z[keep]
    return out


def _straight_contacts(z: np.ndarray, legs: list[_Leg], robot: RobotModel, allowance: float) -> list[float]:
    """Per straight leg: how far the body drives before it meets a point (inf: never), to
    the last control tick before the contact, all legs in one array operation (the
    planner's rule, :mod:`clomp.planner.rollout`: the inflated footprint translated along the
    leg; a point already inside it at the start is held to the real body). ``allowance``
    (m) shrinks the body a point must enter to count (sensor noise)."""
    if not z.size:
        return [math.inf] * len(legs)
    a = np.array([complex(g.start[0], g.start[1]) for g in legs])
    e = np.exp(-1j * np.array([g.start[2] for g in legs]))
    w = (z[None, :] - a[:, None]) * e[:, None]  # legs × points: u + iv in each task's frame
    u, v = w.real, np.abs(w.imag)
    c = robot.clearance
    rear, front, half = robot.rear_offset + c, robot.front_offset + c, robot.width / 2 + c - allowance
    gap = np.where((v <= half) & (u >= -rear), u - (front - allowance), np.inf)
    d = gap.min(axis=1)
    if (d <= allowance).any():
        # inside the inflated footprint at the start: held to the real body (the
        # start-touching rule); strictly inside the real body, the robot's own returns
        rfront, rhalf = robot.front_offset - allowance, robot.width / 2 - allowance
        waived = gap <= allowance
        real = np.where(v < rhalf, u - rfront, np.inf)
        gap = np.where(waived, np.where(real >= allowance, real, np.inf), gap)
        d = gap.min(axis=1)
    per_tick = robot.straight_speed * robot.tick
    # the task ends at the last control tick before the contact, as the planner's rollout
    return [(max(math.ceil(x / per_tick - 1e-12), 1) - 1) * per_tick if math.isfinite(x) else math.inf for x in d.tolist()]


def _turn_contacts(z: np.ndarray, legs: list[_Leg], robot: RobotModel, allowance: float) -> list[float]:
    """Per turn leg: how far (rad) the inflated body turns in place before it meets a point
    (inf: never), tested at every tick heading as the planner's rollout does; all legs in
    one array operation (legs × tick headings × points)."""
    per_tick = robot.turn_rate * robot.tick
    ticks = [math.ceil(g.amount / per_tick - 1e-9) for g in legs]
    if not z.size or max(ticks) <= 0:
        return [math.inf] * len(legs)
    d = z[None, :] - np.array([complex(g.start[0], g.start[1]) for g in legs])[:, None]  # legs × points
    # past a leg's own last tick its heading stays at its end: a repeat, never an earlier contact
    steps = np.arange(max(ticks) + 1) * per_tick
    turned = [np.minimum(steps, g.amount) * (1.0 if g.kind is TaskKind.LEFT else -1.0) + g.start[2] for g in legs]
    w = d[:, None, :] * np.exp(-1j * np.array(turned))[:, :, None]  # legs × ticks × points, body frames
    c = robot.clearance
    rear, front, half = robot.rear_offset, robot.front_offset, robot.width / 2
    mid, length = (front - rear) / 2, (front + rear) / 2
    u, v = np.abs(w.real - mid), np.abs(w.imag)  # about the body's centre: one test per axis
    inside = (u <= length + c - allowance) & (v <= half + c - allowance)
    waived = inside[:, 0, :]
    if waived.any():
        real = (u <= length - allowance) & (v <= half - allowance)
        inside = np.where(waived[:, None, :], real, inside)
    # strictly inside the real body at the start: the robot's own returns, never a contact
    # (with an allowance above the clearance such a point need not be waived)
    inside &= ~((u[:, 0, :] < length) & (v[:, 0, :] < half))[:, None, :]
    hit = inside[:, 1:, :].any(axis=2)
    out = []
    for i, g in enumerate(legs):
        rows = np.flatnonzero(hit[i])
        k = int(rows[0]) + 1 if len(rows) else ticks[i] + 1  # the first tick in contact
        if waived[i].any():
            # a point within the margin is held to the real body with no margin for the
            # corner's path between ticks: tested at eight headings per tick, as the planner does
            sign = 1.0 if g.kind is TaskKind.LEFT else -1.0
            k = min(k, _waived_turn(d[i][waived[i]], g.start[2], sign, per_tick, g.amount, ticks[i], robot, allowance))
        out.append(math.inf if k > ticks[i] else min((k - 1) * per_tick, g.amount))  # the last tick heading before contact
    return out

