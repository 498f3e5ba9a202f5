"""After a push, move clear of what it left the robot against: the supervisor's MOVING_AWAY.

An external push (a passer-by, a bump) slides the robot 0.1-0.3 m; at ``harsh`` 18 of 20
planning collisions began 0.04-0.17 s after one that slid it into an obstacle, and most
count as collisions only because the robot then stayed touching 0.7-7 s while it settled
and replanned (note of session 6, #36 item 4). So a push the robot *felt* — a kick of
its IMU's accelerometer (:class:`~clomp.runtime.estimation.doubt.Doubt`'s ``kick`` event), or
a revolution seeing through the map it drew (``seen through``) with the estimate jumping
within :data:`LOOK_S` of it (the supervisor's ``replan_jump``: the matches followed the body
elsewhere) — is judged on the revolutions read after it (for :data:`LOOK_S`): when one has
``hazard_points`` points within ``push_margin`` of the body, the supervisor runs a short
straight or reverse (``move_away`` m) that leaves fewer of them there without meeting
another point on its way (:func:`away_move`), then plans afresh (MOVING_AWAY →
REPLANNING). A move that would not help, or that no clear way allows, is not made.

Nothing here moves the wheels unless a push was felt: without an IMU and with dead
reckoning alone (no doubt events) the supervisor behaves as before.

>>> import numpy as np
>>> from clomp.planner.robot_model import RobotModel
>>> wall = np.array([[0.10, y] for y in np.linspace(-0.2, 0.2, 21)])   # 1 cm ahead of the body's front
>>> away_move(wall, RobotModel(), 0.04, 0.12)                         # back off, not on
-0.12
>>> away_move(wall + [1.0, 0.0], RobotModel(), 0.04, 0.12) is None    # nothing near: no move
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from clomp.formal.model import TaskKind
from clomp.planner.footprint import body_box, inside
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task
from clomp.formal.geometry import wrap_angle
from clomp.runtime.supervision.states import MOTOR_STATES, Event, SupervisorState

if TYPE_CHECKING:  # pragma: no cover
    from clomp.runtime.supervision.supervisor import Supervisor

__all__ = ["LOOK_S", "PUSH_EVIDENCE", "away_move", "move_tick", "push_tick"]

PUSH_EVIDENCE = ("kick", "seen through", "seen nearer")
"""The estimator's doubt events that mean the body was moved by something else than its wheels:
a kick alone; a revolution seeing through the map only with the estimate jumping within
:data:`LOOK_S` of it; a revolution seeing surfaces nearer than the map holds them (``seen nearer``,
a push *towards* them) as seeing through. Seeing through happens without a push too (a surface the map drew
wrong, a body that moved away), and next to an obstacle a move away is then a needless
detour."""
LOOK_S = 1.0
"""A push is judged on the revolutions read after the tick it was felt in, for this long (s):
a push of 0.1-0.5 m slides the body 0.16-0.36 s on open floor, and a revolution (0.18 s at
5.5 Hz) read while it still slid may not show it against the obstacle yet. The first that
does starts the move; a contact lasting under 0.5 s and 1 cm deep is a brush."""
_STEP = 0.01  # m between the poses a move away is checked at
_JUMP = 0.02  # m beyond a tick's drive: an estimate that moved more was re-localised, not driven


def _near(local: np.ndarray, shift: float, box: tuple[float, float, float]) -> np.ndarray:
    """Which of the body-frame points ``local`` lie within ``box`` of the body moved ``shift`` m along its heading."""
    return inside(local[:, 0] - shift, np.abs(local[:, 1]), box)


def away_move(scan: np.ndarray, model: RobotModel, margin: float, distance: float, least: int = 2,
              longest: float | None = None) -> float | None:
    """The straight (positive, m) or reverse (negative) of ``distance`` to ``longest`` m (default:
    ``distance`` alone) that takes the body clear of the points of ``scan`` (robot frame) within
    ``margin`` of it, or None: none are (fewer than ``least``), or no way leaves fewer of them
    within the margin without a point entering the real body on the way (the start-touching
    rule: points already inside it may stay). Each way is driven no farther than it takes to
    leave fewer than ``least`` within the margin; of the moves that help, the one that leaves
    fewest, then the shortest; a tie backs off. Why the farther reach: a body pushed against
    a post beside it slides along it when it backs off, and 12 cm left the post at its corner
    1.4 cm away, where the scan's noise shut every turn (clutter 1/0, harsh: UNREACHABLE).
    A way goes past ``distance`` only to get clear, and only with the body touching fewer than
    ``least`` points there: past it, a body still touching a surface is dragged along it. Driven
    on 29 cm along an obstacle's side (10 points still inside the body at 13 cm, 2 of 41 left
    in the margin at the end), a body scraped it for 1.3 s (slalom 0/1, harsh); backed off the
    16 cm that left fewest (7) without being clear, it found no plan.

    >>> import numpy as np
    >>> behind = np.array([[-0.19, y] for y in np.linspace(-0.2, 0.2, 21)])
    >>> away_move(behind, RobotModel(), 0.04, 0.12)                   # against a wall behind: drive on
    0.12
    >>> post = np.array([[0.03 + 0.0465 * np.cos(a), 0.1365 + 0.0465 * np.sin(a)] for a in np.linspace(-2.6, -0.5, 15)])
    >>> away_move(post, RobotModel(), 0.04, 0.12), away_move(post, RobotModel(), 0.04, 0.12, longest=0.3)  # beside a post
    (-0.12, -0.14)
    """
    pts = np.asarray(scan, dtype=float).reshape(-1, 2)
    grown = body_box(model, margin)
    start = int(np.count_nonzero(_near(pts, 0.0, grown)))
    if start < least:
        return None
    reach = max(distance, distance if longest is None else longest)
    lengths = np.arange(distance, reach + _STEP / 2, _STEP) if reach > distance else np.array([distance])
    body = body_box(model)
    best: tuple[int, float, float] | None = None  # (points left, length, signed move)
    for sign in (-1.0, 1.0):  # reverse first: a tie backs off
        for length in lengths:
            d = sign * round(float(length), 3)
            if _blocked(pts, model, d, least):
                break  # the way meets points the body does not touch now (and so does any longer one)
            farther = abs(d) > distance + _STEP / 2
            if farther and int(np.count_nonzero(_near(pts, d, body))) >= least:
                break  # still touching what it touches now: farther only drags the body along it
            left = int(np.count_nonzero(_near(pts, d, grown)))
            helps = left < least if farther else left < start  # farther than distance only to get clear
            if helps and (best is None or (left, abs(d)) < best[:2]):
                best = (left, abs(d), d)
            if left < least:
                break  # clear: no farther
    return None if best is None else best[2]


def _felt(sup: Supervisor, now: float) -> None:
    """Note the newest push the estimator's doubt recorded since the last look (``sup._pushed_at``)."""
    est = sup.estimator
    if est is None:
        return
    events = est.doubt.events
    new, sup._push_events = events[sup._push_events:], len(events)
    if sup._pushed_at is None and any(why == PUSH_EVIDENCE[0] for _, why, _ in new):
        sup._pushed_at = now  # the first: the collision a push ends in kicks the accelerometer again
    if any(why in PUSH_EVIDENCE[1:] for _, why, _ in new):
        sup._seen_at = now
    seen, jump = sup._seen_at, sup._jumped_at
    if seen is None:
        return
    if jump is not None and abs(jump - seen) <= LOOK_S:  # seen through, and the estimate followed the body
        sup._seen_at = None
        if sup._pushed_at is None:
            sup._pushed_at = max(seen, jump)
    elif now > seen + LOOK_S:
        sup._seen_at = None  # seen through, but no jump: not a push


