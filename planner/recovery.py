"""WAIT and REVERSE in the Configurator's search (issue #42): their rollouts and when they are offered.

A world that moves needs two tasks beyond the paper's three. Both are offered only when
needed (``Configurator(recovery=True)``; off by default, so maps of static worlds are the
paper's), and both are ordinary states of the cognitive map: labelled transitions, Ψ and R
as for any task, exported with their labels.

- **REVERSE** backs the body off :data:`REVERSE_STEP` m along its heading, checked against
  the points *behind* it (the A1 sees all round): the inflated footprint translated
  backwards, cut at the last control tick before it meets a point (D_N names the point's
  box), as a STRAIGHT is cut ahead. It is offered from a state none of whose forward or
  turn expansions is collision-free (a blocked robot backs off and goes round), never right
  after another REVERSE, and not when its end would leave the sensed disc.
- **WAIT** stands still: its rollout ends where it started after :data:`WAIT_TIME` s. It is
  offered from the planning origin when the scan holds points that appeared where the
  previous scans saw free space (``transient``: possibly moving, handed over by the
  supervisor): the states after it are simulated in the world *without* those points (the
  way is expected to clear), the states of the other branches in the world with them.
  Its φ is 0, so the search looks past the wait before it looks for a detour; the
  supervisor runs the WAIT until the way ahead clears or its time-out, and plans round
  what stayed (then no longer transient).

>>> from clomp.planner import Configurator
>>> from clomp.planner.robot_model import RobotModel
>>> from clomp.planner.perception import perceive
>>> box = np.array([[0.14, y] for y in np.linspace(-0.08, 0.08, 9)])   # a box 5 cm ahead of the front
>>> out = simulate_reverse(Pose(0.0, 0.0, 0.0), Disturbance.goal(1.0, 0.0), perceive(box), RobotModel())
>>> out.task.value, round(out.end.x, 2), out.d_n is None
('REVERSE', -0.15, True)
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from clomp.formal.model import Disturbance, DisturbanceKind, Pose, State, TaskKind
from clomp.planner.engine import Outcome
from clomp.planner.perception import Obstacles
from clomp.planner.robot_model import RobotModel

if TYPE_CHECKING:  # pragma: no cover
    from clomp.planner._search import _Search

__all__ = ["REVERSE_STEP", "WAIT_TIME", "RECOVERY_TASKS", "simulate_reverse", "simulate_wait", "cleared_points",
           "noisy_recovery", "after_wait"]

REVERSE_STEP = 0.15
"""How far (m) a REVERSE backs off: room for the body's front to turn clear of what is ahead
(the front corners swing 0.13 m round the rotation centre, the rear ones 0.22 m)."""
WAIT_TIME = 2.0
"""A WAIT's duration in the planner's rollout (s); the supervisor waits up to its own time-out."""
RECOVERY_TASKS = (TaskKind.WAIT, TaskKind.REVERSE)
"""The tasks a moving world adds to the paper's three."""


def simulate_wait(start: Pose, goal: Disturbance | None, robot: RobotModel, duration: float = WAIT_TIME) -> Outcome:
    """A WAIT's rollout: the body stands ``duration`` s where it is.

    >>> simulate_wait(Pose(0.0, 0.0, 0.0), None, RobotModel()).duration
    2.0
    """
    ticks = int(math.ceil(duration / robot.tick - 1e-9))
    reached = goal is not None and start.distance_to(goal.x, goal.y) <= robot.goal_tolerance
    return Outcome(TaskKind.WAIT, start, start, 0.0, ticks * robot.tick, ticks, None, reached)


