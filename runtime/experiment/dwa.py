"""The ``dwa`` condition: the dynamic window approach (Fox, Burgard and Thrun 1997) as a baseline.

The classical local planner a robot user would pick instead of the planner: every control
tick (:attr:`~clomp.planner.robot_model.RobotModel.tick`) it samples the velocities
``(v, ω)`` the robot can reach within one tick from the speed it commands now (the *dynamic
window*: forward speed 0 to the top wheel speed ``max_speed``, each wheel at most ``accel``
m/s² faster or slower — by default the execution world's wheel acceleration limit, 1 m/s²,
as :class:`~clomp.runtime.backends.world.BodySpec` declares it; the planner's model has
none), rolls each out as an arc for ``horizon`` s, discards those along which the body
(:attr:`~clomp.planner.robot_model.RobotModel.footprint`, the body inflated by its
clearance) comes within ``margin`` of a scan point, and drives the one with the best score

    ``heading · (1 − |bearing of the goal from the arc's end| / π)
    + progress · (drop in the goal distance over the arc) / (v_max · horizon)
    + distance · min(clearance along the arc, 0.3 m) / 0.3 m + velocity · v / v_max``

no faster than the goal is near. Fox et al.'s score has no progress term; without it the
robot stops facing a box in line with the goal (standing still keeps the goal dead ahead).
When no motion is admissible, or standing still scores best, it turns in place — away from
the obstacles ahead, one way until it can move on, the other way if the body would touch,
backing up slowly if it would touch either way (the usual recovery; ``avoid_ticks`` counts
its ticks). The weights (``heading`` 0.5, ``progress`` 1.0, ``distance`` 0.5, ``velocity``
0.2; ``horizon`` 1.5 s, ``margin`` 0.02 m) were tuned on the ``corridor`` and ``clutter``
families (seed 100, noise paper; docs/gym.md) and are scored on the others.

It is the same robot, sensing and estimate as the reactive condition (it is a
:class:`~clomp.runtime.experiment.reactive.ReactiveController` with another control law): the
pose estimate by scan matching or dead reckoning (``feedback``), the newest revolution moved
into the body frame each tick, the goal believed reached within ``goal_radius``.

>>> from clomp.planner import load_scenario
>>> from clomp.runtime.backends.sim import SimRobot
>>> scene = load_scenario("open")
>>> DwaController(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(60).state
'GOAL_REACHED'
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from clomp.formal.geometry import points_from_frame, relative
from clomp.formal.model import Pose
from clomp.runtime.experiment._dwa_clearance import Body, arc_clearance
from clomp.runtime.experiment.reactive import ReactiveController

__all__ = ["DwaController", "DwaWeights"]

DwaWeights = dict[str, float]
"""``heading``, ``distance``, ``velocity``: the score's weights (see the module)."""
_DEFAULT_WEIGHTS: DwaWeights = {"heading": 0.5, "progress": 1.0, "distance": 0.5, "velocity": 0.2}
_CLEAR_CAP = 0.3
_ARC_STEP = 0.2  # s between the poses an arc is checked at (4 cm at the top speed)


