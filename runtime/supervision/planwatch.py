"""The supervisor's watch over its plan: the hazard test, the plan check and recall.

:class:`PlanWatch` is the part of :class:`clomp.runtime.supervision.supervisor.Supervisor` that
asks whether the plan still holds on what the LiDAR now shows, and what of the map the
robot can reuse when it does not:

- every control tick, :meth:`PlanWatch.hazard`: scan points in the body's remaining path
  (:meth:`clomp.runtime.supervision.alarms.Alarms.hazard`);
- every revolution while executing, :meth:`PlanWatch.check`: the running task and the
  queued ones tested against the newest revolution
  (:meth:`clomp.runtime.supervision.alarms.Alarms.check`, i.e.
  :func:`clomp.runtime.supervision.plancheck.check_plan` with the noise allowance);
- the fused revolutions that judge shallow alarms (:meth:`PlanWatch._fused`) hold only
  the revolutions that agree with the newest (:func:`misplaced`): one the estimate placed
  wrong, after a push or a slip it does not model, would outvote the newest;
- first in REPLANNING, :meth:`PlanWatch.recall`: a plan continued from a state of the map
  the robot already has (:func:`clomp.runtime.supervision.plancheck.recall`), at most
  ``max_recalls`` in a row before the supervisor explores anew;
- a fresh plan, :func:`plan_deepening` (:mod:`clomp.planner.deepening`, the one-shot
  commands' too): when the search spends its budget, the same scan is searched again with
  a larger one (a spent budget's plan ends at argmin φ, which can lie inside a trap);
- progress: :meth:`PlanWatch.started` notes where each plan (fresh or recalled) began,
  :meth:`PlanWatch.stalled` counts the plans in a row that ended before the robot moved.
  After two such plans recall is skipped (a plan interrupted where it began is not
  continued again: a fresh plan from the current estimate instead); after ``max_stuck``
  the supervisor gives up with the reason, rather than stand by an obstacle recalling
  until its time runs out.

It keeps the records of every check and recall (with wall and thread CPU times) and the
map's recall index, built when a fresh plan is made (:meth:`PlanWatch.planned`). The
supervisor keeps the state machine, the task queue and the wheels.

>>> from clomp.planner.robot_model import RobotModel
>>> watch = PlanWatch(RobotModel())
>>> watch.checks, watch.recalls, watch.index is None
([], [], True)
"""

from __future__ import annotations

import math
import time
from collections import deque
from typing import Any, Protocol

import numpy as np

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Pose, State
from clomp.planner.configurator import PlanResult
from clomp.planner.deepening import plan_deepening
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task
from clomp.runtime.estimation.fusion import fuse_revolutions
from clomp.runtime.supervision.alarms import Alarms
from clomp.runtime.supervision._contacts_core import warm_up as contacts_warm_up
from clomp.runtime.supervision.plancheck import Recall, RecallIndex, recall
from clomp.runtime.supervision.records import PlanRecord, TimedRecord, scan_to_frame

__all__ = ["LogFn", "PlanWatch", "misplaced", "plan_deepening"]


