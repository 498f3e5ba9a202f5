"""A Gymnasium environment of the execution world: :class:`ClompEnv` (issue #41).

Each episode draws one layout of a family (:func:`~clomp.runtime.experiment.layouts.make_layout`)
and drops a fresh robot of the execution world (:func:`~clomp.runtime.backends.world.make_world_robot`,
a noise preset; a moving family's people, boxes or door move in it, issue #42) at its start, where it stands until its LiDAR has delivered a first revolution. Everything is drawn from the environment's ``np_random``, so
``reset(seed=s)`` makes the episode reproducible bit for bit (the world's time is simulated).

- **Observation** (``Box``, float32, ``bins + 2`` values): the newest LiDAR revolution the robot
  delivered (noisy, as the sensor reports it, robot frame), as ``bins`` ranges, one per bearing
  sector of ``2π/bins`` starting straight ahead and going counter-clockwise, each the nearest
  return in its sector, clipped to the sensor range (``max_range``; an empty sector reads
  ``max_range``); then the goal in the robot frame (x ahead, y left, m), taken from the world's
  **ground truth** pose (an oracle: the agent is not asked to localise itself), clipped to ±5 m.
- **Actions**: ``action="discrete"``: ``Discrete(3)``, 0 straight, 1 left, 2 right, each the
  planner's task (:class:`~clomp.planner.robot_model.RobotModel`'s straight speed or turn wheel
  speed) held for one step of ``step_time`` s, as the authors' LiDAR environment does;
  ``action="continuous"``: ``Box(-vmax, vmax, (2,))``, the left and right wheel speeds (m/s) for
  one step.
- **Reward**: the progress towards the goal this step (m, the drop in the true distance:
  about +0.05 a straight step aimed at the goal, negative moving away), then +1 and
  ``terminated`` when the true distance is at most :data:`GOAL_RADIUS`, or −1 and ``terminated``
  at a collision (the body touched an obstacle during the step: the world's contact trace).
- **Truncation**: the registered ids stop after ``max_episode_steps`` (Gymnasium's TimeLimit,
  :data:`MAX_STEPS` steps of 0.5 s: the experiment's 120 s).

>>> env = ClompEnv("overtaking", noise="ideal")
>>> obs, info = env.reset(seed=0)
>>> obs.shape, env.action_space
((66,), Discrete(3))
>>> obs2, reward, terminated, truncated, info = env.step(0)
>>> bool(reward > 0), terminated, truncated
(True, False, False)
"""

from __future__ import annotations

import math
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from clomp.formal.geometry import relative
from clomp.formal.model import Pose
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene
from clomp.runtime.backends.world import WorldRobot, make_world_robot
from clomp.runtime.experiment.groundtruth import NOISE_PRESETS
from clomp.runtime.experiment.layouts import ALL_FAMILIES, make_layout
from clomp.runtime.experiment.policy import ACTION_TASKS, scan_ranges

__all__ = ["ACTIONS", "GOAL_RADIUS", "GOAL_LIMIT", "MAX_STEPS", "ClompEnv"]

ACTIONS = ACTION_TASKS
"""The discrete actions, in order: the planner's three tasks."""
GOAL_RADIUS = 0.1
"""The true distance to the goal (m) that ends an episode as a success."""
GOAL_LIMIT = 5.0
"""The goal coordinates in the observation are clipped to ±this (m)."""
MAX_STEPS = 240
"""The registered ids' step limit: 240 steps of 0.5 s, the experiment's 120 s."""


