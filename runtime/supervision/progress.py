"""Whether the supervisor's plans still get the robot anywhere: :class:`Progress`.

The counts behind UNREACHABLE (see :mod:`clomp.runtime.supervision.supervisor`): plans in
a row that found no safe task (``confirm``), plans that backed off with none between that
found a task without (``confirm`` too), plans in a row that brought the robot no closer to
the goal (``patience``), plans that in ``stall_time`` seconds brought it less than
``real_progress`` closer (a count of plans misses deep plans that each creep a few
centimetres on: a cul-de-sac or a shut door ran into the time limit, HALTED, after 9-25
plans), and the recalled continuations already taken (the same
one again, after tasks of it ran and no closer than before, is a loop).

Progress in time is judged at *every* plan the robot sets out on (fresh, backing off or
recalled; issue #36): judged only at fresh plans that did not back off, a cul-de-sac that
alternated a back-off plan with a frontier plan (each ending the other's count of
``confirm``) left the judgement one point in 85 s and ran into the time limit (cul-de-sac
17/0, harsh, gyro). A WAIT that timed out (:meth:`Progress.world_changed`) excuses the time
it stood, not the search before it: wiping the record at every such WAIT let a shut door
whose wall looked new after each correction of the estimate search for ever (shut 23/0, 32/0).

>>> from clomp.runtime.supervision.config import SupervisorConfig
>>> p = Progress(SupervisorConfig(patience=2))
>>> p.planned(False, 1.0), p.planned(False, 1.0), p.planned(False, 1.0)
(None, None, 'goal unreachable: 2 plans in a row brought it no closer')
"""

from __future__ import annotations

import math
from typing import Any

from clomp.formal.model import TaskKind
from clomp.runtime.supervision.config import SupervisorConfig

__all__ = ["Progress", "backs_off"]