def simulate_reverse(start: Pose, goal: Disturbance | None, obstacles: Obstacles, robot: RobotModel,
                     distance: float = REVERSE_STEP) -> Outcome | None:
    """A REVERSE's rollout (see the module): the body backs off ``distance`` m, cut at the
    last control tick before its inflated footprint meets a point behind it (a point already
    within the margin waives it: the real body decides); None when its end would leave the
    sensed disc (not available).

    >>> from clomp.planner.perception import perceive
    >>> wall = np.array([[-0.25, y] for y in np.linspace(-0.2, 0.2, 21)])  # 7 cm behind the rear
    >>> out = simulate_reverse(Pose(0.0, 0.0, 0.0), None, perceive(wall), RobotModel())
    >>> out.collided, round(out.distance, 2)
    (True, 0.06)
    """
    c, s = math.cos(start.theta), math.sin(start.theta)
    rear, half, margin = robot.rear_offset, robot.width / 2, robot.clearance
    gap, hit = math.inf, -1
    pts = obstacles.points
    if len(pts):
        dx, dy = pts[:, 0] - start.x, pts[:, 1] - start.y
        u, v = dx * c + dy * s, dy * c - dx * s
        lane = (np.abs(v) <= half + margin) & (u < -rear)
        if lane.any():
            k = int(np.flatnonzero(lane)[np.argmax(u[lane])])
            gap = -rear - float(u[k])
            if gap > margin:
                gap -= margin
            hit = k
    step = robot.straight_speed * robot.tick
    # the gap in whole ticks (a gap within rounding of a tick counts as the tick); a cut that
    # still allows the whole distance is no cut
    ticked = max(0.0, math.floor(gap / step + 1e-9) * step) if gap < distance else distance
    if ticked >= distance:
        travelled, d_n = distance, None
    else:
        travelled = ticked
        i = int(obstacles.owner[hit])
        d_n = Disturbance(DisturbanceKind.OBSTACLE, float(pts[hit, 0]), float(pts[hit, 1]), obstacles.outline(i), i)
    end = Pose(start.x - c * travelled, start.y - s * travelled, start.theta)
    r2 = robot.sensor_range * robot.sensor_range
    for a, b in robot.corners:
        x, y = end.x + a * c - b * s, end.y + a * s + b * c
        if x * x + y * y > r2:
            return None
    ticks = int(math.ceil(travelled / step - 1e-9))
    reached = d_n is None and goal is not None and end.distance_to(goal.x, goal.y) <= robot.goal_tolerance
    return Outcome(TaskKind.REVERSE, start, end, travelled, ticks * robot.tick, ticks, d_n, reached)


def cleared_points(points: np.ndarray, transient: np.ndarray | None) -> np.ndarray | None:
    """``points`` without the ``transient`` ones (a boolean mask over them): the world after a
    WAIT; None when nothing is transient (no WAIT offered).

    >>> cleared_points(np.array([[1.0, 0.0], [0.5, 0.0]]), np.array([False, True])).tolist()
    [[1.0, 0.0]]
    >>> cleared_points(np.zeros((2, 2)), np.array([False, False])) is None
    True
    """
    if transient is None:
        return None
    mask = np.asarray(transient, dtype=bool)
    if mask.shape != (len(points),) or not mask.any():
        return None
    kept: np.ndarray = np.asarray(points)[~mask]
    return kept