class ClompEnv(gym.Env[np.ndarray, Any]):
    """The execution world of one layout family as a Gymnasium environment; see the module.

    >>> env = ClompEnv("clutter", action="continuous")
    >>> env.action_space.shape, env.observation_space.shape
    ((2,), (66,))
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 2}

    def __init__(self, family: str = "overtaking", *, noise: str = "paper", action: str = "discrete",
                 bins: int = 64, step_time: float = 0.5, render_mode: str | None = None,
                 model: RobotModel | None = None) -> None:
        if family not in ALL_FAMILIES:
            raise ValueError(f"unknown layout family {family!r} (known: {', '.join(ALL_FAMILIES)})")
        if noise not in NOISE_PRESETS:
            raise ValueError(f"unknown noise preset {noise!r} (known: {', '.join(NOISE_PRESETS)})")
        if action not in ("discrete", "continuous"):
            raise ValueError(f"action must be 'discrete' or 'continuous', got {action!r}")
        if not (isinstance(bins, int) and bins >= 4):
            raise ValueError(f"bins must be an integer >= 4, got {bins!r}")
        if not (math.isfinite(step_time) and step_time > 0):
            raise ValueError(f"step_time must be a positive number of seconds, got {step_time!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.family, self.noise, self.action, self.bins = family, noise, action, bins
        self.step_time, self.render_mode = float(step_time), render_mode
        self.model = model or RobotModel()
        self.max_range = float(self.model.sensor_range)
        low = np.r_[np.zeros(bins), [-GOAL_LIMIT, -GOAL_LIMIT]].astype(np.float32)
        high = np.r_[np.full(bins, self.max_range), [GOAL_LIMIT, GOAL_LIMIT]].astype(np.float32)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        vmax = float(self.model.max_speed)
        self.action_space = (spaces.Discrete(3) if action == "discrete"
                             else spaces.Box(-vmax, vmax, shape=(2,), dtype=np.float32))
        self.scene: Scene | None = None
        self.robot: WorldRobot | None = None
        self._points = np.zeros((0, 2))
        self._distance = 0.0
        self._contacts = 0

    # -- the episode ------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """A new layout and a fresh robot, both drawn from ``np_random`` (seeded by ``seed``);
        ``options={"layout": (seed, run)}`` takes the family's layout ``make_layout(family, seed, run)``
        instead (what training and held-out evaluation use)."""
        super().reset(seed=seed)
        layout_seed, world_seed = (int(v) for v in self.np_random.integers(2**31, size=2))
        layout_run = 0
        if options and "layout" in options:  # a chosen layout (seed, run) of the family, as an experiment draws it
            layout_seed, layout_run = (int(v) for v in options["layout"])
        layout = make_layout(self.family, layout_seed, layout_run)
        self.scene = layout.scene
        self.robot = make_world_robot(self.scene, self.noise, seed=world_seed, robot=self.model, movers=layout.movers)
        self._points = np.zeros((0, 2))
        first = self.robot.read_scan(timeout=1.0)  # stand until the first revolution (under 0.2 s simulated)
        if first is not None:
            self._points = np.asarray(first.points, dtype=float).reshape(-1, 2)
        self._take_scan()
        self._distance = self._goal_distance()
        self._contacts = 0
        return self._observation(), self._info()

    def step(self, action: Any) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Drive the wheels ``step_time`` s by ``action``; reward and termination as in the module."""
        if self.robot is None:
            raise RuntimeError("call reset() before step()")
        left, right = self._wheels(action)
        self.robot.set_wheel_speeds(left, right)
        self.robot.sleep(self.step_time)
        self._take_scan()
        distance = self._goal_distance()
        reward = self._distance - distance
        self._distance = distance
        contacts = len(self.robot.contact_trace())
        collided, self._contacts = contacts > self._contacts, contacts
        reached = distance <= GOAL_RADIUS
        if collided:
            reward -= 1.0
        elif reached:
            reward += 1.0
        info = self._info() | {"collided": collided, "reached": reached and not collided}
        return self._observation(), float(reward), bool(collided or reached), False, info

    def _wheels(self, action: Any) -> tuple[float, float]:
        m = self.model
        if self.action == "continuous":
            a = np.clip(np.asarray(action, dtype=float).reshape(2), -m.max_speed, m.max_speed)
            return float(a[0]), float(a[1])
        k = int(action)
        if not 0 <= k < 3:
            raise ValueError(f"action must be 0 (straight), 1 (left) or 2 (right), got {action!r}")
        spin = m.turn_wheel_speed
        return ((m.straight_speed, m.straight_speed), (-spin, spin), (spin, -spin))[k]

    # -- observation -----------------------------------------------------------------------
    def _take_scan(self) -> None:
        assert self.robot is not None
        frame = self.robot.read_scan(timeout=0.0)
        while frame is not None:  # the newest revolution delivered
            self._points = np.asarray(frame.points, dtype=float).reshape(-1, 2)
            frame = self.robot.read_scan(timeout=0.0)

    def ranges(self) -> np.ndarray:
        """The newest revolution as ``bins`` ranges (see the module), float32."""
        return scan_ranges(self._points, self.bins, self.max_range)

    def goal_in_robot_frame(self) -> tuple[float, float]:
        """The goal seen from the robot's true pose (x ahead, y left, m)."""
        assert self.robot is not None and self.scene is not None
        g = relative(self.robot.ground_truth_pose(), Pose(*self.scene.goal, 0.0))
        return g.x, g.y

    def _goal_distance(self) -> float:
        return math.hypot(*self.goal_in_robot_frame())

    def _observation(self) -> np.ndarray:
        goal = np.clip(np.asarray(self.goal_in_robot_frame(), dtype=np.float32), -GOAL_LIMIT, GOAL_LIMIT)
        return np.concatenate([self.ranges(), goal]).astype(np.float32)

    def _info(self) -> dict[str, Any]:
        assert self.robot is not None and self.scene is not None
        p = self.robot.ground_truth_pose()
        return {"pose": (p.x, p.y, p.theta), "time_s": self.robot.now(), "scene": self.scene.name}

    # -- rendering -------------------------------------------------------------------------
    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the layout, the goal, the robot's body and its newest
        scan (world frame) as an RGB image (H, W, 3, uint8); None otherwise."""
        if self.render_mode != "rgb_array" or self.robot is None or self.scene is None:
            return None
        from clomp.runtime.gym.render import draw

        return draw(self.scene, self.robot.ground_truth_pose(), self._points, self.model)

    def close(self) -> None:
        """Close the world's robot."""
        if self.robot is not None:
            self.robot.close()
            self.robot = None
