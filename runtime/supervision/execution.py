"""One task of a plan on the robot: the closed loop started from the map's state, and the
judgement of where it ended (see :mod:`clomp.runtime.supervision.supervisor`).

A task may start only over a transition of the map that the guard Ψ enables
(:func:`guard`); it then runs as :class:`clomp.planner.tasks.Task` from the pose estimate
(:func:`task_for`), and a task that ends farther than the tolerance from the map's
prediction is a disagreement (:func:`end_error`).

>>> from clomp.formal.model import Pose
>>> end_error(Pose(0.0, 0.0, 0.0), Pose(0.1, 0.0, 0.0), (0.08, 0.3))
'0.100 m, 0° off'
"""

from __future__ import annotations

import math

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Disturbance, Pose, State, TaskKind
from clomp.planner.configurator import PlanResult
from clomp.planner.robot_model import RobotModel
from clomp.planner.rollout import make_task
from clomp.planner.tasks import Task

__all__ = ["GuardViolation", "end_error", "guard", "jumped", "task_for"]


class GuardViolation(RuntimeError):
    """A task was about to start over a transition the guard Ψ does not enable.

    >>> isinstance(GuardViolation("Ψ = 0"), RuntimeError)
    True
    """


def guard(result: PlanResult, step: tuple[int, int]) -> int:
    """Ψ of the map's transition ``step`` (source, target); GuardViolation unless it is 1.

    >>> from clomp.planner import Configurator, load_scenario
    >>> scene = load_scenario("open")
    >>> result = Configurator().plan(scene.scan(), scene.goal_in_robot_frame())
    >>> s = result.plan.states
    >>> guard(result, (s[0], s[1]))
    1
    """
    psi = max((v for t, v in result.psi.items() if (t.source, t.target) == step), default=0)
    if psi != 1:
        raise GuardViolation(f"Ψ(q{step[0]} ↪ q{step[1]}) = {psi}: the plan does not enable this task")
    return psi


def task_for(q: State, result: PlanResult, predicted_end: Pose, model: RobotModel, pose: Pose, goal: Pose,
             wait: float = 5.0) -> Task:
    """The closed loop that runs the map's state ``q`` from the estimate ``pose`` (``goal`` and
    ``predicted_end``, where the map says the task ends, in the supervisor's frame).

    A STRAIGHT drives what the map planned: a straight cut at the rim of the sensed disc (a
    frontier) must not run on into unseen space. A turn turns to the predicted heading. A
    REVERSE backs off what the map planned; a WAIT stands at most ``wait`` s (the supervisor
    ends it sooner, :mod:`clomp.runtime.supervision.moving`).

    >>> from clomp.planner import Configurator, load_scenario
    >>> scene = load_scenario("open")
    >>> result = Configurator().plan(scene.scan(), scene.goal_in_robot_frame())
    >>> q = result.map[result.plan.states[1]]
    >>> task_for(q, result, q.end, RobotModel(), Pose(0.0, 0.0, 0.0), Pose(*scene.goal_in_robot_frame())).kind == q.task
    True
    """
    goal_d = Disturbance.goal(goal.x, goal.y)
    if q.task is TaskKind.WAIT:
        return Task.wait(model, pose, goal_d, wait)
    if q.task is TaskKind.REVERSE:
        return Task.reverse(model, pose, goal_d, q.distance)
    if q.task is TaskKind.STRAIGHT:
        limit = q.distance if q.distance > 0 else make_task(q.task, result.obstacles, model, q.start, result.goal).limit
        return Task.straight(model, pose, goal_d, limit)
    turn = wrap_angle(predicted_end.theta - pose.theta)
    angle = turn if q.task is TaskKind.LEFT else -turn
    if angle < -math.pi / 2:  # wrapped: a turn of nearly pi
        angle += 2 * math.pi
    return Task.turn(model, q.task, pose, goal_d, min(max(angle, 0.0), math.pi))


def end_error(pose: Pose, predicted: Pose, tolerance: tuple[float, float]) -> str | None:
    """How far a task that ended at ``pose`` is off the map's ``predicted`` end, when farther
    than ``tolerance`` (m, rad); None within it.

    >>> end_error(Pose(0.0, 0.0, 0.0), Pose(0.05, 0.0, 0.1), (0.08, 0.3)) is None
    True
    """
    off = _beyond(pose, predicted, tolerance)
    return None if off is None else f"{off} off"


def jumped(before: Pose, after: Pose, limit: tuple[float, float]) -> str | None:
    """How far one revolution moved the estimate from ``before`` to ``after`` (the same
    instant: the wheels did not do it), when farther than ``limit`` (m, rad); None within it.
    A task set from ``before`` would drive the rest of its length from the wrong place.

    >>> jumped(Pose(0.0, 0.0, 0.0), Pose(0.12, 0.0, 0.0), (0.05, 0.1))
    '0.120 m, 0°'
    >>> jumped(Pose(0.0, 0.0, 0.0), Pose(0.02, 0.01, 0.02), (0.05, 0.1)) is None
    True
    """
    return _beyond(before, after, limit)


def _beyond(a: Pose, b: Pose, limit: tuple[float, float]) -> str | None:
    """``"D m, A°"``: how far apart ``a`` and ``b`` are, when farther than ``limit`` (m, rad)."""
    d = a.distance_to(b.x, b.y)
    turn = abs(wrap_angle(b.theta - a.theta))
    if d > limit[0] or turn > limit[1]:
        return f"{d:.3f} m, {math.degrees(turn):.0f}°"
    return None
