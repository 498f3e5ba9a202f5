"""The robot model: dimensions, speeds and task parameters, defaults from the paper's robot."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace
from typing import Any

__all__ = ["RobotModel"]


@dataclass(frozen=True)
class RobotModel:
    """A differential-drive robot and the parameters of its tasks.

    All units SI. The body is a ``length`` × ``width`` rectangle; the rotation centre
    (where the LiDAR sits, the origin of the robot frame) is ``front_offset`` behind the
    front edge. Defaults are the paper's robot (DESIGN.md). ``clearance`` is the margin
    the planner keeps between the body and a sensed point. With ``free_turns`` a turn
    ends where its error is zero (facing the goal, or where the way ahead is clear, see
    :func:`clomp.planner.rollout.turn_angle`) and a step ends early where the body could no
    longer spin in place; without, every turn turns ``turn_angle`` and every step is
    ``step_length`` long (the authors' planner).

    >>> RobotModel().turn_wheel_speed  # wheel speed for a 0.58 rad/s spin in place
    0.0435
    """

    length: float = 0.27
    width: float = 0.18
    front_offset: float = 0.09
    wheel_base: float = 0.15
    max_speed: float = 0.2
    straight_speed: float = 0.1
    turn_rate: float = 0.58
    turn_angle: float = math.pi / 2
    step_length: float | None = 0.27
    tick: float = 0.1
    sensor_range: float = 1.1
    cluster_distance: float = 0.1
    goal_tolerance: float = 0.05
    clearance: float = 0.01
    free_turns: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None and f.name == "step_length":
                continue
            if f.name == "free_turns":
                if not isinstance(v, bool):
                    raise ValueError(f"RobotModel.free_turns must be True or False, got {v!r}")
                continue
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                if f.name == "clearance" and isinstance(v, (int, float)) and v == 0:
                    continue
                raise ValueError(f"RobotModel.{f.name} must be a positive finite number, got {v!r}")
        if self.front_offset >= self.length:
            raise ValueError("RobotModel.front_offset must be smaller than the body length")
        if self.straight_speed > self.max_speed:
            raise ValueError("RobotModel.straight_speed exceeds max_speed")
        if self.turn_wheel_speed > self.max_speed:
            raise ValueError("RobotModel.turn_rate needs wheel speeds above max_speed")
        if self.turn_angle > math.pi:
            raise ValueError("RobotModel.turn_angle must be at most pi")

    @property
    def rear_offset(self) -> float:
        """Distance from the rotation centre to the rear edge."""
        return self.length - self.front_offset

    @property
    def turn_wheel_speed(self) -> float:
        """Wheel speed (m/s) that spins the robot in place at ``turn_rate``."""
        return round(self.turn_rate * self.wheel_base / 2, 12)

    # derived once per model (the dataclass is frozen: a cached value never goes stale)
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

    @functools.cached_property
    def corners(self) -> tuple[tuple[float, float], ...]:
        """The real body's outline in the robot frame (no clearance), counter-clockwise."""
        h = self.width / 2
        return ((-self.rear_offset, -h), (self.front_offset, -h), (self.front_offset, h), (-self.rear_offset, h))

    @functools.cached_property
    def body_radius(self) -> float:
        """The distance from the rotation centre to the real body's farthest corner."""
        return max(math.hypot(a, b) for a, b in self.corners)

    def with_(self, **changes: Any) -> "RobotModel":
        """A copy with some parameters changed (validated)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (every field is a number or a flag: no deep copy is needed).

        >>> RobotModel().to_dict()["width"]
        0.18
        """
        return {f.name: getattr(self, f.name) for f in fields(self)}
