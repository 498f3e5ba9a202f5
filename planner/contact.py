"""Where the body meets the sensed points: the closed forms of :mod:`clomp.planner.rollout`.

A planning run shares one :class:`Scene`: the sensed points perception kept (in surface
order) as flat arrays, and the body's extents, built once; a rollout allocates nothing
per point and builds no shape. Per position it keeps the points within reach of a step
and its turns (one pass over all points per position, shared by the straight, both turns
and their choice of angle), and per pose what is known of the way ahead (the exact gap
to the first point in the lane, or a distance known to be clear), so that a turn's choice
of angle answers the straight that follows it. Every answer is the one a pass over all
points would give, to the bit.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Pose, TaskKind, new_pose
from clomp.planner.engine import Outcome, _obstacle_disturbance
from clomp.planner.footprint import body_box, inside
from clomp.planner.perception import Obstacles
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task

__all__ = ["Scene", "cut_straight", "lane_reach", "unobstructed", "SPIN_SLACK"]

# kept beyond the swept disc, so that a point ahead is not met on the sweep's very edge (m)
SPIN_SLACK = 0.003
_EPS = 1e-9
_TWO_PI = 2 * math.pi


@functools.cache
def _lane_gap() -> Any:
    """:func:`clomp.planner._kernels.lane_gap`, imported at the first straight among points
    (numba's import is paid by a process that plans among obstacles, not by every import);
    None where numpy rounds otherwise (``_kernels.ROUNDS_AS_NUMPY``: the numpy statement runs)."""
    from clomp.planner import _kernels

    return _kernels.lane_gap if _kernels.ROUNDS_AS_NUMPY else None


@functools.cache
def _lane_gaps() -> Any:
    """:func:`clomp.planner._kernels.lane_gaps` (as :func:`_lane_gap`), or None where numpy rounds otherwise."""
    from clomp.planner import _kernels

    return _kernels.lane_gaps if _kernels.ROUNDS_AS_NUMPY else None


@functools.cache
def _turn_hits() -> Any:
    """:func:`clomp.planner._kernels.turn_hits`, or None where numpy rounds otherwise or its
    cos and sin are not the C library's (``_free_kernels.TRIG_AS_NUMPY``)."""
    from clomp.planner import _free_kernels, _kernels

    return _kernels.turn_hits if _kernels.ROUNDS_AS_NUMPY and _free_kernels.TRIG_AS_NUMPY else None


def lane_reach(robot: RobotModel) -> tuple[float, float]:
    """How much farther than a step a point ahead must be for the step to run its length
    (room to spin in place), and the gap up to which :class:`Scene` finds a straight's first
    point among the points local to its start (``Scene.spin``, ``Scene.local_gap``).

    >>> [round(v, 4) for v in lane_reach(RobotModel())]
    [0.1177, 0.3878]
    """
    spin = robot.swept_radius - robot.front_offset - robot.clearance + SPIN_SLACK if robot.free_turns else 0.0
    step = robot.step_length if robot.step_length is not None else robot.sensor_range
    return spin, step + spin + 1e-4


class Scene:
    """The run's sensed points as flat arrays, and the body's extents: what every
    rollout of one planning run shares (built once per run, nothing per query)."""

    __slots__ = (
        "obstacles", "robot", "x", "y", "z", "real", "infl", "radius2", "gaps", "clear", "reach", "spin",
        "local", "local2", "local_gap", "turns", "turned",
    )

    def __init__(self, obstacles: Obstacles, robot: RobotModel) -> None:
        self.obstacles = obstacles
        self.robot = robot
        # the points as x + iy (a frame change is one product): the points' own memory read
        # as complex, as perception built them (before, x + 1j * y: the same parts up to
        # the sign of a zero part, which no test or square tells apart); x and y are views
        self.z = np.ascontiguousarray(obstacles.points, dtype=np.float64).view(np.complex128).reshape(-1)
        self.x = self.z.real
        self.y = self.z.imag
        c = robot.clearance
        self.real = body_box(robot)
        self.infl = body_box(robot, c)
        self.radius2 = robot.swept_radius ** 2
        rear, front, half = self.infl
        self.reach = (math.hypot(rear, half), front, half)
        self.gaps: dict[tuple[float, float, float], tuple[float, int]] = {}
        # per pose, a distance the body is known to drive clear of every point (a turn's
        # choice of angle found it, over the points within its reach)
        self.clear: dict[tuple[float, float, float], float] = {}
        # how much farther than a step a point ahead must be for the step to run its length
        self.spin, far = lane_reach(robot)
        # per position, the points within reach of a step and its turns (one pass over all
        # points per position; the straight, both turns and their choice of angle share it)
        self.local2 = max(self.reach[0], math.hypot(front + far, half)) ** 2
        self.local_gap = far  # a gap up to this is found among the local points
        self.local: dict[tuple[float, float], tuple[np.ndarray, np.ndarray, bool]] = {}
        # per pose, kind and goal: the angle a turn ends at (:func:`clomp.planner.rollout.turn_angle`)
        self.turns: dict[tuple[Any, ...], float] = {}
        # per pose, kind and angle: the outcome of a turn answered with another one
        self.turned: dict[tuple[Any, ...], Outcome] = {}

    @property
    def owner(self) -> np.ndarray:
        """For every point, the index of the box that covers it (:attr:`Obstacles.owner`,
        built when a task first meets a point: a plan where nothing is met never needs it)."""
        return self.obstacles.owner

    def near(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray, bool]:
        """The points within reach of a step and its turns from (x, y): their indices
        (ascending), their offsets from (x, y) as complex numbers, and whether any lies
        within the body's swept disc (else none can be inside the body at any heading)."""
        key = (x, y)
        hit = self.local.get(key)
        if hit is None:
            # the offsets as complex numbers: their parts are x - x0 and y - y0 as floats
            # (z's parts are x and y up to the sign of a zero, which squaring drops)
            dzall = self.z - complex(x, y)
            sq = dzall.view(np.float64)
            sq = sq * sq  # one contiguous product, then re² + im² (the same sum)
            d2 = sq[0::2] + sq[1::2]
            idx = (d2 <= self.local2).nonzero()[0]
            # a point within the swept disc is within reach too (local2 >= radius2)
            body = len(d2) > 0 and bool(d2.min() <= self.radius2)
            hit = self.local[key] = (idx, dzall.take(idx), body)
        return hit

    def knows(self, s: Pose, need: float) -> bool:
        """True when :meth:`straight_gap` from ``s`` (to ``need`` metres) is remembered."""
        key = (s.x, s.y, s.theta)
        return key in self.gaps or self.clear.get(key, -1.0) >= need

    def straight_gap(self, s: Pose, need: float = math.inf) -> tuple[float, int]:
        """(distance the body can drive from ``s`` before it meets a point, that point's
        index); (inf, -1) when none, or when none is met within ``need`` metres (what the
        caller needs to know: beyond it the answer makes no difference). Remembered per
        pose (a turn's choice of angle and the straight after it ask the same question)."""
        key = (s.x, s.y, s.theta)
        hit = self.gaps.get(key)
        if hit is None:
            if need < math.inf and self.clear.get(key, -1.0) >= need:
                return math.inf, -1
            if need > self.local_gap:
                # the local points could only answer a gap within local_gap, and a gap
                # beyond it is needed too (the run to a goal dead ahead): one pass over
                # all points answers both (every point whose gap is within local_gap is
                # local, so the pass over them finds the same point)
                hit = self.gaps[key] = self._straight_gap(s)
                return hit
            d, j = self._straight_gap(s, self.near(s.x, s.y))
            if d <= self.local_gap:
                hit = self.gaps[key] = (d, j)  # every point that could be nearer is local
                return hit
            self.clear[key] = self.local_gap
            if need <= self.local_gap:
                return math.inf, -1
            hit = self.gaps[key] = self._straight_gap(s)
        return hit

    def _straight_gap(self, s: Pose, near: tuple[np.ndarray, np.ndarray, bool] | None = None) -> tuple[float, int]:
        # :meth:`_gaps` for one heading, on the points in the body's lane only (of ``near``):
        # the compiled loop of :meth:`_straight_gap_numpy` (the same arithmetic, to the bit)
        gap = _lane_gap()
        if gap is None:
            return self._straight_gap_numpy(s, near)
        cr, ci = math.cos(s.theta), -math.sin(s.theta)
        if near is None:
            d, k = gap(self.x, self.y, s.x, s.y, cr, ci, self.infl, self.real, True)
            return d, k
        dz = near[1]
        d, k = gap(dz.real, dz.imag, 0.0, 0.0, cr, ci, self.infl, self.real, near[2])
        return (d, int(near[0][k])) if k >= 0 else (d, k)

    def _straight_gap_numpy(self, s: Pose, near: tuple[np.ndarray, np.ndarray, bool] | None = None) -> tuple[float, int]:
        # :meth:`_straight_gap` as array operations (the statement the tests hold the loop to)
        rot = complex(math.cos(s.theta), -math.sin(s.theta))
        if near is None:
            w = (self.z - complex(s.x, s.y)) * rot
            body = True
        else:
            w = near[1] * rot
            body = near[2]
        rear, front, half = self.infl
        lane = (np.abs(w.imag) <= half).nonzero()[0]
        if not len(lane):
            return math.inf, -1
        lane_idx = lane if near is None else near[0].take(lane)
        w = w.take(lane)
        u = w.real
        ahead = u > front
        gap = np.where(ahead, u - front, np.inf)
        if body:
            # inside the inflated footprint at the start: the margin is waived for these
            # points, the real body still must not touch them (the start-touching rule)
            waived = ~ahead & (u >= -rear)
            if np.count_nonzero(waived):
                _, rfront, rhalf = self.real
                gap = np.where(waived & (np.abs(w.imag) < rhalf) & (u >= rfront), u - rfront, gap)
        k = int(gap.argmin())
        d = float(gap[k])
        return (d, int(lane_idx[k])) if math.isfinite(d) else (math.inf, -1)

    def _gaps(self, dz: np.ndarray, rot: np.ndarray, body: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Per heading (K, given as ``rot`` = cos h − i sin h) and point at offset ``dz``
        (complex x + iy from the start), K×N: how far the body can drive before it meets
        the point (inf when it never does), and per heading which point it meets first
        (its column: the least gap of row r is ``gap[r, k[r]]``). The same arithmetic as
        :meth:`_straight_gap`, so that the two agree to the bit. ``body``: whether any point
        lies within the body's swept disc (else none is inside the footprint at the start)."""
        w = dz * rot[:, None]  # K×N: u + iv in each task frame
        u = w.real.copy()  # contiguous: read three to five times below
        v = np.abs(w.imag)
        rear, front, half = self.infl
        lane = v <= half
        gap = np.where(lane & (u > front), u - front, np.inf)
        if body:
            # inside the inflated footprint at the start: the margin is waived for these
            # points, the real body still must not touch them (the start-touching rule).
            # The waived points the real body meets ahead are those with v < rhalf (so in
            # the lane) and rfront <= u <= front (so not ahead of the inflated front, and
            # ahead of its rear): one mask, not the waived ones first and then these
            _, rfront, rhalf = self.real
            met = (v < rhalf) & (u <= front) & (u >= rfront)
            if np.count_nonzero(met):
                gap = np.where(met, u - rfront, gap)
        return gap, gap.argmin(axis=1)

    def first_clear_each(
        self, s: Pose, groups: list[tuple[list[float], list[float], int]], straight: float | None = None
    ) -> list[int]:
        """Per turn from ``s`` (``groups``: its headings, each in (−π, π], the length of way
        each needs clear, and a fallback heading index), the index of the first heading from
        which the body, turned in place at ``s``, can drive its length without meeting a
        point; -1 when none can (the turn then ends at its fallback). Several turns at once
        (a left and a right turn: one array operation for both), and with ``straight``
        (metres) the way ahead of ``s`` itself too (the straight from ``s``, asked just
        before its turns), remembered as :meth:`straight_gap` would find it.

        Over the points within reach of the longest drive only (a nearer contact is among
        them; none nearer means clear). The reach is widened by what a step needs beyond
        its length (room to spin), so that it answers the straight that follows the turn
        too: a gap found within it is the exact :meth:`straight_gap` of the pose turned to
        that heading (every point that could be nearer is among those tested), and none
        found means the way is clear that far; either is remembered for the heading each
        turn ends at.
        """
        if len(groups) == 2:
            heads = groups[0][0] + groups[1][0]
            needs = groups[0][1] + groups[1][1]
        else:
            heads = [h for g in groups for h in g[0]]
            needs = [n for g in groups for n in g[1]]
        if not heads:
            return [-1] * len(groups)
        body, front, half = self.reach
        far = (max(needs) if straight is None else max(max(needs), straight)) + self.spin + 1e-5
        reach = max(body, math.hypot(front + far, half))
        if reach * reach <= self.local2:
            # a superset of the points within reach: the same answers
            near, dz, body = self.near(s.x, s.y)
        else:
            dz = self.z - complex(s.x, s.y)
            near = (dz.real * dz.real + dz.imag * dz.imag <= reach * reach).nonzero()[0]
            dz, body = dz.take(near), True
        kx, ky = s.x, s.y
        found = len(near) > 0
        if found:
            least, k = self._least_gaps(dz, heads if straight is None else [*heads, s.theta], body)
        if straight is not None:
            key = (kx, ky, s.theta)
            ds = least[-1] if found else math.inf
            if ds <= far:
                self.gaps.setdefault(key, (ds, int(near[k[-1]])))
            else:
                self.clear[key] = max(self.clear.get(key, 0.0), far)
        out = []
        base = 0
        for headings, _, fallback in groups:
            m = len(headings)
            if not found:
                i = 0 if m else -1
            else:
                # the first heading with its way clear (most often the first asked: no
                # array of the needs is built for the rest)
                i = -1
                for q in range(base, base + m):
                    if least[q] >= needs[q] - _EPS:
                        i = q - base
                        break
            j = i if i >= 0 else fallback
            if j >= 0:
                key = (kx, ky, headings[j])
                dj = least[base + j] if found else math.inf
                if dj <= far:
                    self.gaps.setdefault(key, (dj, int(near[k[base + j]])))
                else:
                    self.clear[key] = far
            out.append(i)
            base += m
        return out

    def _least_gaps(self, dz: np.ndarray, heads: list[float], body: bool) -> tuple[list[float], list[int]]:
        """Per heading (rad), the least gap over the points at offsets ``dz`` and the column
        of the first point that has it: :meth:`_gaps` by rows, in one compiled loop
        (``_kernels.lane_gaps``, the same arithmetic to the bit) where numpy rounds as it does."""
        cos, sin = math.cos, math.sin
        lanes = _lane_gaps()
        if lanes is not None:
            gaps, idx = lanes(dz.real, dz.imag, np.array([cos(h) for h in heads]), np.array([-sin(h) for h in heads]),
                              self.infl, self.real, body)
            return gaps.tolist(), idx.tolist()
        gap, gk = self._gaps(dz, np.array([complex(cos(h), -sin(h)) for h in heads]), body)
        # each heading's least gap read where argmin found it (gap.item(row, k[row]))
        k = gk.tolist()
        return [gap.item(q, kq) for q, kq in enumerate(k)], k

    def _turns_compiled(
        self, hits: Any, tasks: list[Task], near: np.ndarray, dx: np.ndarray, dy: np.ndarray, per_tick: float
    ) -> list[Outcome]:
        """:meth:`_turns` by ``_kernels.turn_hits`` (the same ticks, points and headings)."""
        s = tasks[0].start
        e0s = [t.start_error() for t in tasks]
        ticks = [math.ceil(e0 / per_tick - 1e-9) if e0 > 1e-9 else 0 for e0 in e0s]
        if not any(ticks):
            return [unobstructed(t) for t in tasks]
        signs = [1.0 if t.kind is TaskKind.LEFT else -1.0 for t in tasks]
        got = hits(dx, dy, s.theta, np.array(signs), np.array(e0s), np.array(ticks, dtype=np.int64), per_tick, self.infl, self.real)
        outs = []
        tick = tasks[0].robot.tick
        for t, n, k, j, head in zip(tasks, ticks, *got.tolist()):
            if not n or k > n:
                outs.append(unobstructed(t))
                continue
            done = int(k) - 1
            end = new_pose(s.x, s.y, wrap_angle(head)) if done else s
            i = int(near[int(j)])
            d_n = _obstacle_disturbance(self.obstacles, (int(self.owner[i]), float(self.x[i]), float(self.y[i])))
            outs.append(Outcome(t.kind, s, end, 0.0, done * tick, done, d_n, False))
        return outs

    def _waived_turn(self, dx: np.ndarray, dy: np.ndarray, theta: float, sign: float, per_tick: float, e0: float, ticks: int) -> int:
        """The first tick at or after which the real body meets one of these points
        (strictly outside it at the start), sampled at eight headings per tick."""
        fine = np.minimum(np.arange(1, 8 * ticks + 1) * (per_tick / 8), e0)
        th = theta + sign * fine
        c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
        u = dx * c + dy * sn
        v = np.abs(dy * c - dx * sn)
        u0 = dx * math.cos(theta) + dy * math.sin(theta)
        v0 = np.abs(dy * math.cos(theta) - dx * math.sin(theta))
        live = ~inside(u0, v0, self.real, strict=True)
        hit = np.logical_or.reduce(inside(u, v, self.real) & live, axis=1).nonzero()[0]
        return int(hit[0]) // 8 + 1 if len(hit) else ticks + 1

    def turn(self, task: Task) -> Outcome:
        """A turn among the points within its swept disc, checked at every tick heading
        (remembered when :meth:`turn_each` answered it with another turn)."""
        s = task.start
        known = self.turned.pop((s.x, s.y, s.theta, task.kind, task.limit), None)
        return known if known is not None else self.turn_each([task])[0]

    def turn_each(self, tasks: list[Task]) -> list[Outcome]:
        """:meth:`turn` for turns from one pose (a left and a right turn: one array
        operation for both); the outcomes after the first are remembered for
        :meth:`turn`."""
        s = tasks[0].start
        local, dz, body = self.near(s.x, s.y)
        if not body:
            outs = [unobstructed(t) for t in tasks]
        else:
            dx, dy = dz.real, dz.imag
            sel = (dx * dx + dy * dy <= self.radius2).nonzero()[0]
            outs = self._turns(tasks, local.take(sel), dx.take(sel), dy.take(sel))
        key = (s.x, s.y, s.theta)
        for t, out in zip(tasks[1:], outs[1:]):
            self.turned[key + (t.kind, t.limit)] = out
        return outs

    def _turns(self, tasks: list[Task], near: np.ndarray, dx: np.ndarray, dy: np.ndarray) -> list[Outcome]:
        s = tasks[0].start
        r = tasks[0].robot
        per_tick = r.turn_rate * r.tick
        hits = _turn_hits()
        if hits is not None:
            return self._turns_compiled(hits, tasks, near, dx, dy, per_tick)
        blocks = []  # per task: (sign, e0, ticks, first row)
        ths = []
        row = 0
        for t in tasks:
            e0 = t.start_error()
            ticks = math.ceil(e0 / per_tick - 1e-9) if e0 > 1e-9 else 0
            sign = 1.0 if t.kind is TaskKind.LEFT else -1.0
            blocks.append((sign, e0, ticks, row))
            if ticks:
                ths.append(s.theta + _tick_turns(sign, ticks, per_tick, e0))
                row += ticks + 1
        if not ths:
            return [unobstructed(t) for t in tasks]
        th = ths[0] if len(ths) == 1 else np.concatenate(ths)
        c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
        u = dx * c + dy * sn
        v = np.abs(dy * c - dx * sn)
        met = inside(u, v, self.infl)
        waived = met[0]  # every block's first row is the start heading
        any_waived = bool(np.count_nonzero(waived))
        if any_waived:
            met = np.where(waived, inside(u, v, self.real), met)
            # exempt: strictly inside the real body at the start (a point on its edge is not)
            met[:, inside(u[0], v[0], self.real, strict=True)] = False
        hit_rows = np.logical_or.reduce(met, axis=1)
        outs = []
        for t, (sign, e0, ticks, first) in zip(tasks, blocks):
            if not ticks:
                outs.append(unobstructed(t))
                continue
            rows = hit_rows[first + 1 : first + ticks + 1].nonzero()[0]
            k = int(rows[0]) + 1 if len(rows) else ticks + 1  # the first tick in contact
            if any_waived:
                # a point within the margin is held to the real body, with no margin for the
                # corner's path between ticks: test it at eight headings per tick
                k = min(k, self._waived_turn(dx[waived], dy[waived], s.theta, sign, per_tick, e0, ticks))
            if k > ticks:
                outs.append(unobstructed(t))
                continue
            at = met[first + k]
            j = int(near[int(np.argmax(at))]) if np.count_nonzero(at) else int(near[np.flatnonzero(waived)[0]])
            done = k - 1
            end = new_pose(s.x, s.y, wrap_angle(float(th[first + done]))) if done else s
            d_n = _obstacle_disturbance(self.obstacles, (int(self.owner[j]), float(self.x[j]), float(self.y[j])))
            outs.append(Outcome(t.kind, s, end, 0.0, done * r.tick, done, d_n, False))
        return outs


_TICKS: dict[tuple[float, int, float, float], np.ndarray] = {}


def _tick_turns(sign: float, ticks: int, per_tick: float, e0: float) -> np.ndarray:
    """The signed heading change at each tick of a turn by ``e0`` (read-only; remembered:
    turns end at a few marks, so the same few arrays serve every plan).

    >>> _tick_turns(1.0, 3, 0.1, 0.25).tolist()
    [0.0, 0.1, 0.2, 0.25]
    """
    key = (sign, ticks, per_tick, e0)
    arr = _TICKS.get(key)
    if arr is None:
        if len(_TICKS) >= 512:
            _TICKS.clear()
        arr = sign * np.minimum(np.arange(ticks + 1) * per_tick, e0)
        arr.flags.writeable = False
        _TICKS[key] = arr
    return arr


def cut_straight(task: Task, d: float, obstacles: Obstacles, i: int, x: float, y: float) -> Outcome:
    """A STRAIGHT whose front meets a point after ``d`` metres (inf: never)."""
    r = task.robot
    s = task.start
    e0 = task.start_error()
    if d >= e0 or not math.isfinite(d):
        return unobstructed(task, e0=e0)
    per_tick = r.straight_speed * r.tick
    k = max(1, math.ceil(d / per_tick - 1e-12))  # the first tick whose travel reaches the point
    done = k - 1
    travel = done * per_tick
    c, sn = math.cos(s.theta), math.sin(s.theta)
    end = new_pose(s.x + travel * c, s.y + travel * sn, s.theta) if done else s
    d_n = _obstacle_disturbance(obstacles, (i, x, y))
    return Outcome(task.kind, s, end, travel, done * r.tick, done, d_n, False)


def unobstructed(task: Task, frontier: bool = False, e0: float | None = None) -> Outcome:
    """The outcome of a task that nothing interrupts, in closed form.

    Both controllers drive their error down linearly at full rate and cover the rest in
    the last tick (see :mod:`clomp.planner.tasks`), so the end pose is the start moved by the
    initial error and the duration is the number of ticks that takes. ``e0`` is the
    task's :meth:`~clomp.planner.tasks.Task.start_error` when the caller has it.
    """
    r = task.robot
    s = task.start
    if e0 is None:
        e0 = task.start_error()
    kind = task.kind
    straight = kind is TaskKind.STRAIGHT
    per_tick = r.straight_speed * r.tick if straight else r.turn_rate * r.tick
    ticks = math.ceil(e0 / per_tick - 1e-9) if e0 > 1e-9 else 0
    if not ticks:
        return Outcome(kind, s, s, 0.0, ticks * r.tick, ticks, None, False, frontier)
    if straight:
        th = s.theta
        end = new_pose(s.x + e0 * math.cos(th), s.y + e0 * math.sin(th), th)
        return Outcome(kind, s, end, e0, ticks * r.tick, ticks, None, False, frontier)
    # clomp.formal.geometry.wrap_angle(s.theta + sign * e0), inline (the same arithmetic)
    h = math.fmod(s.theta + (e0 if kind is TaskKind.LEFT else -e0) + math.pi, _TWO_PI)
    if h <= 0:
        h += _TWO_PI
    return Outcome(kind, s, new_pose(s.x, s.y, h - math.pi), 0.0, ticks * r.tick, ticks, None, False, frontier)
