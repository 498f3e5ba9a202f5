"""The ``rl`` condition: a learned policy drives the robot, one discrete action per step.

Same robot, sensing and estimate as the reactive and dwa conditions (it is a
:class:`~clomp.runtime.experiment.reactive.ReactiveController` with another control law):
every ``step_time`` s (0.5 s, the Gymnasium environment's step) it builds the environment's
observation — the newest revolution moved into the body frame as ``bins`` ranges, and the
goal in the robot frame from the robot's own **estimate** (the environment gives its agent
the true goal; a robot has only its estimate) — asks the policy
(:mod:`clomp.runtime.experiment.policy`) for an action and holds it: 0 straight at the
straight task's speed, 1 left and 2 right turning in place at the turn tasks' wheel speed.
It believes the goal reached within ``goal_radius`` of its estimate, as the others do; it
cannot say "unreachable".

>>> from clomp.planner import load_scenario
>>> from clomp.runtime.backends.sim import SimRobot
>>> from clomp.runtime.experiment.policy import LinearPolicy
>>> scene = load_scenario("open")
>>> RlController(SimRobot(scene, seed=0), scene.goal_in_robot_frame(), policy=LinearPolicy.goal_seeker()).run(60).state
'GOAL_REACHED'
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from clomp.formal.geometry import points_from_frame, relative
from clomp.formal.model import Pose
from clomp.runtime.experiment.policy import ACTION_TASKS, Policy, load_policy, scan_ranges
from clomp.runtime.experiment.reactive import ReactiveController

__all__ = ["RlController"]


class RlController(ReactiveController):
    """Drive to ``goal`` (robot frame at start) by a policy's actions; see the module.

    ``policy``: a :class:`~clomp.runtime.experiment.policy.Policy`, a policy file's path, or
    None for the shipped default; ``step_time``: how long each action is held (s); ``bins``:
    the observation's ranges (the policy's own when it says). The other arguments are the
    ReactiveController's.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> RlController(SimRobot(load_scenario("open"), seed=0), (1.0, 0.0)).step_time
    0.5
    """

    def __init__(self, robot: Any, goal: tuple[float, float], *args: Any, policy: Policy | str | None = None,
                 step_time: float = 0.5, bins: int | None = None, **kwargs: Any) -> None:
        super().__init__(robot, goal, *args, **kwargs)
        self.policy: Policy = policy if policy is not None and not isinstance(policy, str) else load_policy(policy)
        if not (math.isfinite(step_time) and step_time > 0):
            raise ValueError(f"step_time must be a positive number of seconds, got {step_time!r}")
        self.step_time = float(step_time)
        self.bins = int(bins if bins is not None else getattr(self.policy, "bins", 64))
        self.max_range = float(getattr(self.policy, "max_range", self.model.sensor_range))
        self._action = -1
        self._action_end = -math.inf

    def observation(self, g: Pose) -> np.ndarray:
        """The environment's observation on the robot: the newest scan in the body frame as
        ranges, then the estimated goal (x ahead, y left), clipped to ±5 m."""
        pts = points_from_frame(self._scan, relative(self.pose, self._scan_pose)) if len(self._scan) else self._scan
        goal = np.clip([g.x, g.y], -5.0, 5.0)
        out: np.ndarray = np.r_[scan_ranges(pts, self.bins, self.max_range), goal].astype(np.float32)
        return out

    def _control(self, g: Pose, now: float) -> tuple[float, float]:
        m = self.model
        if now >= self._action_end - 1e-9:
            action = int(self.policy.act(self.observation(g)))
            if not 0 <= action < 3:
                raise ValueError(f"the policy chose action {action!r}; expected 0, 1 or 2")
            if action != self._action:
                self._begin(ACTION_TASKS[action], now, "rl")
            self._action, self._action_end = action, now + self.step_time
        spin = m.turn_wheel_speed
        return ((m.straight_speed, m.straight_speed), (-spin, spin), (spin, -spin))[self._action]
