"""Tasks: the temporary closed-loop controllers STRAIGHT, LEFT and RIGHT (and, for a world
that moves, WAIT and REVERSE).

A task is contingent on a disturbance D_I (here the goal D_G). At every control tick it
computes an error signal E from the robot's pose and its disturbance, maps E to wheel
speeds (the motor law M = H(E)) and ends when E reaches zero. The same controller runs
in the physics rollouts of the Configurator and on the robot under the supervisor: in
both, the task ends by its own criterion measured on the (simulated or estimated) pose.

- STRAIGHT: both wheels equal. E is the distance still to drive: the smaller of what is
  left of its length limit (a body-length step, or the distance to the goal when the
  goal is dead ahead and nothing is in the way) and, when the goal was ahead at the
  start, the goal's distance along the heading (E = 0 when the goal comes abeam or is
  reached). Speed ramps down in the last tick so that it stops exactly on E = 0.
- LEFT / RIGHT: spin in place (wheels opposite). E is the heading change still to make
  towards the commanded turn angle.
- WAIT (issue #42): both wheels stopped. E is the time still to stand (s): ``limit`` less
  what the executor counted in :attr:`Task.waited`; the supervisor ends it sooner when the
  way ahead clears.
- REVERSE (issue #42): both wheels equal and backwards, holding the heading as a STRAIGHT
  does. E is the distance still to back off (m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Disturbance, Pose, TaskKind
from clomp.planner.robot_model import RobotModel

__all__ = ["HOLD_GAIN", "HOLD_LIMIT", "Task", "wrap_angle"]

_EPS = 1e-9
HOLD_GAIN = 1.0
"""rad/s of turn per rad a STRAIGHT has turned off its start heading (:meth:`Task.wheel_speeds`)."""
HOLD_LIMIT = 0.5
"""rad/s: the most a STRAIGHT turns to hold its heading."""


@dataclass(slots=True)
class Task:
    """One closed-loop controller, started at ``start`` with its limits fixed then.

    ``limit`` is the length (m) of a STRAIGHT or the angle (rad) of a turn.
    ``goal`` is D_I. Create with :meth:`straight` / :meth:`turn` or :meth:`create`.

    >>> from clomp.planner.robot_model import RobotModel
    >>> t = Task.straight(RobotModel(), Pose(0.0, 0.0), None, 0.27)
    >>> e = t.error_at(0.0, 0.0, 0.0)
    >>> round(e, 2), t.done(e), t.wheel_speeds(e)[0] == t.wheel_speeds(e)[1]
    (0.27, False, True)
    """

    kind: TaskKind
    robot: RobotModel
    start: Pose
    limit: float
    goal: Disturbance | None = None
    goal_ahead: bool = False
    waited: float = field(default=0.0, kw_only=True)  # a WAIT's time stood so far (s), counted by whoever runs it

    @classmethod
    def wait(cls, robot: RobotModel, start: Pose, goal: Disturbance | None, duration: float) -> "Task":
        """A WAIT: stand still for at most ``duration`` s (its error is the time left).

        >>> t = Task.wait(RobotModel(), Pose(0.0, 0.0), None, 2.0)
        >>> t.wheel_speeds(t.error(t.start)), t.max_ticks()
        ((0.0, 0.0), 22)
        """
        return cls(TaskKind.WAIT, robot, start, float(duration), goal)

    @classmethod
    def reverse(cls, robot: RobotModel, start: Pose, goal: Disturbance | None, distance: float) -> "Task":
        """A REVERSE: back off ``distance`` metres along the start heading.

        >>> t = Task.reverse(RobotModel(), Pose(0.0, 0.0), None, 0.15)
        >>> t.wheel_speeds(t.error(t.start)), round(t.error(Pose(-0.1, 0.0)), 3)
        ((-0.1, -0.1), 0.05)
        """
        return cls(TaskKind.REVERSE, robot, start, float(distance), goal)

    @classmethod
    def straight(cls, robot: RobotModel, start: Pose, goal: Disturbance | None, limit: float) -> "Task":
        """A STRAIGHT of at most ``limit`` metres, ending early when ``goal`` comes abeam."""
        ahead = False
        if goal is not None:
            ahead = _along(start, goal) > _EPS
        return cls(TaskKind.STRAIGHT, robot, start, float(limit), goal, ahead)

    @classmethod
    def turn(cls, robot: RobotModel, kind: TaskKind, start: Pose, goal: Disturbance | None = None,
             angle: float | None = None) -> "Task":
        """A LEFT or RIGHT spin in place by ``angle`` (default the robot's turn angle)."""
        if not kind.is_turn:
            raise ValueError("turn() needs LEFT or RIGHT")
        return cls(kind, robot, start, float(robot.turn_angle if angle is None else angle), goal)

    # -- the control loop ------------------------------------------------------------
    def error(self, pose: Pose) -> float:
        """E: what is left to do, in metres (STRAIGHT) or radians (turns); 0 means done."""
        return self.error_at(pose.x, pose.y, pose.theta)

    def error_at(self, x: float, y: float, theta: float) -> float:
        """:meth:`error` for a pose given as three floats (the rollouts' hot path)."""
        s = self.start
        if self.kind is TaskKind.STRAIGHT:
            c, sn = math.cos(s.theta), math.sin(s.theta)
            e = self.limit - ((x - s.x) * c + (y - s.y) * sn)
            if self.goal_ahead and self.goal is not None:
                g = self.goal
                e = min(e, (g.x - x) * math.cos(theta) + (g.y - y) * math.sin(theta))
            return max(e, 0.0)
        if not self.kind.is_turn:
            return self._recovery_error(x, y)
        turned = wrap_angle(theta - s.theta)
        if self.kind is TaskKind.RIGHT:
            turned = -turned
        # a turn by pi may wrap: count a wrapped heading as turned past
        if turned < -math.pi / 2 and self.limit > math.pi / 2:
            turned += 2 * math.pi
        return max(self.limit - turned, 0.0)

    def _recovery_error(self, x: float, y: float) -> float:
        """:meth:`error_at` of a WAIT (time left) or a REVERSE (distance left)."""
        if self.kind is TaskKind.WAIT:
            return max(self.limit - self.waited, 0.0)
        s = self.start
        return max(self.limit + (x - s.x) * math.cos(s.theta) + (y - s.y) * math.sin(s.theta), 0.0)

    def start_error(self) -> float:
        """:meth:`error_at` the start pose, where a rollout begins, without the terms that are
        zero there (the distance driven, the angle turned): the same value, but for the sign
        of a zero error.

        >>> t = Task.straight(RobotModel(), Pose(0.1, 0.2, 0.3), None, 0.27)
        >>> t.start_error() == t.error(t.start)
        True
        """
        if self.kind is TaskKind.STRAIGHT:
            e = self.limit
            if self.goal_ahead and self.goal is not None:
                s, g = self.start, self.goal
                e = min(e, (g.x - s.x) * math.cos(s.theta) + (g.y - s.y) * math.sin(s.theta))
            return max(e, 0.0)
        return max(self.limit, 0.0)

    def done(self, error: float) -> bool:
        """True when the task's error signal has reached zero."""
        return error <= _EPS

    def wheel_speeds(self, error: float, turned: float = 0.0) -> tuple[float, float]:
        """M = H(E): (left, right) wheel speeds in m/s for this tick.

        ``turned`` (rad): for a STRAIGHT, how far the robot's heading has turned since the
        task began, a second error signal measured on the robot (the authors' robot measured
        its rotation by its camera's optic flow and corrected its straights on it): the
        wheels steer it back at ``HOLD_GAIN`` rad/s per rad, at most ``HOLD_LIMIT`` rad/s.
        The rollouts' unicycle drives straight and passes 0.

        >>> t = Task.straight(RobotModel(), Pose(0.0, 0.0), None, 0.27)
        >>> left, right = t.wheel_speeds(0.27, turned=0.1)    # turned left: steer right
        >>> left > right
        True
        """
        r = self.robot
        if self.kind is TaskKind.STRAIGHT or self.kind is TaskKind.REVERSE:
            v = min(r.straight_speed, error / r.tick)
            if self.kind is TaskKind.REVERSE:
                v = -v  # backwards: the same hold of the heading (a turn rate is a turn rate)
            if turned and v:
                w = max(-HOLD_LIMIT, min(HOLD_LIMIT, -HOLD_GAIN * turned))
                return v - w * r.wheel_base / 2, v + w * r.wheel_base / 2
            return v, v
        if self.kind is TaskKind.WAIT:
            return 0.0, 0.0
        w = min(r.turn_rate, error / r.tick)
        wheel = w * r.wheel_base / 2
        return (-wheel, wheel) if self.kind is TaskKind.LEFT else (wheel, -wheel)

    def max_ticks(self) -> int:
        """An upper bound on the ticks the task can take (for loops that must end)."""
        r = self.robot
        if self.kind is TaskKind.WAIT:
            return int(math.ceil(self.limit / r.tick - 1e-9)) + 2
        rate = r.turn_rate if self.kind.is_turn else r.straight_speed
        return int(math.ceil(self.limit / (rate * r.tick))) + 2


def _along(pose: Pose, goal: Disturbance) -> float:
    """The goal's distance ahead of ``pose`` along its heading (negative when behind)."""
    return (goal.x - pose.x) * math.cos(pose.theta) + (goal.y - pose.y) * math.sin(pose.theta)
