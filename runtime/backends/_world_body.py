"""The world robot's body: its dimensions (the one :class:`~clomp.planner.robot_model.Body`
type) with its drive's physics, and the pymunk world it moves in (a dynamic body pulled by
a kinematic control body through force-limited joints, as :mod:`clomp.runtime.backends.world`
describes it).

>>> BodySpec().wheel_accel, BodySpec(length=0.3).rear_offset
(1.0, 0.21)
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, NamedTuple

import pymunk

from clomp.formal.model import Pose
from clomp.planner.robot_model import Body
from clomp.planner.scenarios import Scene, ScenarioError

__all__ = ["BodySpec", "Physics", "build_physics"]

_OBSTACLE, _ROBOT = 1, 2


@dataclass(frozen=True)
class BodySpec(Body):
    """The physical robot: a :class:`~clomp.planner.robot_model.Body` (``length``, ``width``,
    ``front_offset``, ``wheel_base``) with its wheels' limits, mass and friction (SI units;
    the paper's robot). Every field is a positive finite number.

    >>> BodySpec.like(Body(width=0.2)).width, BodySpec(mass=2.0).mass
    (0.2, 2.0)
    """

    max_wheel_speed: float = 0.2
    wheel_accel: float = 1.0
    mass: float = 1.5
    traction: float = 0.8
    wall_friction: float = 0.4

    @classmethod
    def like(cls, model: Body, **changes: Any) -> "BodySpec":
        """A body with the dimensions of ``model`` (a :class:`~clomp.planner.robot_model.Body`,
        e.g. a RobotModel) and, when it has one, its top speed ``max_speed``."""
        dims = {f.name: getattr(model, f.name) for f in fields(Body)}
        speed = getattr(model, "max_speed", None)
        base = cls(**dims) if speed is None else cls(**dims, max_wheel_speed=float(speed))
        return replace(base, **changes)


class Physics(NamedTuple):
    """The pymunk world: the space, the robot's body and shape and the control body that
    drives it."""

    space: pymunk.Space
    body: pymunk.Body
    shape: pymunk.Shape
    control: pymunk.Body


def _add_obstacles(space: pymunk.Space, scene: Scene, friction: float) -> None:
    for s in scene.shapes:
        if s.kind == "circle":
            shape: pymunk.Shape = pymunk.Circle(space.static_body, s.radius, s.center)
        else:
            shape = pymunk.Poly(space.static_body, list(s.vertices))
        shape.friction = friction
        shape.collision_type = _OBSTACLE
        shape.filter = pymunk.ShapeFilter(categories=_OBSTACLE)
        space.add(shape)


def build_physics(scene: Scene, b: BodySpec, start: Pose) -> Physics:
    """The scene's obstacles as static shapes and the body at ``start`` with its traction
    joints; ScenarioError when the body overlaps an obstacle there."""
    space = pymunk.Space()
    space.collision_slop = 0.0005
    space.iterations = 20
    _add_obstacles(space, scene, b.wall_friction)
    outline = list(b.corners)
    body = pymunk.Body(b.mass, pymunk.moment_for_poly(b.mass, outline))
    body.position = (start.x, start.y)
    body.angle = start.theta
    shape = pymunk.Poly(body, outline)
    shape.friction = 1.0
    shape.collision_type = _ROBOT
    shape.filter = pymunk.ShapeFilter(categories=_ROBOT)
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.position = body.position
    grip = b.traction * b.mass * 9.81
    pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
    pivot.max_bias = 0.0
    pivot.max_force = grip
    gear = pymunk.GearJoint(control, body, 0.0, 1.0)
    gear.error_bias = 0.0
    gear.max_bias = 0.0
    gear.max_force = grip * b.wheel_base / 2
    space.add(body, shape, control, pivot, gear)
    if space.shape_query(shape):
        raise ScenarioError(f"{scene.name}.start: the robot's body overlaps an obstacle at the start pose")
    return Physics(space, body, shape, control)