def misplaced(newest: np.ndarray, older: np.ndarray, noise: float, near: float = 0.6, tolerance: float = 0.015,
              least: int = 12) -> float | None:
    """How far (m) ``older``, a revolution placed in ``newest``'s frame by the pose estimate,
    puts the surfaces near the robot from where ``newest`` sees them, when beyond what range
    noise explains; None when they agree (or too few bearings to tell).

    Per 1° bearing bin within ``near`` m (both revolutions' mean range), the median absolute
    range difference: two readings of one surface differ by the noise of both,
    0.954 ``noise`` in the median, so a misplacement shows as the excess beyond that plus
    ``tolerance``. Only where a surface appears matters to an alarm: a shift along a wall
    leaves the wall where it was, and the median ignores edges and shadows.

    >>> a = np.linspace(-1.2, 1.2, 120)
    >>> wall = np.c_[np.full(120, 0.4), 0.4 * np.tan(a)]  # a wall 0.4 m ahead
    >>> misplaced(wall, wall + [0.005, 0.0], 0.005) is None, round(misplaced(wall, wall + [0.1, 0.0], 0.005), 2)
    (True, 0.11)
    """
    def ranges(pts: np.ndarray) -> np.ndarray:
        out = np.full(360, np.nan)
        if len(pts):
            r = np.hypot(pts[:, 0], pts[:, 1])
            b = np.mod(np.degrees(np.arctan2(pts[:, 1], pts[:, 0])).astype(int) + 360, 360)
            n = np.bincount(b, minlength=360)
            s = np.bincount(b, weights=r, minlength=360)
            out[n > 0] = s[n > 0] / n[n > 0]
        return out

    rn = ranges(np.asarray(newest, dtype=float).reshape(-1, 2))
    ro = ranges(np.asarray(older, dtype=float).reshape(-1, 2))
    both = np.isfinite(rn) & np.isfinite(ro) & (np.minimum(rn, ro) <= near)
    if int(both.sum()) < least:
        return None
    off = float(np.median(np.abs(rn[both] - ro[both])))
    return off if off > 0.954 * noise + tolerance else None


class LogFn(Protocol):
    """Where the watch writes its events (the supervisor's run log)."""

    def __call__(self, event: str, **fields: Any) -> None: ...


def _no_log(event: str, **fields: Any) -> None:
    del event, fields