class Progress:
    """The supervisor's judgement of progress over its plans (see the module docstring).

    >>> from clomp.runtime.supervision.config import SupervisorConfig
    >>> p = Progress(SupervisorConfig(confirm=2))
    >>> p.no_safe_task(), p.no_safe_task()
    (None, 'goal unreachable: no safe task leads closer to the goal (on 2 scans in a row)')
    """

    def __init__(self, config: SupervisorConfig) -> None:
        self.config = config
        self.empty = 0  # plans in a row, each from fresh revolutions at this stop, that found no safe task
        self.backoffs = 0  # plans that backed off since the last plan that found a task without
        self.best = math.inf  # the closest to the goal (m) a plan started from
        self.stalled = 0  # plans in a row that started no closer than ``best``
        self._recalled: dict[tuple[int, int], tuple[float, int]] = {}  # (map, state) -> distance, tasks done
        self.closest = math.inf  # the closest to the goal (m) any plan (fresh, backing off, recalled) started from
        self._history: list[tuple[float, float]] = []  # (search time s, closest m) at each plan judged in time
        self._excused = 0.0  # seconds stood waiting for the world (a WAIT that timed out): not search time

    def backed_off(self, dist: float, now: float | None = None) -> str | None:
        """A plan made ``dist`` m from the goal found no safe task of the paper's three and
        backs off (``back_off``: it begins with REVERSE) without reaching the goal (one that
        reaches it is progress, :meth:`planned`): the reason to give up after
        ``confirm`` such plans with no progress between (no plan that found a task without
        backing off, none begun closer to the goal by ``min_progress``), else None. So a
        robot cannot back off and come back for ever (in a cul-de-sac it did until the time
        limit). ``now`` (s, the run's time; None: not judged in time): it is judged in time
        too (:meth:`stalled_for`).

        >>> p = Progress(SupervisorConfig(confirm=2))
        >>> p.backed_off(1.0), p.backed_off(0.99)
        (None, 'goal unreachable: no safe task leads closer to the goal (backed off 2 times in a row)')
        >>> p.backed_off(0.5) is None  # closer: the count begins again
        True
        """
        if dist < self.best - self.config.min_progress:
            self.backoffs = 0
        self.best = min(self.best, dist)
        self.backoffs += 1
        if self.backoffs >= self.config.confirm:
            return f"goal unreachable: no safe task leads closer to the goal (backed off {self.backoffs} times in a row)"
        return None if now is None else self.stalled_for(now, dist)

    def no_safe_task(self) -> str | None:
        """A plan found no safe task: the reason to give up after ``confirm`` in a row, else
        None (a verdict from one fused scan: stand, take fresh revolutions, plan again)."""
        self.empty += 1
        if self.empty < self.config.confirm:
            return None
        return ("goal unreachable: no safe task leads closer to the goal"
                + (f" (on {self.empty} scans in a row)" if self.empty > 1 else ""))

    def planned(self, reached_goal: bool, dist: float, now: float | None = None) -> str | None:
        """A plan with tasks, made ``dist`` m from the goal (``reached_goal``: it ends there) at
        ``now`` s (the run's time; None: not judged in time): the reason to give up after
        ``patience`` plans in a row that came no closer, or when the plans of the last
        ``stall_time`` s brought it less than ``real_progress`` closer (:meth:`stalled_for`),
        else None. Progress is what the robot achieved, not what a plan to the disc's rim promised."""
        self.empty = self.backoffs = 0
        if reached_goal or dist < self.best - self.config.min_progress:
            self.stalled = 0
        else:
            self.stalled += 1
            if self.stalled >= self.config.patience:
                return f"goal unreachable: {self.stalled} plans in a row brought it no closer"
        self.best = min(self.best, dist)
        if now is None or reached_goal:
            return None
        return self.stalled_for(now, dist)

    def stalled_for(self, now: float, dist: float = math.inf) -> str | None:
        """Progress in time: a plan sets out ``dist`` m from the goal at ``now`` s (the run's
        time); the reason to give up when the closest any plan started from by then is less
        than ``real_progress`` below the closest known ``stall_time`` s of search before
        (plans judged for at least that long; time excused by :meth:`world_changed` is not
        search), else None. A few centimetres now and then is no progress.

        >>> p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1))
        >>> [p.planned(False, d, t) for t, d in ((0.0, 1.0), (20.0, 0.96), (31.0, 0.92))]
        [None, None, 'goal unreachable: 0.08 m closer in the last 30 s (needs 0.1 m)']
        >>> p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1))
        >>> [p.planned(False, d, t) for t, d in ((0.0, 1.0), (20.0, 0.96), (31.0, 0.85))]
        [None, None, None]
        """
        cfg = self.config
        self.closest = min(self.closest, self.best, dist)
        now -= self._excused
        self._history.append((now, self.closest))
        if cfg.stall_time <= 0 or now - self._history[0][0] < cfg.stall_time:
            return None
        before = min((b for t, b in self._history if t <= now - cfg.stall_time), default=self._history[0][1])
        gain = before - self.closest
        if gain < cfg.real_progress:
            return (f"goal unreachable: {max(gain, 0.0):.2f} m closer in the last {cfg.stall_time:g} s "
                    f"(needs {cfg.real_progress:g} m)")
        return None

    def world_changed(self, waited: float = 0.0) -> None:
        """What stood in the way turned out to stay (a WAIT timed out after ``waited`` s, issue
        #42): the plans before were made for another world, so their count of plans that came
        no closer starts again, and the time stood waiting is not search time. The search in
        time before it still counts: a WAIT can time out again and again where the estimate
        makes a wall look new (a shut door searched until the time limit).

        >>> from clomp.runtime.supervision.config import SupervisorConfig
        >>> p = Progress(SupervisorConfig(patience=2))
        >>> p.planned(False, 1.0), p.planned(False, 1.0)  # the first sets the best distance
        (None, None)
        >>> p.world_changed(); p.planned(False, 1.0) is None  # without it: 'goal unreachable: 2 plans …'
        True
        """
        self.stalled = 0
        self._excused += max(waited, 0.0)

    def recalled(self, dist: float = math.inf, now: float | None = None) -> str | None:
        """A recalled plan runs, ``dist`` m from the goal at ``now`` s (None: not judged in time):
        an earlier empty one no longer counts towards ``confirm``; the reason to give up when
        the plans of the last ``stall_time`` s brought it too little closer (:meth:`stalled_for`),
        else None.

        >>> p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1))
        >>> p.planned(False, 1.0, 0.0), p.recalled(0.97, 31.0)
        (None, 'goal unreachable: 0.03 m closer in the last 30 s (needs 0.1 m)')
        """
        self.empty = 0
        return None if now is None else self.stalled_for(now, dist)

    def loops(self, key: tuple[int, int], dist: float, done: int) -> bool:
        """True when the recalled continuation ``key`` (map, state) was taken before, ``done``
        tasks ago, and the robot is no closer (``dist`` m) than then: a loop (a cul-de-sac's
        zig-zag, recalled five times over 90 s, ran into the time limit). Else it is noted.

        >>> p = Progress(SupervisorConfig())
        >>> p.loops((1, 2), 0.5, 0), p.loops((1, 2), 0.5, 3)
        (False, True)
        """
        before = self._recalled.get(key)
        if before is not None and done > before[1] and dist >= before[0] - self.config.min_progress:
            return True
        self._recalled[key] = (dist, done)
        return False


def backs_off(result: Any, recovery: bool) -> bool:
    """True when ``result`` (a plan result) is ``back_off``'s plan, not to the goal: its first
    task is a REVERSE though the configurator plans without (``recovery`` False), because no
    task of the paper's three was free. :meth:`Progress.backed_off` counts such plans, fresh
    or recalled.

    >>> import numpy as np
    >>> from clomp.planner import Configurator
    >>> backs_off(Configurator().plan(np.zeros((0, 2)), (1.0, 0.0)), False)
    False
    """
    steps = result.plan.states
    return not (recovery or result.reached_goal) and len(steps) > 1 and result.map[steps[1]].task is TaskKind.REVERSE
