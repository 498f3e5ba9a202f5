"""The vocabulary of the cognitive map: tasks, disturbances, poses and states.

These are plain frozen (hashable) records with no physics in them, so that the formal
layer can reason about a map without importing the planner's engine.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, fields
from typing import Any

__all__ = [
    "TaskKind",
    "PAPER_TASKS",
    "DisturbanceKind",
    "Pose",
    "Disturbance",
    "State",
    "new_pose",
    "new_state",
]


class TaskKind(str, enum.Enum):
    """The task space **T**: the three closed-loop controllers of the paper, and the two a
    world that moves needs (issue #42): WAIT (stand still, watching, until the way ahead
    clears or a time-out; its disturbance is something that moves) and REVERSE (back off a
    short straight distance, checked against the scan behind). Maps of static worlds hold
    only the paper's three (:data:`PAPER_TASKS`).

    >>> TaskKind.LEFT.is_turn, TaskKind("STRAIGHT") is TaskKind.STRAIGHT, TaskKind.WAIT.is_turn
    (True, True, False)
    """

    STRAIGHT = "STRAIGHT"
    LEFT = "LEFT"
    RIGHT = "RIGHT"
    WAIT = "WAIT"
    REVERSE = "REVERSE"

    @property
    def is_turn(self) -> bool:
        """True for LEFT and RIGHT (turns in place)."""
        return self is TaskKind.LEFT or self is TaskKind.RIGHT


PAPER_TASKS: tuple[TaskKind, ...] = (TaskKind.STRAIGHT, TaskKind.LEFT, TaskKind.RIGHT)
"""The paper's task space: the tasks of every map of a static world."""


class DisturbanceKind(str, enum.Enum):
    """What a disturbance is: the goal D_G or an obstacle.

    >>> Disturbance.goal(1.0, 0.0).kind is DisturbanceKind.GOAL
    True
    """

    GOAL = "GOAL"
    OBSTACLE = "OBSTACLE"


@dataclass(frozen=True, slots=True)
class Pose:
    """A planar pose (x, y, theta) in metres and radians, theta in (-pi, pi].

    >>> Pose(0.0, 0.0).distance_to(3.0, 4.0)
    5.0
    >>> Pose.from_list(Pose(1.0, 2.0, 0.5).as_list())
    Pose(x=1.0, y=2.0, theta=0.5)
    """

    x: float
    y: float
    theta: float = 0.0

    def __post_init__(self) -> None:
        # one test per coordinate, no generator: poses are built in the planner's hot path
        isfinite = math.isfinite
        if not (isfinite(self.x) and isfinite(self.y) and isfinite(self.theta)):
            raise _pose_error(self.x, self.y, self.theta)

    def distance_to(self, x: float, y: float) -> float:
        """Euclidean distance from this pose's position to the point (x, y)."""
        return math.hypot(x - self.x, y - self.y)

    def as_list(self) -> list[float]:
        """``[x, y, theta]``, the JSON form."""
        return [self.x, self.y, self.theta]

    @classmethod
    def from_list(cls, values: Any) -> "Pose":
        """Inverse of :meth:`as_list`."""
        x, y, theta = (float(v) for v in values)
        return cls(x, y, theta)