class PlanWatch:
    """Hazard test, plan check and recall for one supervisor run; see the module docstring.

    ``model``: the robot the plans are for; ``log``: called with each check and recall.
    """

    def __init__(self, model: RobotModel, log: LogFn = _no_log) -> None:
        self.model = model
        self.log = log
        self.alarms = Alarms(clearance=model.clearance)  # the hazard test's and the plan check's noise allowance
        self.checks: list[TimedRecord] = []
        self.recalls: list[TimedRecord] = []
        self.index: RecallIndex | None = None
        self.recalls_in_a_row = 0
        self.stuck = 0  # plans in a row that ended before the robot moved (see :meth:`stalled`)
        self._from: Pose | None = None
        self._recent: deque[tuple[np.ndarray, Pose]] = deque(maxlen=3)  # the newest clean revolutions, where taken
        self.unfused = 0  # times a kept revolution disagreed with the newest and was left out of the fusion
        contacts_warm_up()  # the compiled plan check is ready before the robot moves

    def started(self, pose: Pose) -> None:
        """A plan, fresh or recalled, starts executing with the robot at ``pose``."""
        self._from = pose

    def stalled(self, pose: Pose, min_progress: float, min_turn: float = 0.1) -> int:
        """REPLANNING is deciding with the robot at ``pose``: how many plans in a row ended
        before it moved ``min_progress`` m or turned ``min_turn`` rad from where they began
        (0 once one moved it).

        >>> w = PlanWatch(RobotModel())
        >>> w.started(Pose(0.0, 0.0)); w.stalled(Pose(0.01, 0.0), 0.03)
        1
        >>> w.started(Pose(0.01, 0.0)); w.stalled(Pose(0.01, 0.0), 0.03)
        2
        >>> w.started(Pose(0.01, 0.0)); w.stalled(Pose(0.2, 0.0), 0.03)
        0
        """
        if self._from is None:
            return self.stuck
        a = self._from
        moved = math.hypot(pose.x - a.x, pose.y - a.y) >= min_progress or abs(wrap_angle(pose.theta - a.theta)) >= min_turn
        self.stuck = 0 if moved else self.stuck + 1
        self._from = None
        return self.stuck

    def planned(self, result: PlanResult) -> float:
        """A fresh plan was made: index its map for recall; returns the seconds that took
        (part of making the map: the caller times it with the plan)."""
        self.index = RecallIndex(result.map, plan=result.plan, psi=result.psi)
        self.recalls_in_a_row = 0
        return self.index.build_s

    def hazard(self, clean_scan: np.ndarray | None, scan_pose: Pose, pose: Pose, task: Task, error: float,
               lookahead: float, needed: int) -> str | None:
        """A reason to interrupt when the newest clean scan (taken at ``scan_pose``) has
        points in the body's remaining path from ``pose``: deep at once, shallow when it persists."""
        if clean_scan is None or len(clean_scan) == 0:
            return None
        self._remember(clean_scan, scan_pose)
        pts = scan_to_frame(clean_scan, scan_pose, pose)
        recent = (lambda: self._fused(pose)) if self.alarms.allowance > 0 else None  # fused only when asked
        return self.alarms.hazard(pts, task.kind, error, self.model, lookahead, needed, pose, recent)

    def _remember(self, clean_scan: np.ndarray, scan_pose: Pose) -> None:
        """Keep the newest clean revolution, where it was taken (once, however often asked)."""
        if not self._recent or self._recent[-1][0] is not clean_scan:
            self._recent.append((clean_scan, scan_pose))

    def _fused(self, frame: Pose) -> np.ndarray | None:
        """The kept revolutions that agree with the newest (:func:`misplaced`), fused in the
        robot frame at ``frame``; None when fewer than two agree. A revolution the estimate
        placed wrong (a push, a slip between the revolutions: motion it does not model) is
        not fused: its surfaces stand where they no longer are, and a true alarm would be
        dismissed as the noise's (issue: harsh, a push 0.14 m, a turn dismissed three
        revolutions running, then a contact)."""
        if len(self._recent) < 2:
            return None
        placed = [scan_to_frame(s, p, frame) for s, p in self._recent]
        noise = self.alarms.noise
        kept = [s for s in placed[:-1] if misplaced(placed[-1], s, noise) is None] + [placed[-1]]
        if len(kept) < len(placed):
            self.unfused += 1
        if len(kept) < 2:
            return None
        return fuse_revolutions(kept)

    def check(self, states: list[State], plan: PlanRecord, scan_pose: Pose, goal: Pose, clean_scan: np.ndarray,
              tolerance: tuple[float, float], t: float) -> TimedRecord:
        """Test ``states`` (the running task first, then the queued ones) of ``plan``
        against the newest revolution, seen from ``scan_pose``; recorded at time ``t``."""
        t0, c0 = time.perf_counter(), time.thread_time()  # everything the check needs: it tests the raw points
        self._remember(clean_scan, scan_pose)
        verdict = self.alarms.check(states, plan.origin, scan_pose, goal, clean_scan, self.model, tolerance,
                                    running=True, recent=lambda: self._fused(scan_pose))  # fused only when asked
        rec = TimedRecord(t, time.perf_counter() - t0, verdict.ok, verdict.reason, time.thread_time() - c0)
        self.checks.append(rec)
        self.log("check", ok=rec.ok, duration_s=rec.duration_s, reason=rec.reason)
        return rec

    def recall(self, last: PlanRecord | None, pose: Pose, goal: Pose, scan: np.ndarray, tolerance: tuple[float, float],
               max_recalls: int, t: float) -> Recall | None:
        """REPLANNING's first try: a plan continued from a state of ``last``'s map where the
        robot is at ``pose``, its tasks free on ``scan``; None: explore anew."""
        if last is None or self.recalls_in_a_row >= max_recalls:  # recalls leading nowhere
            self.recalls.append(TimedRecord(t, 0.0, False, "skipped: explore anew"))
            return None
        if self.stuck >= 2:  # the last plans ended where they began: do not continue them again
            self.recalls.append(TimedRecord(t, 0.0, False, f"skipped: {self.stuck} plans in a row ended before the robot "
                                                           f"moved; explore anew from the current estimate"))
            return None
        c0 = time.thread_time()  # ``took``: everything a recall needs (the map's index is built with the plan)
        found, why, took = recall(last.result, last.origin, pose, goal, scan, self.model,
                                  check_tolerance=tolerance, index=self.index)
        self.recalls.append(TimedRecord(t, took, found is not None, why, time.thread_time() - c0))
        self.log("recall", ok=found is not None, duration_s=took, reason=why)
        if found is not None:
            self.recalls_in_a_row += 1
        return found
