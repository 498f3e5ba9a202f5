"""The supervisor's records: plans, tasks, checks/recalls/fresh plans and the report, and
the hazard geometry (which scan points the body's remaining motion sweeps).

Kept apart from :mod:`clomp.runtime.supervision.supervisor`, which re-exports the records.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from clomp.formal.geometry import compose, points_from_frame, relative
from clomp.formal.model import Pose, State, TaskKind
from clomp.planner.configurator import PlanResult
from clomp.planner.footprint import body_box, inside_at
from clomp.planner.robot_model import RobotModel
from clomp.runtime.estimation.odometry import FeedbackRecord
from clomp.runtime.supervision.states import SupervisorState, TransitionRecord

__all__ = ["PlanRecord", "SupervisorReport", "TaskRecord", "TimedRecord", "hits", "scan_to_frame", "sweep"]

S = SupervisorState


def scan_to_frame(points: np.ndarray, source: Pose, target: Pose) -> np.ndarray:
    """Points in the frame of a robot at ``source`` → the frame of a robot at ``target``."""
    if len(points) == 0:
        return points
    return points_from_frame(points, relative(target, source))


# -- records ------------------------------------------------------------------------------
@dataclass(frozen=True)
class PlanRecord:
    """One plan: when, from which pose estimate (the planner frame's origin), and what."""

    time: float
    origin: Pose
    result: PlanResult
    recalled: bool = False

    def to_frame(self, p: Pose) -> Pose:
        """A pose of the plan (planner frame) in the supervisor's frame."""
        return compose(self.origin, p)


@dataclass
class TaskRecord:
    """One task the supervisor started: its plan step, the guard's verdict and its run."""

    plan_index: int
    state: State
    transition: tuple[int, int]
    psi: int
    start_time: float
    start_pose: Pose
    predicted_end: Pose
    end_time: float | None = None
    end_pose: Pose | None = None
    outcome: str = "running"


@dataclass(frozen=True)
class TimedRecord:
    """One plan check, recall or fresh plan: when (s), how long it took (s, wall clock), its
    verdict and why, and the thread CPU time it took (s; on a loaded machine the wall clock
    also counts the time other processes had the core)."""

    time: float
    duration_s: float
    ok: bool
    reason: str
    cpu_s: float = 0.0


@dataclass
class SupervisorReport:
    """The outcome of :meth:`Supervisor.run`.

    ``feedback``: one record per revolution of what scan matching did to the estimate;
    ``checks``, ``recalls``, ``fresh_plans``: every plan check, recall attempt and fresh
    plan, with when (s since start) and how long it took (s). ``goal_distance``,
    ``goal_bound`` (m): at the end, when the estimate put the robot at the goal, how far
    from it the estimate was and the 95 % bound of its position
    (:meth:`~clomp.runtime.supervision.sensing.Sensing.position_bound`).

    >>> SupervisorReport(SupervisorState.HALTED, "LiDAR unplugged", 1.5, [], [], [], [], (1.0, 0.0)).reached_goal
    False
    """

    state: SupervisorState
    reason: str
    time_s: float
    plans: list[PlanRecord]
    tasks: list[TaskRecord]
    transitions: list[TransitionRecord]
    trajectory: list[tuple[float, float, float, float]]
    goal: tuple[float, float]
    feedback: list[FeedbackRecord] = dataclasses.field(default_factory=list)
    checks: list[TimedRecord] = dataclasses.field(default_factory=list)
    recalls: list[TimedRecord] = dataclasses.field(default_factory=list)
    fresh_plans: list[TimedRecord] = dataclasses.field(default_factory=list)
    goal_distance: float | None = None
    goal_bound: float | None = None

    @property
    def reached_goal(self) -> bool:
        """True when the supervisor ended in GOAL_REACHED."""
        return self.state is S.GOAL_REACHED

    @property
    def replans(self) -> int:
        """Plans made after the first."""
        return max(0, len(self.plans) - 1)



def sweep(kind: TaskKind, amount: float) -> np.ndarray:
    """Sample poses (x, y, theta; current robot frame) of the remaining motion of a task (a
    REVERSE's backwards, a WAIT's where the body stands)."""
    if kind is TaskKind.WAIT:
        amount = 0.0
    if not kind.is_turn:
        n = max(2, int(math.ceil(amount / 0.02)) + 1)
        out = np.zeros((n, 3))  # filled column by column: np.c_ cost more than the values (issue #41)
        out[:, 0] = np.linspace(0.0, max(amount, 0.0), n) * (-1.0 if kind is TaskKind.REVERSE else 1.0)
        return out
    n = max(2, int(math.ceil(amount / math.radians(5))) + 1)
    out = np.zeros((n, 3))
    out[:, 2] = np.linspace(0.0, max(amount, 0.0), n) * (1 if kind is TaskKind.LEFT else -1)
    return out


def hits(points: np.ndarray, poses: np.ndarray, m: RobotModel, allowance: float = 0.0) -> int:
    """How many points lie inside the (uninflated) body at any of ``poses``, more than
    ``allowance`` (m) inside its outline."""
    met = np.zeros(len(points), dtype=bool)
    box = body_box(m, -allowance)
    for x, y, th in poses:
        met |= inside_at(points, (x, y, th), box)
    return int(met.sum())