@dataclass(frozen=True, slots=True)
class Disturbance:
    """A disturbance D: the goal, or an obstacle the robot's sensors see.

    ``x, y`` is its reference point in the planning frame (the robot frame at q0): the
    goal's position, or for an obstacle the point where it was hit (D_N) or the centre
    of the shape. ``vertices`` is the obstacle's outline (a convex polygon), empty for
    a point-like disturbance such as the goal. ``ident`` names the obstacle so that two
    states interrupted by the same object can be told apart from two different ones.

    >>> g = Disturbance.goal(1.0, 0.5)
    >>> g.kind.value, g.x, g.y
    ('GOAL', 1.0, 0.5)
    """

    kind: DisturbanceKind
    x: float
    y: float
    vertices: tuple[tuple[float, float], ...] = ()
    ident: int = -1

    def __post_init__(self) -> None:
        if not (math.isfinite(self.x) and math.isfinite(self.y)):
            raise ValueError(f"disturbance position must be finite, got ({self.x}, {self.y})")

    @classmethod
    def goal(cls, x: float, y: float) -> "Disturbance":
        """The goal disturbance D_G at (x, y)."""
        return cls(DisturbanceKind.GOAL, float(x), float(y))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (lossless)."""
        return {
            "kind": self.kind.value,
            "x": self.x,
            "y": self.y,
            "vertices": [list(v) for v in self.vertices],
            "ident": self.ident,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "Disturbance":
        """Inverse of :meth:`to_dict`."""
        return cls(
            DisturbanceKind(data["kind"]),
            float(data["x"]),
            float(data["y"]),
            tuple((float(a), float(b)) for a, b in data.get("vertices", ())),
            int(data.get("ident", -1)),
        )


@dataclass(frozen=True, slots=True)
class State:
    """A state q = (T, D) of the cognitive map, with its simulated outcome.

    ``task`` is T; ``d_i`` the disturbance the task is contingent on (D_I, set by the
    reset R); ``d_n`` the disturbance that interrupted it (D_N), ``None`` when the task
    ended by its own criterion. ``start``/``end`` are the simulated poses, ``distance``
    the path length driven (metres), ``duration`` the simulated time (seconds), ``cost``
    the value of phi = gamma + chi the Configurator assigned, and ``reached_goal``
    whether the task ended within the goal tolerance. ``ident`` is the order of
    creation (the subscript of q in the paper); q0 has ident 0.

    >>> g = Disturbance.goal(1.0, 0.0)
    >>> q = State(1, TaskKind.STRAIGHT, g, None, Pose(0.0, 0.0), Pose(0.27, 0.0), distance=0.27)
    >>> q.interrupted, q.end.x
    (False, 0.27)
    """

    ident: int
    task: TaskKind
    d_i: Disturbance | None
    d_n: Disturbance | None
    start: Pose
    end: Pose
    distance: float = 0.0
    duration: float = 0.0
    cost: float = 0.0
    reached_goal: bool = False
    extra: tuple[tuple[str, float], ...] = field(default=(), compare=True)

    @property
    def interrupted(self) -> bool:
        """True when D_N is not empty: the task was cut short by a disturbance."""
        return self.d_n is not None

    @property
    def label(self) -> str:
        """A short human label, e.g. ``q3:RIGHT``."""
        return f"q{self.ident}:{self.task.value}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (lossless: floats are written with repr precision)."""
        return {
            "id": self.ident,
            "task": self.task.value,
            "d_i": None if self.d_i is None else self.d_i.to_dict(),
            "d_n": None if self.d_n is None else self.d_n.to_dict(),
            "start": self.start.as_list(),
            "end": self.end.as_list(),
            "distance": self.distance,
            "duration": self.duration,
            "cost": self.cost,
            "reached_goal": self.reached_goal,
            "extra": {k: v for k, v in self.extra},
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "State":
        """Inverse of :meth:`to_dict`."""
        return cls(
            ident=int(data["id"]),
            task=TaskKind(data["task"]),
            d_i=None if data.get("d_i") is None else Disturbance.from_dict(data["d_i"]),
            d_n=None if data.get("d_n") is None else Disturbance.from_dict(data["d_n"]),
            start=Pose.from_list(data["start"]),
            end=Pose.from_list(data["end"]),
            distance=float(data.get("distance", 0.0)),
            duration=float(data.get("duration", 0.0)),
            cost=float(data.get("cost", 0.0)),
            reached_goal=bool(data.get("reached_goal", False)),
            extra=tuple(sorted((str(k), float(v)) for k, v in data.get("extra", {}).items())),
        )


def _pose_error(x: float, y: float, theta: float) -> ValueError:
    return ValueError(f"pose must be finite, got ({x}, {y}, {theta})")


_new = object.__new__  # a record without its __init__: the setters below fill every slot
_set_x, _set_y, _set_theta = (Pose.__dict__[name].__set__ for name in ("x", "y", "theta"))
_isfinite = math.isfinite


def new_pose(x: float, y: float, theta: float) -> Pose:
    """``Pose(x, y, theta)`` built through the slots' setters, with the same check that
    every coordinate is finite: the same record at half the cost (the rollouts build one
    per task).

    >>> new_pose(0.1, 0.2, 0.3) == Pose(0.1, 0.2, 0.3)
    True
    >>> new_pose(0.0, float("nan"), 0.0)
    Traceback (most recent call last):
    ...
    ValueError: pose must be finite, got (0.0, nan, 0.0)
    """
    if not (_isfinite(x) and _isfinite(y) and _isfinite(theta)):
        raise _pose_error(x, y, theta)
    p: Pose = _new(Pose)
    _set_x(p, x)
    _set_y(p, y)
    _set_theta(p, theta)
    return p


# the slots' own setters, in field order: :func:`new_state` builds a State with them
_STATE_FIELDS = ("ident", "task", "d_i", "d_n", "start", "end", "distance", "duration", "cost", "reached_goal", "extra")
if tuple(f.name for f in fields(State)) != _STATE_FIELDS:  # pragma: no cover - a guard for whoever edits State
    raise ImportError("clomp.formal.model: new_state() names State's fields in another order than State has them")
(_set_ident, _set_task, _set_d_i, _set_d_n, _set_start, _set_end, _set_distance, _set_duration, _set_cost,
 _set_reached_goal, _set_extra) = (State.__dict__[name].__set__ for name in _STATE_FIELDS)


def new_state(
    ident: int,
    task: TaskKind,
    d_i: Disturbance | None,
    d_n: Disturbance | None,
    start: Pose,
    end: Pose,
    distance: float,
    duration: float,
    cost: float,
    reached_goal: bool,
    extra: tuple[tuple[str, float], ...],
) -> State:
    """``State(...)`` with every field given, built through the slots' setters: the same
    record at 40 % of the cost (a frozen dataclass's ``__init__`` sets each of the eleven
    fields through ``object.__setattr__``; the Configurator builds a state per rollout).

    >>> g = Disturbance.goal(1.0, 0.0)
    >>> args = (1, TaskKind.STRAIGHT, g, None, Pose(0.0, 0.0), Pose(0.27, 0.0), 0.27, 2.7, 0.4, False, ())
    >>> new_state(*args) == State(*args)
    True
    """
    s: State = _new(State)
    _set_ident(s, ident)
    _set_task(s, task)
    _set_d_i(s, d_i)
    _set_d_n(s, d_n)
    _set_start(s, start)
    _set_end(s, end)
    _set_distance(s, distance)
    _set_duration(s, duration)
    _set_cost(s, cost)
    _set_reached_goal(s, reached_goal)
    _set_extra(s, extra)
    return s