def push_tick(sup: Supervisor, now: float, fresh: bool) -> bool:
    """Once a tick (``fresh``: a revolution came in this tick): a push felt is judged on the
    revolutions read after the tick it was felt in, for :data:`LOOK_S`, in EXECUTING or
    REPLANNING; True when it started a move away (MOVING_AWAY)."""
    _felt(sup, now)
    at = sup._pushed_at
    cfg = sup.config
    if at is None or not fresh or cfg.move_away <= 0 or now <= at or sup.sensing.scan is None:
        return False
    if now > at + LOOK_S or sup.state not in (SupervisorState.EXECUTING, SupervisorState.REPLANNING):
        sup._pushed_at = None  # nothing near it after the slide, or a state that does not move away
        return False
    d = away_move(sup.sensing.scan, sup.model, cfg.push_margin, cfg.move_away, cfg.hazard_points,
                  cfg.move_away_longest)
    if d is None:
        return False
    sup._pushed_at = None  # one move a push
    if sup._record is not None:
        sup._end_task("pushed against an obstacle: moving away")
    sup._queue.clear()
    sup._fire(Event.MOVE_AWAY, f"pushed against an obstacle: {'backing off' if d < 0 else 'driving on'} {abs(d):.2f} m")
    pose = sup.pose
    sup._away = Task.reverse(sup.model, pose, None, -d) if d < 0 else Task.straight(sup.model, pose, None, d)
    sup._away_ticks = 0
    sup._away_left = None
    sup._log("task", task=sup._away.kind.value, phase="start", pose=pose.as_list(), reason="move away")
    move_tick(sup, now)
    return True


