"""The supervisor in a world that moves (issue #42, ``SupervisorConfig(moving=True)``): telling
moving from static, and running WAIT and REVERSE.

- **Telling moving from static** (:class:`Appearance`): the scan a plan was made from is the
  *reference*. Points of a later planning scan that lie where the reference's rays passed
  through free space (nearer, along their bearing, than the reference's returns on that
  bearing and both neighbours, by ``margin``) appeared since: possibly moving. They are
  handed to the planner (``Configurator.transient``), which offers a WAIT before a detour.
  When a WAIT times out with the way still blocked, what appeared *stayed*: the reference
  is renewed from the next planning scan, so it is static there and planned round.
- **WAIT** (:func:`wait_tick`): the wheels stay stopped; every tick the next task of the
  plan is tested against the newest clean scan from the pose now (the hazard test over its
  whole length). Clear: the WAIT ends and the plan goes on. Still blocked after
  ``wait_timeout`` s: a disagreement, and a fresh plan round what stayed.
- **REVERSE** runs as any task: its wheels turn backwards (:meth:`clomp.planner.tasks.Task.wheel_speeds`),
  and the hazard test sweeps the body *backwards* over what is left of it, so a point the
  newest scan shows behind interrupts it.

>>> import numpy as np
>>> from clomp.planner.robot_model import RobotModel
>>> a = Appearance(RobotModel())
>>> wall = np.array([[0.8, y] for y in np.linspace(-0.3, 0.3, 31)])
>>> a.transient(wall, Pose(0.0, 0.0)) is None      # no reference yet: nothing is known to have appeared
True
>>> a.renew(wall, Pose(0.0, 0.0))
>>> person = np.array([[0.4, y] for y in np.linspace(-0.1, 0.1, 11)])
>>> mask = a.transient(np.vstack([wall, person]), Pose(0.0, 0.0))
>>> int(mask.sum()), bool(mask[:31].any())
(11, False)
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from clomp.formal.geometry import relative
from clomp.formal.model import Pose, TaskKind
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task
from clomp.runtime.supervision.alarms import hazard_hits
from clomp.runtime.supervision.execution import task_for
from clomp.runtime.supervision.plancheck import check_plan

if TYPE_CHECKING:  # pragma: no cover
    from clomp.runtime.supervision.supervisor import Supervisor

__all__ = ["Appearance", "wait_tick", "scan_to"]

_BINS = 180  # bearing bins of the reference (2° each)


def scan_to(points: np.ndarray, taken: Pose, frame: Pose) -> np.ndarray:
    """Points seen from ``taken`` (robot frame there) in the robot frame at ``frame``.

    >>> scan_to(np.array([[1.0, 0.0]]), Pose(0.5, 0.0), Pose(0.0, 0.0)).tolist()
    [[1.5, 0.0]]
    """
    rel = relative(frame, taken)
    c, s = math.cos(rel.theta), math.sin(rel.theta)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    out: np.ndarray = np.c_[rel.x + c * p[:, 0] - s * p[:, 1], rel.y + s * p[:, 0] + c * p[:, 1]]
    return out


class Appearance:
    """The reference scan and what appeared since (see the module). ``margin`` (m): how much
    nearer than the reference's returns a point must be; ``least``: the fewest appeared
    points that count (fewer are range noise)."""

    def __init__(self, model: RobotModel, margin: float = 0.1, least: int = 3) -> None:
        self.model, self.margin, self.least = model, margin, least
        self.reference: tuple[np.ndarray, Pose] | None = None
        self.stale = False  # a WAIT timed out: what appeared stayed; renew the reference at the next plan

    def renew(self, scan: np.ndarray, pose: Pose) -> None:
        """Make ``scan`` (robot frame at ``pose``, the supervisor's frame) the reference."""
        self.reference = (np.asarray(scan, dtype=float).reshape(-1, 2).copy(), pose)
        self.stale = False

    def transient(self, scan: np.ndarray, pose: Pose) -> np.ndarray | None:
        """A mask over ``scan`` (robot frame at ``pose``): True on the points that appeared where
        the reference saw free space; None when fewer than ``least`` did (or no reference)."""
        if self.reference is None or self.stale or len(scan) == 0:
            return None
        ref, at = self.reference
        near = np.full(_BINS, np.inf)
        if len(ref):
            b = _bin(ref)
            np.minimum.at(near, b, np.hypot(ref[:, 0], ref[:, 1]))
        lowest = np.minimum(np.minimum(near, np.roll(near, 1)), np.roll(near, -1))
        pts = scan_to(scan, pose, at)  # the new points seen from where the reference was taken
        r = np.hypot(pts[:, 0], pts[:, 1])
        mask: np.ndarray = (r <= self.model.sensor_range) & (r < lowest[_bin(pts)] - self.margin)
        return mask if int(mask.sum()) >= self.least else None


def _bin(pts: np.ndarray) -> np.ndarray:
    b: np.ndarray = ((np.arctan2(pts[:, 1], pts[:, 0]) + math.pi) / (2 * math.pi) * _BINS).astype(int) % _BINS
    return b


def wait_tick(sup: "Supervisor", task: Task) -> str | None:
    """One control tick of a WAIT (see the module): count the time, end it when the next task
    is clear; a reason to plan anew when ``wait_timeout`` has passed with the way still blocked."""
    tick = sup.model.tick
    task.waited += tick
    if _next_clear(sup):
        task.limit = task.waited  # the way ahead cleared: the WAIT's error is zero, the plan goes on
        return None
    if task.waited >= sup.config.wait_timeout - 1e-9:
        sup.appearance.stale = True  # what appeared stayed: static from the next plan on
        return f"waited {task.waited:.1f} s and the way ahead is still blocked: planning round what stayed"
    return None


def _next_clear(sup: "Supervisor") -> bool:
    """Whether the rest of the plan, run from the pose now, is free of the newest clean scan:
    the next task's hazard test, then the plan check of every queued task."""
    s = sup.sensing
    if not sup._queue or s.clean_scan is None or sup._plan is None or sup._record is None:
        return False
    q, _ = sup._queue[0]
    if q.task is TaskKind.WAIT:
        return False
    nxt = task_for(q, sup._plan.result, sup._plan.to_frame(q.end), sup.model, sup.pose, sup.goal)
    pts = scan_to(s.clean_scan, s.scan_pose, sup.pose)
    if hazard_hits(pts, nxt.kind, nxt.error(sup.pose), sup.model, sup.config.lookahead) != (0, 0):
        return False
    states = [sup._record.state] + [t for t, _ in sup._queue]
    verdict = check_plan(states, sup._plan.origin, s.scan_pose, sup.goal, s.clean_scan, sup.model,
                         tolerance=sup.config.end_tolerance, running=True)
    return verdict.ok

