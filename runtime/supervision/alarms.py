"""The supervisor's alarms under sensor noise: the hazard test and the plan check.

Both ask whether scan points lie in the body's path. A LiDAR's range noise puts points
of a surface beside the path inside it now and then (under the ``harsh`` preset, 2.5 cm
against the planner's 1 cm clearance), and each such alarm costs a stop and a replan.
:class:`Alarms` keeps a measured **noise allowance** and decides which alarms stand:

- the allowance is ``k`` times the range noise the revolutions show
  (:func:`range_noise`, the median over the last ``window`` revolutions) less the
  planner's clearance (1 cm: the margin it plans with already absorbs that much), at most
  ``cap``. At the ``paper`` preset (5 mm; 5–7 mm measured) it is about 0.5 cm; at
  ``harsh`` (2.5 cm) the cap, 3 cm. ``k`` is 3, the usual bound for Gaussian noise: at
  1.5 (0 at ``paper``) a LiDAR whose ranges are rounded to 1 cm put points of a wall 1 cm
  beside the path inside the body often enough that the demo replanned 9 times;
- a *deep* alarm — points more than the allowance inside the body (the body shrunk by
  the allowance on every side still meets them) — stands at once, in the revolution
  that shows it: an obstacle truly in the way is never driven on;
- a *shallow* alarm — only the full body meets the points — stands when the previous
  revolution raised one too (it persisted over two revolutions), or when the robot is
  within ``near`` of where an alarm of its kind last stood; otherwise, seen once, it is
  noted and the task goes on. Range noise is drawn anew each revolution, a surface is not.
  The hazard test and the plan check ask the surface itself too: a shallow alarm that
  the last revolutions fused (median range per bearing, each placed where it was taken) do
  not raise is the noise's and does not stand. At ``harsh`` a surface 1.5-2 cm beside the
  path puts points inside the body in most single revolutions, in a row, while their
  median lies outside (in 20 harsh overtaking runs, 46 of the 74 check alarms acted on
  were false before the check asked the fused revolutions, 10 of 29 after).

A shallow alarm is therefore acted on at most one revolution late (about 0.18 s at
5.5 Hz, 1.8 cm at the straight speed); everything deeper than the allowance at once.

>>> a = Alarms()
>>> a.revolution(np.c_[np.full(50, 0.5), np.linspace(-0.3, 0.3, 50)])  # a noise-free wall
>>> round(a.allowance, 2), a.stands("hazard", deep=False)
(0.0, False)
>>> a.revolution(np.c_[np.full(50, 0.5), np.linspace(-0.3, 0.3, 50)])
>>> a.stands("hazard", deep=False), a.stands("check", deep=True)
(True, True)
"""

from __future__ import annotations

import functools
import math
from collections import deque
from collections.abc import Callable

import numpy as np

from clomp.formal.model import Pose, State, TaskKind
from clomp.planner.footprint import body_box, inside
from clomp.planner.noise import ALARM_DEVIATIONS
from clomp.planner.robot_model import RobotModel
from clomp.runtime.jit import interruptible
from clomp.runtime.supervision._contacts_core import sweep_hits
from clomp.runtime.supervision.plancheck import CheckResult, check_plan
from clomp.runtime.supervision.records import sweep

__all__ = ["Alarms", "hazard_hits", "range_noise"]