def move_tick(sup: Supervisor, now: float) -> None:
    """MOVING_AWAY: run the move's task on the estimate; it ends done (``moved_away``), or
    after twice its expected ticks, or when a new revolution puts a point in its way
    (``disagree``); then REPLANNING plans afresh."""
    task = sup._away
    assert task is not None
    e = task.error(sup.pose)
    left = sup._away_left
    if left is not None and abs(e - left) > sup.model.max_speed * sup.model.tick + _JUMP:
        # the estimate jumped (a re-localisation after the push), not the wheels: the move
        # is what was left of it, from where the robot now is believed to be
        pose = sup.pose
        again = Task.reverse if task.kind is TaskKind.REVERSE else Task.straight
        task = again(sup.model, pose, None, left)
        sup._away = task
        e = task.error(pose)
    sup._away_left = e
    sup._away_ticks += 1
    if task.done(e) or sup._away_ticks > 2 * task.max_ticks() + 10:
        why = "moved away" if task.done(e) else "moved away (its time spent)"
        sup._away = None
        sup._fire(Event.MOVED_AWAY, why)
        return
    if sup._check_due and sup.sensing.scan is not None:
        sup._check_due = False
        left = e if task.kind is TaskKind.STRAIGHT else -e
        if _blocked(sup.sensing.scan, sup.model, left, sup.config.hazard_points):
            sup._away = None
            sup._fire(Event.DISAGREE, "the way away is blocked")
            return
    vl, vr = task.wheel_speeds(e, wrap_angle(sup.pose.theta - task.start.theta))
    if sup.state not in MOTOR_STATES:  # pragma: no cover - the machine's table forbids it
        raise RuntimeError(f"the wheels may not turn in {sup.state.value}")
    sup.robot.set_wheel_speeds(vl, vr)
    sup._cmd = (vl, vr)
    sup.sensing.drove(sup._cmd)


def _blocked(scan: np.ndarray, model: RobotModel, left: float, least: int) -> bool:
    """``least`` points or more that the body does not touch now enter it within the ``left``
    m (negative: backwards) still to move."""
    pts = np.asarray(scan, dtype=float).reshape(-1, 2)
    body = body_box(model)
    touching = _near(pts, 0.0, body)
    steps = np.linspace(0.0, left, max(2, int(abs(left) / _STEP) + 1))[1:]
    return any(int(np.count_nonzero(_near(pts, s, body) & ~touching)) >= least for s in steps)
