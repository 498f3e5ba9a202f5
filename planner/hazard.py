"""The supervisor's scan test applied to a noisy rollout: where the closed loop would stop it.

A rollout of :mod:`clomp.planner.probabilistic` follows its task to the end. The
supervisor does not: every revolution of the LiDAR it tests the rest of the task against
the newest scan (the hazard test of runtime/supervision/alarms.py and the plan check of
runtime/supervision/plancheck.py), and stops the task when the body's path meets scan
points, then replans from where the robot stands. :class:`HazardRule` is that test and
:func:`hazard_stop` applies it to one rollout:

- a rollout that ends free is a *stop* where the rule fires first (a false alarm of the
  range noise, or a surface the path grazes);
- with ``contacts`` (the closed loop), a rollout that *touches* an obstacle is tested
  too, as the plan check tests a plan: on the way it drove up to the contact and, beyond
  it, on the rest of the task it was given (the check looks at the whole remaining
  task), with the body the contacts and the plan check use (grown by the robot's
  clearance), against the points of the rollout's own noisy world (those it touched),
  each revolution with fresh range noise and dropout; one point in the way fails the
  check, as one fails a plan. When a revolution before the contact fires, the rollout is
  a stop there, not a collision: the supervisor would have stopped and replanned. Only
  a contact no revolution before it sees coming (its returns dropped, or pushed out
  of the grown body by the range noise, in every revolution) stays a collision; one at
  the very start is seen by the revolution at the start, as the check sees a plan
  before its first task. Without ``contacts`` every contact
  is a collision (the open-loop rollout).

>>> from clomp.planner.noise import RolloutNoise
>>> HazardRule().contacts, HazardRule(contacts=True).points
(False, 2)
>>> round(HazardRule.supervisor(RolloutNoise.preset("harsh"), contacts=True).allowance, 4)
0.03
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from clomp.formal.geometry import polar_to_xy, wrap_angle
from clomp.formal.model import Disturbance, DisturbanceKind, Pose, TaskKind
from clomp.planner import footprint
from clomp.planner.engine import Outcome
from clomp.planner.noise import ALARM_DEVIATIONS, NoiseError, RolloutNoise
from clomp.planner.robot_model import RobotModel

__all__ = ["HazardRule", "hazard_stop", "path_poses"]


@dataclass(frozen=True)
class HazardRule:
    """The supervisor's interruption on the scan, applied to a rollout: every revolution
    (``scan_rate`` a second) of a task shows the scan with fresh noise, and the task is
    interrupted as soon as ``points`` or more of its returns lie inside the (uninflated)
    body anywhere along the rest of the task's path. In the world this, not a contact, is
    what stops a task that passes close to an obstacle under range noise: the model's
    ``collision`` then means "the task is interrupted", as the closed loop measures it.
    Defaults: the supervisor's ``hazard_points`` (2) and the A1 LiDAR's 5.5 Hz.

    ``allowance`` (m) is the supervisor's noise allowance (runtime/supervision/alarms.py):
    with it, only points more than ``allowance`` inside the body stop a task at once (a
    *deep* alarm); points inside the full body only stop it when the revolution before
    showed such points too (a *shallow* alarm must persist). :meth:`supervisor` gives the
    rule the supervisor applies at a noise level.

    ``contacts``: test the rollouts that touch an obstacle too (see the module
    docstring): a contact the rule sees coming is a stop, as in the closed loop; default
    False, every contact a collision (the rollouts as they were).

    >>> HazardRule().points, HazardRule().scan_rate
    (2, 5.5)
    >>> round(HazardRule.supervisor(RolloutNoise.preset("harsh")).allowance, 4), round(HazardRule.supervisor(RolloutNoise()).allowance, 4)
    (0.03, 0.005)
    """

    points: int = 2
    scan_rate: float = 5.5
    allowance: float = 0.0
    contacts: bool = False

    @classmethod
    def supervisor(cls, noise: RolloutNoise, k: float = ALARM_DEVIATIONS, clearance: float = 0.01, cap: float = 0.03,
                   contacts: bool = False) -> "HazardRule":
        """The supervisor's rule at ``noise``: its allowance, ``k`` range-noise sd less the
        planner's ``clearance``, at most ``cap`` (the defaults of the runtime's ``Alarms``)."""
        return cls(allowance=min(max(k * noise.range_sd - clearance, 0.0), cap), contacts=contacts)

    def __post_init__(self) -> None:
        if not (isinstance(self.allowance, (int, float)) and math.isfinite(self.allowance) and self.allowance >= 0):
            raise NoiseError(f"hazard allowance: expected a finite number >= 0, got {self.allowance!r}")
        if isinstance(self.points, bool) or not isinstance(self.points, int) or self.points < 1:
            raise NoiseError(f"hazard points: expected a whole number >= 1, got {self.points!r}")
        if not (isinstance(self.scan_rate, (int, float)) and math.isfinite(self.scan_rate) and self.scan_rate > 0):
            raise NoiseError(f"hazard scan_rate: expected a positive number, got {self.scan_rate!r}")
        if not isinstance(self.contacts, bool):
            raise NoiseError(f"hazard contacts: expected True or False, got {self.contacts!r}")


def path_poses(kind: TaskKind, start: Pose, end: Pose) -> np.ndarray:
    """Poses (x, y, theta) along a rollout's path from ``start`` to ``end`` (every 2 cm of a
    straight, every 5° of a turn, both ends included).

    >>> path_poses(TaskKind.STRAIGHT, Pose(0.0, 0.0), Pose(0.04, 0.0))[:, 0].tolist()
    [0.0, 0.02, 0.04]
    """
    if kind is TaskKind.STRAIGHT:
        n = max(2, int(math.ceil(start.distance_to(end.x, end.y) / 0.02)) + 1)
        f = np.linspace(0.0, 1.0, n)
        th = start.theta + f * wrap_angle(end.theta - start.theta)
        line: np.ndarray = np.c_[start.x + f * (end.x - start.x), start.y + f * (end.y - start.y), th]
        return line
    turn = wrap_angle(end.theta - start.theta)
    if kind is TaskKind.LEFT and turn < -math.pi / 2:
        turn += 2 * math.pi
    elif kind is TaskKind.RIGHT and turn > math.pi / 2:
        turn -= 2 * math.pi
    return _spin(start, turn)


def _spin(start: Pose, turn: float) -> np.ndarray:
    n = max(2, int(math.ceil(abs(turn) / math.radians(5))) + 1)
    f = np.linspace(0.0, 1.0, n)
    spin: np.ndarray = np.c_[np.full(n, start.x), np.full(n, start.y), start.theta + f * turn]
    return spin


def _beyond(out: Outcome, limit: float) -> np.ndarray:
    """The poses of the rest of the task beyond where ``out`` touched (the task was given
    ``limit``: metres of a straight, radians of a turn), at least one step of it."""
    end = out.end
    if out.task is TaskKind.STRAIGHT:
        rest = max(limit - out.distance, 0.02)
        ahead = Pose(end.x + rest * math.cos(end.theta), end.y + rest * math.sin(end.theta), end.theta)
        return path_poses(TaskKind.STRAIGHT, end, ahead)[1:]
    turned = abs(wrap_angle(end.theta - out.start.theta))
    rest = max(limit - turned, math.radians(5))
    return _spin(end, rest if out.task is TaskKind.LEFT else -rest)[1:]


def hazard_stop(out: Outcome, scan: np.ndarray | None, rng: np.random.Generator, robot: RobotModel,
                noise: RolloutNoise, rule: HazardRule, limit: float | None = None,
                touched_scan: np.ndarray | None = None) -> Outcome:
    """``out`` interrupted where ``rule`` would stop it (a new outcome, ``d_n`` the
    return that stopped it), else ``out`` itself. ``scan``: the scan as given (planner
    frame); each revolution perturbs it anew with ``rng``. ``limit``: what the task was
    given; ``touched_scan``: the points the rollout's contact is with (its noisy world's).
    Both are needed to test a contact (with ``rule.contacts``, see the module
    docstring): there the test is the plan check's, one point of the rollout's world
    (each revolution with fresh noise) in the body grown by the clearance, anywhere on
    the rest of the task."""
    touched = out.d_n is not None
    if touched:
        if not (rule.contacts and limit is not None):
            return out
        scan = touched_scan
    if scan is None or len(scan) == 0:
        return out
    poses = path_poses(out.task, out.start, out.end)
    driven = len(poses)  # the revolutions fall on the way driven; the test looks on along the task
    margin, need = 0.0, rule.points
    if touched:
        assert limit is not None
        poses = np.r_[poses, _beyond(out, limit)]
        margin, need = robot.clearance, 1  # the contacts' and the plan check's body; one point fails a plan
    reach = max(robot.front_offset, robot.rear_offset) + robot.width + 4 * noise.range_sd + 0.02 + margin
    lo, hi = poses[:, :2].min(axis=0) - reach, poses[:, :2].max(axis=0) + reach
    pts = scan[np.all((scan >= lo) & (scan <= hi), axis=1)]
    if len(pts) < need:
        return out
    revs = max(1, int(math.ceil(out.duration * rule.scan_rate)))
    r = np.hypot(pts[:, 0], pts[:, 1])
    a = np.arctan2(pts[:, 1], pts[:, 0])
    shape = (revs, len(pts))
    rr = r + rng.normal(0.0, noise.range_sd, shape) if noise.range_sd else np.broadcast_to(r, shape)
    aa = a + rng.normal(0.0, noise.angle_sd, shape) if noise.angle_sd else np.broadcast_to(a, shape)
    seen = rng.random(shape) >= noise.dropout
    xy = polar_to_xy(rr, aa)  # (revs, M, 2)
    px, py = xy[..., 0], xy[..., 1]
    dx = px[:, None, :] - poses[None, :, 0, None]
    dy = py[:, None, :] - poses[None, :, 1, None]
    c, s_ = np.cos(poses[:, 2])[None, :, None], np.sin(poses[:, 2])[None, :, None]
    u, v = dx * c + dy * s_, -dx * s_ + dy * c
    across = np.abs(v)
    inside = footprint.inside(u, across, footprint.body_box(robot, margin)) & seen[:, None, :]
    # revolution k is seen at pose index i_k and tests the rest of the path (i >= i_k)
    ahead = np.logical_or.accumulate(inside[:, ::-1, :], axis=1)[:, ::-1, :]
    at = np.minimum((np.arange(revs) / (revs * 1.0) * driven).astype(int), driven - 1)
    counts = ahead[np.arange(revs), at, :].sum(axis=1)
    alarm = counts >= need
    if rule.allowance > 0:
        a_ = rule.allowance
        deep_in = footprint.inside(u, across, footprint.body_box(robot, margin - a_)) & seen[:, None, :]
        deep_ahead = np.logical_or.accumulate(deep_in[:, ::-1, :], axis=1)[:, ::-1, :]
        deep = deep_ahead[np.arange(revs), at, :].sum(axis=1) >= need
        before = np.r_[False, alarm[:-1]]
        alarm = deep | (alarm & before)  # a shallow alarm stands when the revolution before raised one
    if touched and driven > 1:
        alarm &= at < driven - 1  # a revolution at the contact itself comes too late
    hit = np.flatnonzero(alarm)
    if len(hit) == 0:
        return out
    k = int(hit[0])
    x, y, th = poses[at[k]]
    first = int(np.flatnonzero(ahead[k, at[k]])[0])
    d_n = Disturbance(DisturbanceKind.OBSTACLE, float(px[k, first]), float(py[k, first]))
    end = Pose(float(x), float(y), float(th))
    frac = at[k] / max(driven - 1, 1)
    return replace(out, end=end, distance=out.distance * frac, duration=out.duration * frac, d_n=d_n, reached_goal=False)
