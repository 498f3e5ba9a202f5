"""External pushes in the rollouts: the execution world's ``push_rate`` / ``push_size``.

The ``harsh`` world kicks the robot at random (``specs/noise_presets.json``: 0.02 a
second, each sliding the body 0.1-0.3 m in a random direction); the estimator does not
model it. In the calibration bench's runs at ``harsh`` (docs/calibration.md) a push is
the commonest cause of a failed run: the slide ends in a wall (a contact episode), or
the estimate loses the robot. The probabilistic map's rollouts had no such term, so a
plan through a narrow gap scored as well as one in the open. :func:`push_outcome` gives
a rollout the push the world would give it while the task runs: with probability
``1 - exp(-rate * duration)`` one push at a uniform time along the task, whose slide is
tested against the noisy world's obstacles (a contact: a collision outcome where it
meets them) or displaces the task's end (an outcome off the prediction, which the
closed loop replans from).

Only the time the plan's tasks run is covered: pushes while the robot plans, stands
for the goal's confirmation or runs later plans are not in a first plan's map.

>>> import numpy as np
>>> from clomp.formal.model import Pose, TaskKind
>>> from clomp.planner.engine import Outcome
>>> out = Outcome(TaskKind.STRAIGHT, Pose(0.0, 0.0), Pose(0.5, 0.0), 0.5, 5.0, 50, None, False)
>>> push_outcome(out, np.zeros((0, 2)), RobotModel(), Pushes(), np.random.default_rng(0)) is out
True
>>> wall = np.array([[x, 0.2] for x in np.linspace(-0.5, 1.0, 151)])
>>> hits = [push_outcome(out, wall, RobotModel(), Pushes(10.0, 0.2), np.random.default_rng(k)).d_n is not None for k in range(40)]
>>> 0 < sum(hits) < 40
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Disturbance, DisturbanceKind, Pose
from clomp.planner.engine import Outcome
from clomp.planner.footprint import body_box, inside_at
from clomp.planner.noise import NoiseError, noise_presets
from clomp.planner.robot_model import RobotModel

__all__ = ["Pushes", "push_outcome"]

SLIDE_STEPS = 8
"""Poses along a slide at which the body is tested against the obstacles (a 0.3 m slide:
every 4 cm, under the 5 cm a body needs to pass a return between two tests)."""


@dataclass(frozen=True)
class Pushes:
    """Pushes a second of driving (``rate``) and how far each slides the body (``size``
    m, drawn uniform in 0.5-1.5 times it), as the world's ``push_rate`` / ``push_size``.

    >>> Pushes.preset("harsh"), Pushes.preset("paper").rate
    (Pushes(rate=0.02, size=0.2), 0.0)
    """

    rate: float = 0.0
    size: float = 0.0

    def __post_init__(self) -> None:
        for name in ("rate", "size"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise NoiseError(f"pushes: {name} must be a finite number >= 0, got {v!r}")

    @classmethod
    def preset(cls, name: str) -> "Pushes":
        """The pushes of the noise preset ``name`` (``specs/noise_presets.json``)."""
        terms = noise_presets()[name]
        return cls(float(terms.get("push_rate", 0.0)), float(terms.get("push_size", 0.0)))

    @property
    def active(self) -> bool:
        """Whether a rollout can be pushed at all."""
        return self.rate > 0 and self.size > 0


def push_outcome(out: Outcome, points: np.ndarray, robot: RobotModel, pushes: Pushes, rng: np.random.Generator) -> Outcome:
    """``out`` with the push the world gives a task that runs ``out.duration`` s (see the
    module): ``out`` itself when none comes (no random draw at all when ``pushes`` is
    inactive or the outcome is already a contact), else the outcome of the slide among
    ``points`` (the noisy world's obstacles, the planner's frame)."""
    if not pushes.active or out.d_n is not None or out.duration <= 0:
        return out
    if rng.random() >= -math.expm1(-pushes.rate * out.duration):
        return out
    u = float(rng.random())
    direction = float(rng.uniform(-math.pi, math.pi))
    size = pushes.size * float(rng.uniform(0.5, 1.5))
    s, e = out.start, out.end
    x, y = s.x + u * (e.x - s.x), s.y + u * (e.y - s.y)
    theta = wrap_angle(s.theta + u * wrap_angle(e.theta - s.theta))
    dx, dy = math.cos(direction), math.sin(direction)
    box = body_box(robot)
    if len(points):
        for f in np.linspace(0.0, size, SLIDE_STEPS + 1)[1:]:
            at = (x + f * dx, y + f * dy, theta)
            hit = inside_at(points, at, box)
            if hit.any():
                cx, cy = (float(v) for v in points[hit][0])
                return replace(out, end=Pose(*at), d_n=Disturbance(DisturbanceKind.OBSTACLE, cx, cy), reached_goal=False)
    return replace(out, end=Pose(e.x + size * dx, e.y + size * dy, e.theta), reached_goal=False)