def noisy_recovery(kind: TaskKind, start: Pose, goal: Disturbance | None, obstacles: Obstacles, robot: RobotModel,
                   rng: np.random.Generator, straight_sd: float = 0.0, straight_mean: float = 0.0,
                   distance: float | None = None) -> Outcome:
    """One noisy rollout of a WAIT or a REVERSE for the probabilistic map
    (:func:`clomp.planner.probabilistic.sample_map`), among a noisy world's ``obstacles``: a
    WAIT stands (no noise moves a robot whose wheels are stopped); a REVERSE backs off the
    planned ``distance`` (default :data:`REVERSE_STEP`) off by the straight's relative error
    (``straight_mean`` + N(0, ``straight_sd``), as a STRAIGHT's length), cut by what is behind
    it in that world. A REVERSE whose end would leave the sensed disc stands (its rollout
    is not available there: the robot does not move).

    >>> import numpy as np
    >>> from clomp.planner.perception import perceive
    >>> out = noisy_recovery(TaskKind.REVERSE, Pose(0.0, 0.0, 0.0), None, perceive(np.zeros((0, 2))), RobotModel(),
    ...                      np.random.default_rng(0), straight_sd=0.05)
    >>> out.task.value, -0.17 < out.end.x < -0.13
    ('REVERSE', True)
    """
    if kind is TaskKind.WAIT:
        return simulate_wait(start, goal, robot)
    length = REVERSE_STEP if distance is None else distance
    if straight_sd or straight_mean:
        length *= 1 + straight_mean + (float(rng.normal(0.0, straight_sd)) if straight_sd else 0.0)
    out = simulate_reverse(start, goal, obstacles, robot, max(length, 0.0))
    return out if out is not None else Outcome(TaskKind.REVERSE, start, start, 0.0, 0.0, 0, None, False)


def after_wait(cmap: Any) -> set[int]:
    """The states of ``cmap`` the search simulated in the world after a WAIT: the WAIT
    states' descendants (a WAIT is offered from the origin only, and the states after it
    are never shared with the others: :class:`Recovery`).

    >>> from clomp.formal.lts import CognitiveMap
    >>> after_wait(CognitiveMap())
    set()
    """
    out: set[int] = set()
    todo = [t.target for t in cmap.transitions() if t.label is TaskKind.WAIT]
    while todo:
        q = todo.pop()
        if q in out:
            continue
        out.add(q)
        todo += [t.target for t in cmap.out_transitions(q)]
    return out


class Recovery:
    """The WAIT/REVERSE part of one search (:class:`clomp.planner._search._Search`): the
    world after a WAIT (``cleared``, None when nothing is transient) and the states in it."""

    def __init__(self, cleared: Obstacles | None) -> None:
        self.cleared = cleared
        self.worlds: dict[Any, Any] = {}
        self.after_wait: set[int] = set()

    def world(self, search: "_Search", parent: State) -> tuple[Obstacles, dict[Any, Any], bool]:
        """The obstacles a child of ``parent`` is simulated among, their rollout cache, and
        whether that is the world after a WAIT."""
        if self.cleared is not None and parent.ident in self.after_wait:
            return self.cleared, self.worlds, True
        return search.obstacles, search.worlds, False

    def outcome(self, kind: TaskKind, start: Pose, d_i: Disturbance | None, obstacles: Obstacles,
                robot: RobotModel) -> Outcome | None:
        """The rollout of a WAIT or a REVERSE (None: not available)."""
        if kind is TaskKind.WAIT:
            return simulate_wait(start, d_i, robot)
        return simulate_reverse(start, d_i, obstacles, robot)

    def expand(self, search: "_Search", qe: State, free: bool) -> str | None:
        """After the paper's options from ``qe``: a WAIT from the origin when something is
        transient, a REVERSE when no option was collision-free; ``budget`` or ``goal`` when
        the search ends here (as :meth:`_Search._expand`)."""
        kinds = []
        if qe.ident == 0 and self.cleared is not None:
            kinds.append(TaskKind.WAIT)
        if not free and qe.task is not TaskKind.REVERSE:
            kinds.append(TaskKind.REVERSE)
        for kind in kinds:
            if len(search.cmap) + 1 > search.max_states:
                return "budget"
            child, fresh = search._child(qe, kind)
            if child is None:
                continue
            if kind is TaskKind.WAIT or qe.ident in self.after_wait:
                self.after_wait.add(child.ident)
            if child.reached_goal:
                search.goal_ids.add(child.ident)
                if search.ends + len(search.goal_ids) >= search.routes:
                    return "goal"
                continue
            if fresh and child.ident not in search.frontier_ids:
                search.push(child)  # an interrupted REVERSE too: its φ (γ ≥ 1) ranks it
        return None