def range_noise(points: np.ndarray) -> float:
    """The range noise a revolution shows (m, a standard deviation): the robust spread of
    the second differences of range between neighbouring bearings. Along a surface the
    range changes smoothly from one bearing to the next, so what is left is the noise
    (√6 σ for independent noise on three ranges); corners, edges and gaps are outliers
    the median ignores. 0 for fewer than 8 points.

    >>> rng = np.random.default_rng(0)
    >>> a = np.linspace(-1.0, 1.0, 200)
    >>> r = 0.6 / np.cos(a) + rng.normal(0.0, 0.02, 200)  # a wall 0.6 m ahead, 2 cm range noise
    >>> round(range_noise(np.c_[r * np.cos(a), r * np.sin(a)]), 2)
    0.02
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(pts) < 8:
        return 0.0
    order = np.argsort(np.arctan2(pts[:, 1], pts[:, 0]))
    r = np.hypot(pts[order, 0], pts[order, 1])
    d2 = r[2:] - 2.0 * r[1:-1] + r[:-2]
    return float(1.4826 * np.median(np.abs(d2)) / math.sqrt(6.0))


def hazard_hits(points: np.ndarray, kind: TaskKind, error: float, m: RobotModel, lookahead: float,
                allowance: float = 0.0) -> tuple[int, int]:
    """How many ``points`` (robot frame now) the body meets in the next ``lookahead`` s of
    the task and over all of its remaining ``error``, the body shrunk by ``allowance``.

    Points strictly inside the real body where it stands are not counted: the planner's
    and the plan check's start-touching rule (the robot's own returns, or range noise of
    a surface beside it; a surface it truly touches shows points outside the body too).
    A robot stopped beside a box otherwise sees the box's noisy returns inside its side
    in most revolutions and never moves again.

    >>> beside = np.array([[0.0, -0.08], [0.02, -0.085]])  # inside the right side, 1 cm deep
    >>> hazard_hits(beside, TaskKind.STRAIGHT, 0.3, RobotModel(), 0.5)
    (0, 0)
    >>> hazard_hits(np.array([[0.12, 0.0], [0.2, 0.02]]), TaskKind.STRAIGHT, 0.3, RobotModel(), 0.5)  # ahead: soon, later
    (1, 2)
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= m.length + error + 0.05] if len(pts) else pts
    if len(pts):
        own = inside(pts[:, 0], np.abs(pts[:, 1]), body_box(m), strict=True)
        pts = pts[~own]
    if len(pts) == 0:
        return 0, 0
    rate = m.turn_rate if kind.is_turn else m.straight_speed
    xs, ys = pts[:, 0].copy(), pts[:, 1].copy()
    return (_hits(xs, ys, _sweep_frames(kind, min(error, rate * lookahead)), m, allowance),
            _hits(xs, ys, _sweep_frames(kind, error), m, allowance))


