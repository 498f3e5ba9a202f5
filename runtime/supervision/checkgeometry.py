"""The plan check's closed-form geometry (:func:`clomp.runtime.supervision.plancheck.check_plan`):
the remaining tasks as legs chained from the robot's pose, the scan's points as complex
numbers, and where each leg's body first meets a point.

The planner's rule (:mod:`clomp.planner.rollout`): the footprint inflated by the robot's
``clearance``, translated along a straight or spun through every tick heading of a turn,
with the start-touching rule (a point already inside the inflated body at a task's start
is held to the real body). Each contact function tests all its legs on the raw points
in one compiled loop (:mod:`clomp.runtime.supervision._contacts_core`); the tests hold them
bit-equal to the reference check (``tests/runtime/_checkref.py``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Pose, State, TaskKind
from clomp.planner.footprint import body_box, inside
from clomp.planner.perception import Obstacles
from clomp.planner.robot_model import RobotModel
from clomp.runtime.jit import interruptible
from clomp.runtime.supervision._contacts_core import straight_gaps, turn_first_ticks

_STRAIGHT, _LEFT = TaskKind.STRAIGHT, TaskKind.LEFT  # looked up once: a member lookup is a descriptor call
_REVERSE, _WAIT = TaskKind.REVERSE, TaskKind.WAIT


class _Leg(NamedTuple):
    """One remaining task as the robot would run it now: from ``start`` (robot frame, x, y,
    theta), a straight of ``amount`` m or a turn of ``amount`` rad; ``end`` is the map's
    prediction and ``reached`` where it ends when run as planned from ``start``."""

    k: int
    kind: TaskKind
    start: tuple[float, float, float]
    amount: float
    end: tuple[float, float, float]
    reached: tuple[float, float, float]


def _legs(states: list[State], frame: Pose, running: bool) -> list[_Leg]:
    """The remaining tasks chained from the robot's pose (the origin of the robot frame):
    each starts where the previous one, run as planned, ends (plain floats: a check builds
    no pose objects)."""
    legs: list[_Leg] = []
    fx, fy, fth = frame.x, frame.y, frame.theta
    fc, fs = math.cos(fth), math.sin(fth)
    x = y = th = 0.0
    for k, q in enumerate(states):
        e = q.end
        end = (fx + fc * e.x - fs * e.y, fy + fs * e.x + fc * e.y, fth + e.theta)  # the map's end, robot frame
        c, sn = math.cos(th), math.sin(th)
        if q.task is _STRAIGHT or q.task is _REVERSE:
            if k == 0 and running:
                amount = ((end[0] - x) * c + (end[1] - y) * sn) * (1.0 if q.task is _STRAIGHT else -1.0)
            else:
                amount = math.hypot(e.x - q.start.x, e.y - q.start.y)
        elif q.task is _WAIT:
            amount = 0.0  # it stands where the map says
        else:
            amount = abs(wrap_angle(end[2] - th))
        if amount <= 1e-3:
            reached = end  # nothing left of it: the next task starts where the map says
        elif q.task is _STRAIGHT:
            reached = (x + c * amount, y + sn * amount, th)
        elif q.task is _REVERSE:  # backwards along the heading, checked against the points behind
            reached = (x - c * amount, y - sn * amount, th)
        else:
            reached = (x, y, th + (amount if q.task is _LEFT else -amount))
        legs.append(_Leg(k, q.task, (x, y, th), amount, end, reached))
        x, y, th = reached
    return legs


def _points(seen: Obstacles | np.ndarray, robot: RobotModel) -> np.ndarray:
    """The scan's points within the sensor's range as complex x + iy (robot frame now): a
    scan's N×2 floats read as N complex numbers, no arithmetic (equal to x + 1j * y up to
    the sign of a zero, which no test of the check sees)."""
    if isinstance(seen, Obstacles):
        pts = seen.points
        out: np.ndarray = pts[:, 0] + 1j * pts[:, 1]
        return out
    xy = np.ascontiguousarray(seen, dtype=float).reshape(-1, 2)
    z = xy.view(np.complex128).ravel()
    if not z.size:
        return z
    r2 = _SUM(xy * xy, axis=1)  # x * x + y * y
    if _MAX(r2) <= robot.sensor_range * robot.sensor_range and _MIN(r2) > 1e-6:  # the usual scan: all kept (a NaN: not)
        return z
    kept: np.ndarray = z[(r2 <= robot.sensor_range * robot.sensor_range) & (r2 > 1e-6)]
    return kept


# the ufuncs' own reductions: ndarray.min and np.min go through Python wrappers first
_SUM, _MIN, _MAX = np.add.reduce, np.minimum.reduce, np.maximum.reduce


def _straight_contacts(z: np.ndarray, legs: list[_Leg], robot: RobotModel, allowance: float,
                       backwards: bool = False) -> list[float]:
    """Per straight leg: how far the body drives before it meets a point (inf: never), to
    the last control tick before the contact (the planner's rule, :mod:`clomp.planner.rollout`:
    the inflated footprint translated along the leg; a point already inside it at the
    start is held to the real body). ``allowance`` (m) shrinks the body a point must
    enter to count (sensor noise). ``backwards``: REVERSE legs, the body driven rear first
    against the points behind it (the same test with the heading turned round and the
    body's front and rear swapped). The points are tested by a compiled loop
    (:func:`~clomp.runtime.supervision._contacts_core.straight_gaps`)."""
    c = robot.clearance
    ahead, behind = (robot.rear_offset, robot.front_offset) if backwards else (robot.front_offset, robot.rear_offset)
    rear, front, half = behind + c, ahead + c, robot.width / 2 + c - allowance
    sign = -1.0 if backwards else 1.0
    out = np.empty(len(legs))
    interruptible(straight_gaps, np.ascontiguousarray(z.real), np.ascontiguousarray(z.imag), np.array([g.start[0] for g in legs]),
                  np.array([g.start[1] for g in legs]), np.array([sign * math.cos(g.start[2]) for g in legs]),
                  np.array([sign * math.sin(g.start[2]) for g in legs]), rear, half, front - allowance, allowance,
                  ahead - allowance, robot.width / 2 - allowance, out)
    per_tick = robot.straight_speed * robot.tick
    # the task ends at the last control tick before the contact, as the planner's rollout
    return [(max(math.ceil(x / per_tick - 1e-12), 1) - 1) * per_tick if math.isfinite(x) else math.inf for x in out.tolist()]


def _turn_contacts(z: np.ndarray, legs: list[_Leg], robot: RobotModel, allowance: float) -> list[float]:
    """Per turn leg: how far (rad) the inflated body turns in place before it meets a point
    (inf: never), tested at every tick heading as the planner's rollout does (a compiled
    loop, :func:`~clomp.runtime.supervision._contacts_core.turn_first_ticks`); a point within the
    margin at the start is held to the real body, between ticks too (:func:`_waived_turn`)."""
    per_tick = robot.turn_rate * robot.tick
    ticks = [math.ceil(g.amount / per_tick - 1e-9) for g in legs]
    if max(ticks) <= 0:
        return [math.inf] * len(legs)
    n = len(legs)
    sign = [1.0 if g.kind is _LEFT else -1.0 for g in legs]
    c = robot.clearance
    rear, front, half = robot.rear_offset, robot.front_offset, robot.width / 2
    mid, length = (front - rear) / 2, (front + rear) / 2
    first, anyw, waived = np.empty(n, dtype=np.int64), np.empty(n, dtype=bool), np.empty((n, z.size), dtype=bool)
    interruptible(turn_first_ticks, np.ascontiguousarray(z.real), np.ascontiguousarray(z.imag), np.array([g.start[0] for g in legs]),
                     np.array([g.start[1] for g in legs]), np.array([g.start[2] for g in legs]), np.array(sign),
                     np.array([g.amount for g in legs]), np.array(ticks, dtype=np.int64), per_tick,
                     robot.swept_radius + 1e-6, mid, length + c - allowance, half + c - allowance, length - allowance,
                     half - allowance, length, half, first, anyw, waived)
    out = []
    for i, g in enumerate(legs):
        k = int(first[i])
        if anyw[i] and k > 1:
            # a point within the margin is held to the real body with no margin for the
            # corner's path between ticks: tested at eight headings per tick, as the planner
            # does (up to the tick before the contact found: only an earlier one matters)
            k = min(k, _waived_turn(z[waived[i]] - complex(g.start[0], g.start[1]), g.start[2], sign[i], per_tick,
                                    g.amount, min(ticks[i], k - 1), robot, allowance))
        out.append(math.inf if k > ticks[i] else min((k - 1) * per_tick, g.amount))  # the last tick heading before contact
    return out


def _waived_turn(d: np.ndarray, theta: float, sign: float, per_tick: float, e0: float, ticks: int,
                 robot: RobotModel, allowance: float) -> int:
    """The first tick at or after which the real body meets one of these points (complex,
    relative to the centre; strictly outside the body at the start), eight headings a tick,
    up to ``ticks`` (``ticks + 1``: none)."""
    fine = np.minimum(np.arange(1, 8 * ticks + 1) * (per_tick / 8), e0)
    w = d[None, :] * np.exp(-1j * (theta + sign * fine))[:, None]
    w0 = d * complex(math.cos(theta), -math.sin(theta))
    live = ~inside(w0.real, np.abs(w0.imag), body_box(robot), strict=True)
    hit = np.flatnonzero((inside(w.real, np.abs(w.imag), body_box(robot, -allowance)) & live).any(axis=1))
    return int(hit[0]) // 8 + 1 if len(hit) else ticks + 1


def _ends_off(g: _Leg, tolerance: tuple[float, float]) -> tuple[float, float] | None:
    """How far (m, rad) the leg run as planned ends from the map's prediction, when beyond ``tolerance``."""
    (rx, ry, rth), (ex, ey, eth) = g.reached, g.end
    d, a = math.hypot(rx - ex, ry - ey), abs(wrap_angle(rth - eth))
    return (d, a) if d > tolerance[0] or a > tolerance[1] else None
