"""A rollout's footprint tested a block of ticks at a time: the same outcome, cheaper.

The engine's tick loop (:meth:`clomp.planner.engine.World.rollout`) tests the footprint
against the sensed points after every tick, one small numpy call per tick: in a robust
run (30 noisy rollouts per choice at every plan) that test was the largest single cost.
The motion of a task does not depend on the test (it only stops the task), so
:func:`rollout_in_blocks` steps a block of ticks first and tests the block's poses in
one call (:func:`clomp.formal.geometry.points_to_frames`), keeping the poses before the
first tick that touches. A noisy task draws its wheels' errors from the world's
generator at every tick; the draws of the ticks after a contact are given back (the
generator is set back and the ticks up to the contact drawn again), so the generator
leaves the rollout exactly as after the engine's loop and the next rollout draws the
same numbers. The outcome is bit-identical to the engine's
(``tests/planner/test_tick_blocks.py``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from clomp.formal.geometry import arc_step, points_to_frames, wheel_twist, wrap_angle
from clomp.formal.model import Disturbance, Pose
from clomp.planner.engine import Outcome, World, _obstacle_disturbance
from clomp.planner.footprint import inside
from clomp.planner.tasks import Task

__all__ = ["BLOCK", "rollout_in_blocks"]

BLOCK = 48
"""Ticks stepped before one test of the footprint (a straight of the planner's length is
about this many ticks at the robot's speed)."""


def rollout_in_blocks(task: Task, world: World, block: int = BLOCK) -> Outcome:
    """``world.rollout(task)``, bit for bit (the outcome, the body placed where the task
    stopped, and the state of ``task.rng`` afterwards, if the task has one), with the
    footprint tested ``block`` ticks at a time.

    >>> from clomp.planner.perception import perceive
    >>> from clomp.planner.robot_model import RobotModel
    >>> robot = RobotModel()
    >>> w = World(perceive(np.array([[0.5, 0.0], [0.5, 0.02]])), robot)
    >>> t = Task.straight(robot, Pose(0.0, 0.0, 0.0), None, 0.6)
    >>> rollout_in_blocks(t, w) == w.rollout(t)
    True
    """
    r = task.robot
    dt, b = r.tick, r.wheel_base
    x, y, th = task.start.x, task.start.y, task.start.theta
    check = world.point_check(task.start)
    rng: Any = getattr(task, "rng", None)
    predraw = rng is not None and hasattr(task, "predraw")
    limit = task.max_ticks()
    ticks, distance = 0, 0.0
    d_n: Disturbance | None = None
    ended = False
    while not ended and d_n is None and ticks < limit:
        if predraw:
            task.predraw(min(block, limit - ticks))  # type: ignore[attr-defined]
        xs: list[float] = []
        ys: list[float] = []
        ths: list[float] = []
        vs: list[float] = []
        errs: list[float] = []
        state = rng.bit_generator.state if rng is not None and not predraw else None
        cx, cy, cth = x, y, th
        while len(xs) < block and ticks + len(xs) < limit:
            e = task.error_at(cx, cy, cth)
            if task.done(e):
                ended = True
                break
            v, w = wheel_twist(*task.wheel_speeds(e), b)
            cx, cy, cth = arc_step(cx, cy, cth, v, w, dt)
            xs.append(cx)
            ys.append(cy)
            ths.append(cth)
            vs.append(v)
            errs.append(e)
        n = len(xs)
        good = n
        if n and len(check.points):
            good, d_n = _first_contact(check, world, xs, ys, ths)
        for v in vs[:good]:
            distance += abs(v) * dt
        if good:
            x, y, th = xs[good - 1], ys[good - 1], ths[good - 1]
        ticks += good
        if predraw:  # the draws of the ticks not driven (after the contact, after the end) given back
            task.settle(good + 1 if d_n is not None else n)  # type: ignore[attr-defined]
        elif d_n is not None and good + 1 < n and rng is not None:
            rng.bit_generator.state = state  # give back the draws of the ticks after the contact
            for e in errs[: good + 1]:
                task.wheel_speeds(e)
    pose = Pose(x, y, wrap_angle(th)) if ticks else task.start
    world.place(pose)
    return Outcome(task.kind, task.start, pose, distance, ticks * dt, ticks, d_n, False)


def _first_contact(
    check: Any, world: World, xs: list[float], ys: list[float], ths: list[float]
) -> tuple[int, Disturbance | None]:
    """(index of the first pose whose footprint meets a point, its D_N), or (len(xs), None):
    the engine's per-tick test (``_PointCheck.hit``) over a block of poses."""
    u, v = points_to_frames(check.points, xs, ys, ths)
    v = np.abs(v)
    met = np.where(check.waived, inside(u, v, world.real), inside(u, v, world.infl)) & ~check.exempt
    rows = met.any(axis=1)
    if not rows.any():
        return len(xs), None
    i = int(np.argmax(rows))
    j = int(np.argmax(met[i]))
    k = int(check.idx[j])
    pts = check.points
    return i, _obstacle_disturbance(world.obstacles, (int(world.owner[k]), float(pts[j, 0]), float(pts[j, 1])))