@functools.lru_cache(maxsize=256)
def _sweep_frames(kind: TaskKind, amount: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The poses of :func:`~clomp.runtime.supervision.records.sweep` as the compiled count
    takes them: x, y and the headings' cosines and sines (Python's, as the frame change
    takes them), read-only. Cached: the look-ahead's sweep (``rate × lookahead``) is the
    same every tick of a task, and building it was a fifth of the hazard test (issue #41)."""
    poses = sweep(kind, amount)
    th = poses[:, 2].tolist()
    out = (np.ascontiguousarray(poses[:, 0]), np.ascontiguousarray(poses[:, 1]),
           np.array([math.cos(t) for t in th]), np.array([math.sin(t) for t in th]))
    for a in out:
        a.setflags(write=False)
    return out


def _hits(xs: np.ndarray, ys: np.ndarray, frames: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
          m: RobotModel, allowance: float) -> int:
    """:func:`~clomp.runtime.supervision.records.hits` of the points (``xs``, ``ys``) at the
    sweep's ``frames`` (:func:`_sweep_frames`), the count the same bit for bit, in one
    compiled loop (the array calls per pose were a tenth of a planning run's CPU; issue #41)."""
    rear, front, half = body_box(m, -allowance)
    return int(interruptible(sweep_hits, xs, ys, *frames, rear, front, half))


class Alarms:
    """The noise allowance and the memory of shallow alarms; see the module docstring.

    ``k``: the allowance in range-noise standard deviations, less the planner's
    ``clearance`` (m, which already absorbs that much); ``cap`` (m): its upper bound;
    ``window``: how many revolutions the noise estimate spans; ``near`` (m): within that
    distance of where an alarm of a kind last stood, a shallow one stands at once (a
    robot stopped and replanned where its path grazes a surface does not creep on into
    it, one revolution a plan).
    """

    def __init__(self, k: float = ALARM_DEVIATIONS, cap: float = 0.03, window: int = 10, near: float = 0.05,
                 clearance: float = 0.01) -> None:
        if not (k >= 0 and math.isfinite(k)) or not (cap >= 0 and math.isfinite(cap)) or window < 1 or not near >= 0:
            raise ValueError(f"Alarms needs k >= 0, cap >= 0, window >= 1 and near >= 0, got {k!r}, {cap!r}, "
                             f"{window!r}, {near!r}")
        self.k, self.cap, self.near, self.clearance = k, cap, near, clearance
        self._noise: deque[float] = deque(maxlen=window)
        self._median: float | None = None  # the median of _noise, once asked after a revolution
        self._revolution = 0
        self._raised: dict[str, int] = {}  # the last revolution each kind of alarm was raised in
        self._before: dict[str, int] = {}  # and the one before that
        self._stood: dict[str, Pose] = {}  # where an alarm of each kind last stood
        self.deferred = 0  # shallow alarms not acted on (seen once, or not in the revolutions fused)
        self._dismissed = -1  # the last revolution a shallow hazard alarm was dismissed as the noise's

    @property
    def noise(self) -> float:
        """The range noise (m, a standard deviation) the last revolutions show (0 before any)."""
        return self._noise_median() if self._noise else 0.0

    @property
    def allowance(self) -> float:
        """How far (m) inside the body a point must be for an alarm to stand at once: the
        part of ``k`` noise deviations the planner's clearance does not already absorb."""
        if not self._noise:
            return 0.0
        return min(max(self.k * self._noise_median() - self.clearance, 0.0), self.cap)

    def _noise_median(self) -> float:
        """``float(np.median(self._noise))``, computed once a revolution: the hazard test asks
        the allowance every tick (a median every tick was 2 % of a planning run; issue #41)."""
        if self._median is None:
            self._median = float(np.median(self._noise))
        return self._median

    def revolution(self, points: np.ndarray) -> None:
        """A new revolution: measure its range noise."""
        self._revolution += 1
        if len(points) >= 8:
            self._noise.append(range_noise(points))
            self._median = None

    def stands(self, kind: str, deep: bool, at: Pose | None = None) -> bool:
        """Whether an alarm of ``kind`` raised now, in this revolution, with the robot ``at``
        (its pose estimate), stands (see the module)."""
        first = self._raised.get(kind) != self._revolution
        if first:  # the first of this revolution: remember the revolution of the one before
            self._before[kind] = self._raised.get(kind, -2)
            self._raised[kind] = self._revolution
        last = self._stood.get(kind)
        near = at is not None and last is not None and math.hypot(at.x - last.x, at.y - last.y) <= self.near
        if deep or near or self._before[kind] == self._revolution - 1:
            if at is not None:
                self._stood[kind] = at
            return True
        self.deferred += first
        return False

    def hazard(self, points: np.ndarray, kind: TaskKind, error: float, m: RobotModel, lookahead: float,
               needed: int, at: Pose | None = None,
               recent: np.ndarray | Callable[[], np.ndarray | None] | None = None) -> str | None:
        """The hazard test's verdict on this tick: a reason to interrupt, or None.

        ``recent``: the last revolutions fused (median range per bearing, robot frame now),
        or a function that fuses them, called only when a shallow alarm asks (fusing every
        tick cost a planning run a sixth of its CPU; issue #41). A shallow alarm that they
        do not raise is the noise's, not the surface's: the surface, placed by several
        revolutions, is clear of the body's path."""
        soon, ahead = hazard_hits(points, kind, error, m, lookahead)
        if max(soon, ahead) < needed:
            return None
        deep = hazard_hits(points, kind, error, m, lookahead, self.allowance) if self.allowance > 0 else (soon, ahead)
        is_deep = max(deep) >= needed
        fused = None if is_deep or recent is None else recent() if callable(recent) else recent
        if fused is not None and max(hazard_hits(fused, kind, error, m, lookahead)) < needed:
            self.deferred += self._dismissed != self._revolution  # once a revolution, as :meth:`stands` counts
            self._dismissed = self._revolution
            return None
        if not self.stands("hazard", is_deep, at):
            return None
        if soon >= needed:
            return "collision imminent: the scan shows an obstacle against the body's next move"
        return "an obstacle the plan did not predict is in the way"

    def check(self, states: list[State], origin: Pose, pose: Pose, goal: Pose, points: np.ndarray, m: RobotModel,
              tolerance: tuple[float, float], running: bool,
              recent: Callable[[], np.ndarray | None] | None = None) -> CheckResult:
        """:func:`check_plan` on this revolution; a failure that only the full body sees
        stands when the previous revolution's check failed too, unless ``recent()`` (the last
        revolutions fused, robot frame at ``pose``; asked only then) passes the check: the
        surface, placed by several revolutions, is clear of the plan's path, as in :meth:`hazard`."""
        verdict = check_plan(states, origin, pose, goal, points, m, tolerance=tolerance, running=running)
        if verdict.ok:
            return verdict
        deep = self.allowance <= 0 or not check_plan(states, origin, pose, goal, points, m, tolerance=tolerance,
                                                     running=running, allowance=self.allowance).ok
        if deep or "meets an obstacle" not in verdict.reason:
            # an end off the map's prediction is the pose's error, not the sensor's: it stands
            self.stands("check", True, pose)
            return verdict
        fused = recent() if recent is not None else None
        if fused is not None and check_plan(states, origin, pose, goal, fused, m, tolerance=tolerance, running=running).ok:
            self.deferred += 1
            return CheckResult(True, f"{verdict.reason}: not in the last revolutions fused, the noise's",
                               verdict.tasks, verdict.duration_s)
        if self.stands("check", False, pose):
            return verdict
        return CheckResult(True, f"{verdict.reason}: within the noise allowance ({self.allowance * 100:.1f} cm), "
                                 f"seen once", verdict.tasks, verdict.duration_s)
