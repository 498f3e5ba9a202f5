"""The robot model: its body, speeds and task parameters, defaults from the paper's robot.

:class:`Body` is the one body type: its dimensions are declared here only. The planner's
:class:`RobotModel` is a body with speeds and task parameters; the execution world's
``BodySpec`` (:mod:`clomp.runtime.backends.world`) is a body with its drive's physics, built
from a model's body by default. A world body that differs from the planner's belief is
another instance of the same type.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace
from typing import Any, ClassVar

__all__ = ["Body", "RobotModel"]


#: the LiDAR's maximum range by default (m): an RPLIDAR A1's
_MAX_RANGE = 12.0


def _check_positive(owner: str, name: str, v: Any) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise ValueError(f"{owner}.{name} must be a positive finite number, got {v!r}")


@dataclass(frozen=True)
class Body:
    """A differential-drive robot's body (SI units; the paper's robot by default).

    The body is a ``length`` × ``width`` rectangle; the wheel axle, the rotation centre and
    the LiDAR (the robot frame's origin) sit ``front_offset`` behind the front edge; the
    wheels are ``wheel_base`` apart. A subclass adds fields; every field must be a
    positive finite number except those it names in ``_CHECKS_ITSELF``.

    >>> Body().corners[1], round(Body(width=0.2).body_radius, 3)
    ((0.09, -0.09), 0.206)
    """

    length: float = 0.27
    width: float = 0.18
    front_offset: float = 0.09
    wheel_base: float = 0.15

    _CHECKS_ITSELF: ClassVar[frozenset[str]] = frozenset()

    def __post_init__(self) -> None:
        owner = type(self).__name__
        for f in fields(self):
            if f.name not in self._CHECKS_ITSELF:
                _check_positive(owner, f.name, getattr(self, f.name))
        if self.front_offset >= self.length:
            raise ValueError(f"{owner}.front_offset must be smaller than the body length")

    @property
    def body(self) -> "Body":
        """The body alone (its dimensions, without what a subclass adds)."""
        return Body(**{f.name: getattr(self, f.name) for f in fields(Body)})

    @property
    def rear_offset(self) -> float:
        """Distance from the rotation centre to the rear edge."""
        return self.length - self.front_offset

    # derived once per body (the dataclass is frozen: a cached value never goes stale)
    @functools.cached_property
    def corners(self) -> tuple[tuple[float, float], ...]:
        """The real body's outline in the robot frame (no clearance), counter-clockwise."""
        h = self.width / 2
        return ((-self.rear_offset, -h), (self.front_offset, -h), (self.front_offset, h), (-self.rear_offset, h))

    @functools.cached_property
    def body_radius(self) -> float:
        """The distance from the rotation centre to the real body's farthest corner."""
        return max(math.hypot(a, b) for a, b in self.corners)


@dataclass(frozen=True)
class RobotModel(Body):
    """A differential-drive robot and the parameters of its tasks.

    All units SI. It is a :class:`Body` (``length``, ``width``, ``front_offset``,
    ``wheel_base``) with its speeds and tasks. Defaults are the paper's robot (DESIGN.md). ``clearance`` is the margin
    the planner keeps between the body and a sensed point. With ``free_turns`` a turn
    ends where its error is zero (facing the goal, or where the way ahead is clear, see
    :func:`clomp.planner.rollout.turn_angle`) and a step ends early where the body could no
    longer spin in place; without, every turn turns ``turn_angle`` and every step is
    ``step_length`` long (the authors' planner).

    Two ranges, one of them the planner's (issue #39): ``sensor_range`` is the **planning
    horizon**, the radius of the sensed disc round the planning origin within which the
    planner uses returns and keeps the body (1.1 m, the paper's); :attr:`planning_horizon`
    reads the same number. Its name is kept because code, ROS parameters (``sensor_range``)
    and written maps (``metadata.robot.sensor_range``) already mean the horizon by it, as
    they did when the paper's sensor was cropped there. ``max_range`` is the LiDAR's own
    maximum range (12 m, an RPLIDAR A1's): the returns between the two are normal and
    cropped without a warning; a scan whose returns lie mostly beyond 20 m is not in
    metres (:mod:`clomp.planner.units`).

    >>> RobotModel().turn_wheel_speed  # wheel speed for a 0.58 rad/s spin in place
    0.0435
    >>> RobotModel().planning_horizon, RobotModel().max_range
    (1.1, 12.0)
    """

    max_speed: float = 0.2
    straight_speed: float = 0.1
    turn_rate: float = 0.58
    turn_angle: float = math.pi / 2
    step_length: float | None = 0.27
    tick: float = 0.1
    sensor_range: float = 1.1  # the planning horizon (see the docstring: the name is kept)
    cluster_distance: float = 0.1
    goal_tolerance: float = 0.05
    clearance: float = 0.01
    free_turns: bool = True
    max_range: float = _MAX_RANGE

    _CHECKS_ITSELF: ClassVar[frozenset[str]] = frozenset({"step_length", "clearance", "free_turns"})

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.step_length is not None:
            _check_positive("RobotModel", "step_length", self.step_length)
        if not (isinstance(self.clearance, (int, float)) and self.clearance == 0):
            _check_positive("RobotModel", "clearance", self.clearance)
        if not isinstance(self.free_turns, bool):
            raise ValueError(f"RobotModel.free_turns must be True or False, got {self.free_turns!r}")
        if self.straight_speed > self.max_speed:
            raise ValueError("RobotModel.straight_speed exceeds max_speed")
        if self.turn_wheel_speed > self.max_speed:
            raise ValueError("RobotModel.turn_rate needs wheel speeds above max_speed")
        if self.turn_angle > math.pi:
            raise ValueError("RobotModel.turn_angle must be at most pi")

    @property
    def planning_horizon(self) -> float:
        """The planning horizon (m): ``sensor_range``, by the name that says what it is.

        >>> RobotModel(sensor_range=1.5).planning_horizon
        1.5
        """
        return self.sensor_range

    @property
    def turn_wheel_speed(self) -> float:
        """Wheel speed (m/s) that spins the robot in place at ``turn_rate``."""
        return round(self.turn_rate * self.wheel_base / 2, 12)

    @functools.cached_property
    def footprint(self) -> tuple[tuple[float, float], ...]:
        """The body outline in the robot frame, inflated by ``clearance``, counter-clockwise."""
        c = self.clearance
        x0, x1 = -self.rear_offset - c, self.front_offset + c
        y = self.width / 2 + c
        return ((x0, -y), (x1, -y), (x1, y), (x0, y))

    @functools.cached_property
    def swept_radius(self) -> float:
        """Radius of the disc the inflated body sweeps when it spins in place."""
        return max(math.hypot(x, y) for x, y in self.footprint)

    def with_(self, **changes: Any) -> "RobotModel":
        """A copy with some parameters changed (validated)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (every field is a number or a flag: no deep copy is needed);
        ``RobotModel(**d)`` gives the model back. ``max_range`` is written only when it is not
        the default: it changes no plan, and the maps written with the default stay as they were.

        >>> RobotModel().to_dict()["width"], "max_range" in RobotModel().to_dict()
        (0.18, False)
        >>> RobotModel(**RobotModel(max_range=30.0).to_dict()).max_range
        30.0
        """
        return dict(self._as_dict)  # a copy: the caller may change it

    @functools.cached_property
    def _as_dict(self) -> dict[str, Any]:
        # built once per model (the dataclass is frozen): a plan writes it into its map
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        if d.get("max_range") == _MAX_RANGE:
            del d["max_range"]
        return d
