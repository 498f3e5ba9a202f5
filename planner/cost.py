"""The costs of the Configurator's best-first search: φ = γ + χ and what they read.

:class:`CostContext` is what a cost function may know besides the state (the goal, the
start, the robot); :func:`gamma` (the past cost of an interrupted task), :func:`chi` (the
heuristic future cost) and :func:`default_cost` (their sum) read only what a
:class:`Rollout` has, so the search prices a rollout before it builds the state.
Re-exported by :mod:`clomp.planner.configurator` and :mod:`clomp.planner`.

>>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
>>> default_cost(State(1, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.5, 0)), ctx)
0.3333333333333333
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from clomp.formal.model import Disturbance, Pose, State, TaskKind  # noqa: F401 - TaskKind: the doctests
from clomp.planner.robot_model import RobotModel

__all__ = ["CostContext", "CostFunction", "Rollout", "default_cost", "gamma", "chi"]


@dataclass(frozen=True)
class CostContext:
    """What a cost function may know besides the state: the goal, the start and the robot.

    >>> ctx = CostContext(Disturbance.goal(3.0, 4.0), Pose(0.0, 0.0), RobotModel())
    >>> ctx.start_distance
    5.0
    """

    goal: Disturbance
    origin: Pose
    robot: RobotModel

    @functools.cached_property
    def start_distance(self) -> float:
        """d0 = ‖D_G − start‖, the normaliser of χ (computed once per context)."""
        return self.origin.distance_to(self.goal.x, self.goal.y)


#: a cost function of the best-first search: (state, context) -> cost, lower explored first
CostFunction = Callable[[State, CostContext], float]


class Rollout(Protocol):
    """What γ and χ read of a state: where its task started and ended, and what
    interrupted it. A :class:`State` is one; so is the rollout a state is about to be
    built from (:class:`clomp.planner.engine.Outcome`), which lets the Configurator price
    a rollout with the very functions below before it builds the state.

    >>> from clomp.planner.engine import Outcome
    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> out = Outcome(TaskKind.STRAIGHT, Pose(0.0, 0.0), Pose(0.5, 0.0), 0.5, 2.5, 25, None, False)
    >>> default_cost(out, ctx) == default_cost(State(1, TaskKind.STRAIGHT, ctx.goal, None, out.start, out.end), ctx)
    True
    """

    @property
    def start(self) -> Pose: ...

    @property
    def end(self) -> Pose: ...

    @property
    def d_n(self) -> Disturbance | None: ...


def gamma(state: Rollout, ctx: CostContext) -> float:
    """γ(q), the past cost: 0 when the task was not interrupted; otherwise
    ``2 − min(d_N, r)/r`` ∈ [1, 2], with d_N the distance from the start of the task to
    the point where D_N interrupted it and r the sensor range (the paper's "normalised
    distance from the start of the task to D_N": the sooner the hit, the dearer).

    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> clear = State(1, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.27, 0))
    >>> gamma(clear, ctx)
    0.0
    >>> hit = State(2, TaskKind.STRAIGHT, ctx.goal, Disturbance.goal(0.0, 0.0), Pose(0, 0), Pose(0.0, 0))
    >>> gamma(hit, ctx)   # hit at once: the dearest
    2.0
    """
    if state.d_n is None:
        return 0.0
    r = ctx.robot.sensor_range
    d = state.start.distance_to(state.d_n.x, state.d_n.y)
    return 2.0 - min(d, r) / r


def chi(state: Rollout, ctx: CostContext) -> float:
    """χ(q), the heuristic future cost: ``d / (d + d0)`` ∈ [0, 1), with d the distance
    from the end of the task to D_G and d0 that from the start of planning: 0 at the
    goal, 1/2 where planning began, approaching 1 far away (normalised so that any
    uninterrupted state costs less than any interrupted one).

    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> far = State(1, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.0, 0))
    >>> near = State(2, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.9, 0))
    >>> chi(near, ctx) < chi(far, ctx)
    True
    """
    d = state.end.distance_to(ctx.goal.x, ctx.goal.y)
    d0 = ctx.start_distance
    return d / (d + d0) if d + d0 > 0 else 0.0


def default_cost(state: Rollout, ctx: CostContext) -> float:
    """φ(q) = γ(q) + χ(q) (Hart, Nilsson & Raphael 1968, in the paper's §2.2).

    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> q = State(1, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.5, 0))
    >>> default_cost(q, ctx) == gamma(q, ctx) + chi(q, ctx)
    True
    """
    return gamma(state, ctx) + chi(state, ctx)