class DwaController(ReactiveController):
    """Drive to ``goal`` (robot frame at start) by the dynamic window approach; see the module.

    ``weights`` change the score's weights, ``horizon`` the arcs' length (s), ``accel`` the
    wheels' acceleration the window assumes (m/s²), ``samples`` the (v, ω) grid; the other
    arguments are the :class:`~clomp.runtime.experiment.reactive.ReactiveController`'s.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> scene = load_scenario("open")
    >>> DwaController(SimRobot(scene, seed=0), scene.goal_in_robot_frame(), horizon=1.0).horizon
    1.0
    """

    def __init__(self, robot: Any, goal: tuple[float, float], *args: Any, weights: DwaWeights | None = None,
                 horizon: float = 1.5, accel: float = 1.0, margin: float = 0.02, samples: tuple[int, int] = (6, 15), **kwargs: Any) -> None:
        super().__init__(robot, goal, *args, **kwargs)
        self.weights = {**_DEFAULT_WEIGHTS, **(weights or {})}
        unknown = set(self.weights) - set(_DEFAULT_WEIGHTS)
        if unknown:
            raise ValueError(f"unknown DWA weights {sorted(unknown)} (known: {', '.join(_DEFAULT_WEIGHTS)})")
        for name, v in (("horizon", horizon), ("accel", accel)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if min(samples) < 2:
            raise ValueError(f"samples must be at least 2 each, got {samples!r}")
        self.margin = float(margin)
        self._recover = 0  # the recovery turn's side: 1 left, -1 right, 0 none
        self.horizon, self.accel, self.samples = float(horizon), float(accel), (int(samples[0]), int(samples[1]))

    def _control(self, g: Pose, now: float) -> tuple[float, float]:
        m = self.model
        if not self.tasks:
            self._begin("straight", now, "dwa")
        pts = self._body_points()
        v, w = self._best(pts, g)
        if v is None or (self._recover and v < 1e-3):  # the recovery: turn in place until it can move on
            return self._recovery(pts, g)
        if v > 0:
            self._recover = 0
        half = m.wheel_base / 2
        return (v - w * half, v + w * half)

    def _recovery(self, pts: np.ndarray, g: Pose) -> tuple[float, float]:
        """Turn in place away from the obstacles ahead (the side their centre is not on; towards
        the goal if none), the same way until a motion is admissible again; the other way when
        the body would touch turning this way; back up slowly when it would touch either way."""
        m = self.model
        self.avoid_ticks += 1
        if self._recover == 0:
            ahead = pts[(pts[:, 0] > 0) & (np.abs(pts[:, 1]) < 0.5)] if len(pts) else pts
            side = -float(np.mean(ahead[:, 1])) if len(ahead) else g.y
            self._recover = 1 if side >= 0 else -1
        spin = m.turn_wheel_speed
        for sign in (self._recover, -self._recover):
            w = np.array([sign * 2 * spin / m.wheel_base])
            t = np.array([[0.5 * m.tick, m.tick, 2 * m.tick]])
            if self._clearance(pts, np.zeros((1, 3)), np.zeros((1, 3)), w[:, None] * t)[0] > 0:
                self._recover = sign
                return (-sign * spin, sign * spin)
        return (-m.straight_speed / 2, -m.straight_speed / 2)

    def _body_points(self) -> np.ndarray:
        if len(self._scan) == 0:
            return np.zeros((0, 2))
        pts = points_from_frame(self._scan, relative(self.pose, self._scan_pose))
        reach = self.horizon * self.model.max_speed + self.model.body_radius + _CLEAR_CAP
        keep: np.ndarray = pts[np.hypot(pts[:, 0], pts[:, 1]) <= reach]
        return keep

    def _window(self) -> tuple[np.ndarray, np.ndarray]:
        """The (v, ω) pairs reachable within one tick, wheel speeds within the top speed."""
        m = self.model
        half = m.wheel_base / 2
        vl, vr = self._cmd
        v0, w0 = (vl + vr) / 2, (vr - vl) / m.wheel_base
        dv = self.accel * m.tick
        vs = np.linspace(max(0.0, v0 - dv), min(m.max_speed, v0 + dv), self.samples[0])
        wmax = m.max_speed / half
        ws = np.linspace(max(-wmax, w0 - dv / half), min(wmax, w0 + dv / half), self.samples[1])
        v, w = (a.ravel() for a in np.meshgrid(vs, ws))
        ok = np.abs(v) + np.abs(w) * half <= m.max_speed + 1e-9
        return v[ok], w[ok]

    def _best(self, pts: np.ndarray, g: Pose) -> tuple[float | None, float]:
        m = self.model
        v, w = self._window()
        if not len(v):
            return None, 0.0
        steps = max(2, int(round(self.horizon / _ARC_STEP)))
        t = np.arange(1, steps + 1) * (self.horizon / steps)  # (T,)
        th = np.outer(w, t)  # (N, T)
        safe_w = np.where(np.abs(w) < 1e-9, 1.0, w)[:, None]
        straight = (np.abs(w) < 1e-9)[:, None]
        x = np.where(straight, v[:, None] * t, v[:, None] / safe_w * np.sin(th))
        y = np.where(straight, 0.0, v[:, None] / safe_w * (1 - np.cos(th)))
        # (N,) the nearest point to the body along each arc: exact where the score reads it (above
        # the margin, below the cap); an arc within the margin is only known to be so
        cap = _CLEAR_CAP if self.margin < _CLEAR_CAP else math.inf
        clear = self._clearance(pts, x, y, th, cap=cap, stop=self.margin)
        admissible = clear > self.margin  # no arc that comes nearer an obstacle than the margin within the horizon
        if not admissible.any():
            return None, 0.0
        off = np.arctan2(g.y - y[:, -1], g.x - x[:, -1]) - th[:, -1]
        bearing = np.arctan2(np.sin(off), np.cos(off))
        ws = self.weights
        d0 = math.hypot(g.x, g.y)
        progress = (d0 - np.hypot(g.x - x[:, -1], g.y - y[:, -1])) / (m.max_speed * self.horizon)
        score = (ws["heading"] * (1 - np.abs(bearing) / math.pi) + ws["progress"] * progress
                 + ws["distance"] * np.minimum(clear, _CLEAR_CAP) / _CLEAR_CAP + ws["velocity"] * v / m.max_speed)
        slow = v <= max(math.hypot(g.x, g.y), m.straight_speed / 2)  # no faster than the goal is near
        pick = admissible & slow if (admissible & slow).any() else admissible
        score = np.where(pick, score, -np.inf)
        k = int(np.argmax(score))
        if v[k] < 1e-3 and abs(w[k]) < 0.1:  # standing still is no plan: the recovery turn instead
            return None, 0.0
        return float(v[k]), float(w[k])

    def _clearance(self, pts: np.ndarray, x: np.ndarray, y: np.ndarray, th: np.ndarray, cap: float = math.inf,
                   stop: float = 0.0) -> np.ndarray:
        """Per arc (poses ``x``, ``y``, ``th``: (N, T)), the smallest distance (m) from the inflated
        body to a point at any of its poses (0: a hit; inf without points), where above ``stop``,
        at most ``cap``: :func:`~clomp.runtime.experiment._dwa_clearance.arc_clearance`."""
        return arc_clearance(pts, x, y, th, self._body(), cap=cap, stop=stop)

    def _body(self) -> Body:
        m = self.model
        return (m.rear_offset, m.front_offset, m.clearance, m.width)
