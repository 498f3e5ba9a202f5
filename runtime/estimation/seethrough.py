"""Seeing past the map: which bearings of a revolution contradict the surfaces the map holds,
judged against the bearings that *could* show a displacement (issue #36).

A robot that stands elsewhere than its estimate sees past the surfaces it drew: the return
at a bearing lies beyond the map's nearest surface there (:func:`see_through`). That is
evidence the matcher cannot hide (it pairs near the estimate, within its reach), but how
much of it to ask for depends on what the scene could show. A robot pushed 0.19 m along a
room 2.3 m long (``stopper`` seed 37, at ``harsh`` without the gyro: nothing felt the push)
sees past the end walls only; the long side walls, parallel to the push, look the same from
where it is and from where it believes it is. Counted against every bearing with a surface
(13-20 of 135-160), the evidence stayed under a fifth of them and the run ended GOAL_REACHED
0.214 m off, believing a 0.068 m bound. Counted against the bearings that a displacement
along the room would move past their surface (48-52), those seeing past as it would (11-16)
are a fifth to a third: the two revolutions after the push contradict the map.

:func:`see_through_along` therefore also gives, for each of ``directions`` displacements of
``step`` m (the matcher's first reach: a smaller one it pulls back itself), how many bearings
see past and how many could: those where the map's range profile from the estimate moved by
that displacement lies ``margin`` beyond the profile from the estimate, or holds no surface
within ``reach``. A bearing whose expected range barely changes (a wall parallel to the
displacement) cannot testify for it, so it does not dilute the evidence
(:meth:`~clomp.runtime.estimation.doubt.Doubt.seen`).

A robot pushed *towards* surfaces sees them nearer than the map, not past it
(:func:`see_nearer`): that is judged by the whole revolution's fit to the map at poses
around the estimate, since one body nearer than it was is common and innocent.

>>> room = np.array([[x, y] for x in (-1.0, 1.0) for y in np.linspace(-0.3, 0.3, 31)]
...                 + [[x, y] for y in (-0.35, 0.35) for x in np.linspace(-1.0, 1.0, 101)])
>>> seen = see_through_along(room, room - [0.2, 0.0], Pose(0.0, 0.0, 0.0))  # truly 0.2 m along +x
>>> seen.through < 0.2 * seen.both                      # a few against the whole room ...
True
>>> seen.through, seen.both, seen.along[0]               # ... a third of what a push along +x could show
(14, 158, (14, 40))
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from clomp.formal.geometry import points_to_frame
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import ring_neighbours
from clomp.runtime.estimation._gridfit import misfit_grid

__all__ = ["Nearer", "Through", "see_nearer", "see_through", "see_through_along"]


class Through(NamedTuple):
    """What a revolution shows against the map (:func:`see_through_along`): ``through``
    bearings see past a surface the map holds, of ``both`` where the map holds one;
    ``along[k]``: (of those seeing past, those that could show the ``k``-th displacement;
    how many could)."""

    through: int
    both: int
    along: tuple[tuple[int, int], ...]


class Nearer(NamedTuple):
    """What a revolution shows nearer than the map (:func:`see_nearer`): ``near`` bearings
    see a surface more than a margin nearer than the map's, of ``both`` where both hold
    one; ``gain``: how much better (misfit, chi-square units) the whole revolution fits
    the map at the best pose near the estimate than at the estimate (0: not searched);
    ``shift`` (m): how far that pose lies from the estimate."""

    near: int
    both: int
    gain: float
    shift: float


def _profile(x: np.ndarray, y: np.ndarray, r: np.ndarray, bins: int) -> np.ndarray:
    """The nearest range per bearing (``bins`` a turn; inf where nothing is)."""
    out = np.full(bins, np.inf)
    np.minimum.at(out, _bearing(x, y, bins), r)
    return out


def _bearing(x: np.ndarray, y: np.ndarray, bins: int) -> np.ndarray:
    """The bearing bin of each point (``bins`` a turn, the first at -π)."""
    width = 2 * math.pi / bins
    out: np.ndarray = np.floor((np.arctan2(y, x) + math.pi) / width).astype(int) % bins
    return out


def _drawn(every: np.ndarray, pose: Pose, reach: float, bins: int) -> np.ndarray:
    """The map's range profile (robot frame) from ``pose``: its points within ``reach``; only
    those in a square a little wider than ``reach`` are turned into the robot frame (each
    point's arithmetic is its own, so the profile is the one the whole map gives)."""
    box = reach + 1e-6
    inside = (np.abs(every[:, 0] - pose.x) <= box) & (np.abs(every[:, 1] - pose.y) <= box)
    local = points_to_frame(every[inside], pose)
    mx, my = local[:, 0], local[:, 1]
    mr = np.hypot(mx, my)
    near = mr <= reach
    return _profile(mx[near], my[near], mr[near], bins)


def _drawn_from(every: np.ndarray, centres: list[tuple[float, float]], theta: float, reach: float, bins: int) -> np.ndarray:
    """:func:`_drawn` from each of ``centres`` (facing ``theta``) in one pass over the map:
    row ``j`` is ``_drawn(every, Pose(*centres[j], theta), reach, bins)`` bit for bit (each
    point's offset from a centre, its turn and its bearing are the same arithmetic, and the
    nearest per bearing does not depend on the order; :func:`_drawn`'s square only spares
    work, as a point outside it lies beyond ``reach``). The displaced profiles of
    :func:`see_through_along` read the map once, not once per displacement (issue #41)."""
    out = np.full(len(centres) * bins, np.inf)
    if not centres or not len(every):
        return out.reshape(len(centres), bins)
    offset = every[None, :, :] - np.asarray(centres, dtype=float)[:, None, :]  # as points_to_frame subtracts a centre
    local = points_to_frame(offset.reshape(-1, 2), Pose(0.0, 0.0, theta))  # less nothing, then the same turn
    mx, my = local[:, 0], local[:, 1]
    mr = np.hypot(mx, my)
    near = mr <= reach
    which = np.nonzero(near.reshape(len(centres), -1))[0]  # the centre each point was seen from
    np.minimum.at(out, which * bins + _bearing(mx[near], my[near], bins), mr[near])  # as _profile
    return out.reshape(len(centres), bins)


def _displaced(every: np.ndarray, pose: Pose, steps: tuple[float, ...], directions: int, reach: float,
               bins: int) -> np.ndarray:
    """The map's profiles from ``pose`` displaced by each of ``steps`` towards each of
    ``directions`` headings (steps outer, as :func:`see_through_along` counts them)."""
    centres = []
    for step in steps:
        for k in range(directions):
            phi = 2 * math.pi * k / directions
            u = np.array([math.cos(phi), math.sin(phi)])
            centres.append((pose.x + step * u[0], pose.y + step * u[1]))
    return _drawn_from(every, centres, pose.theta, reach, bins)


def _through(map_points: np.ndarray, points: np.ndarray, pose: Pose, margin: float, bins: int, reach: float,
             empty: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bearings seeing past the map (:func:`see_through`), the map's profile and the map."""
    every = np.asarray(map_points, dtype=float).reshape(-1, 2)
    drawn = _drawn(every, pose, reach, bins)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    seen = _profile(pts[:, 0], pts[:, 1], np.hypot(pts[:, 0], pts[:, 1]), bins)
    both = np.isfinite(seen) & np.isfinite(drawn)
    past = both & (seen > drawn + margin)
    # a bearing counts with both its neighbours: at a surface's edge one bearing sees past it
    after, before = ring_neighbours(past, 1)  # np.roll(past, 1), np.roll(past, -1)
    past &= after & before
    # no return at all where the map's surface lies well within the LiDAR's range, five
    # bearings in a row (a small post drawn from many revolutions spans a few more
    # bearings than one revolution's rays hit)
    gone = ~np.isfinite(seen) & (drawn <= empty)
    g1, g_1, g2, g_2 = ring_neighbours(gone, 2)
    gone &= g1 & g_1 & g2 & g_2
    return past | gone, drawn, every


def see_through(map_points: np.ndarray, points: np.ndarray, pose: Pose, *, margin: float = 0.1,
                bins: int = 180, reach: float = 1.2, empty: float = 0.9) -> tuple[int, int]:
    """How many bearings of a revolution ``points`` (robot frame) seen from ``pose`` look
    *through* a surface the map holds there: the return lies more than ``margin`` (m) beyond
    the map's nearest point at that bearing (``bins`` bearings a turn; map points within
    ``reach`` m), and so do both neighbouring bearings (one alone is a surface's edge) — or
    has no return at all where the map's is within ``empty`` m (well inside the LiDAR's
    range), five bearings in a row (a dropout is one). A robot moved
    where its estimate does not know sees past the surfaces it drew, whatever the matcher
    pairs: evidence that does not depend on the matcher's reach. Returns (such bearings,
    bearings where the map holds a surface).

    >>> wall = np.array([[0.5, y] for y in np.linspace(-0.3, 0.3, 31)])
    >>> see_through(wall, wall, Pose(0.0, 0.0, 0.0))
    (0, 31)
    >>> see_through(wall, wall + [0.2, 0.0], Pose(0.0, 0.0, 0.0))[0] > 10   # it stands 0.2 m back of where it thinks
    True
    """
    if not len(map_points) or not len(points):
        return 0, 0
    through, drawn, _ = _through(map_points, points, pose, margin, bins, reach, empty)
    return int(through.sum()), int(np.isfinite(drawn).sum())


def see_through_along(map_points: np.ndarray, points: np.ndarray, pose: Pose, *, steps: tuple[float, ...] = (0.15,),
                      directions: int = 16, least: int = 10, clear: float = 0.09, margin: float = 0.1, bins: int = 180,
                      reach: float = 1.2, empty: float = 0.9) -> Through:
    """:func:`see_through` (same ``margin``, ``bins``, ``reach``, ``empty``), and when at least
    ``least`` bearings see past (fewer cannot contradict the map, however few could show a
    displacement), for each displacement of each of ``steps`` m towards each of
    ``directions`` headings (the k-th at ``2πk/directions`` in the map's frame; the steps
    outer): the bearings it explains and the bearings that could show it (see the module
    docstring). A bearing *could* show it when the map holds a surface there from ``pose``
    and, from ``pose`` displaced so, either none within ``reach`` or one more than ``margin``
    farther; it is *explained* when it sees past and its return lies within ``margin`` of
    that farther surface (or the displaced map holds none to compare with). A displacement
    whose way passes within ``clear`` m of a map point (the body's half-width: the point
    would lie inside the body) is not one the robot underwent, and counts (0, 0): a body
    that stood at the robot's nose and left (``stopper``) otherwise reads as a push
    through where it stood. A body that left
    (a person stepping away from the robot's side) is seen past too, but what lies behind it
    is far beyond where a push-sized displacement would move its surface: it explains
    nothing, and a few bearings seeing past cannot make a displacement's case.

    >>> wall = np.array([[0.5, y] for y in np.linspace(-0.3, 0.3, 31)])
    >>> see_through_along(wall, wall + [0.15, 0.0], Pose(0.0, 0.0, 0.0)).along[8]   # truly 0.15 m back of it
    (21, 31)
    >>> see_through_along(wall, wall, Pose(0.0, 0.0, 0.0)).along   # nothing seen past: nothing to weigh
    ()
    """
    if not len(map_points) or not len(points):
        return Through(0, 0, ())
    through, drawn, every = _through(map_points, points, pose, margin, bins, reach, empty)
    has = np.isfinite(drawn)
    if int(through.sum()) < least:
        return Through(int(through.sum()), int(has.sum()), ())
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    seen = _profile(pts[:, 0], pts[:, 1], np.hypot(pts[:, 0], pts[:, 1]), bins)
    box = reach + max(steps, default=0.0) + 1e-6  # what a displaced pose can reach (the rest of the map cannot count)
    every = every[(np.abs(every[:, 0] - pose.x) <= box) & (np.abs(every[:, 1] - pose.y) <= box)]
    along = []
    rel = every - [pose.x, pose.y]
    moved_all = _displaced(every, pose, steps, directions, reach, bins)  # the map read once for every displacement
    for step in steps:
        for k in range(directions):
            phi = 2 * math.pi * k / directions
            u = np.array([math.cos(phi), math.sin(phi)])
            ahead = rel @ u  # the body sweeps the points ahead of it on the way, within ``clear`` of its line
            if bool(((ahead > 0.0) & (ahead <= step + clear) & (np.abs(rel @ [-u[1], u[0]]) < clear)).any()):
                along.append((0, 0))  # the body would pass through a surface the map holds: not a push it underwent
                continue
            moved = moved_all[len(along)]  # _drawn(every, Pose(pose.x + step * u[0], pose.y + step * u[1], pose.theta), ...)
            none = ~np.isfinite(moved)
            could = has & (none | (moved > drawn + margin))
            near = np.isfinite(seen) & ~none
            near[near] = np.abs(seen[near] - moved[near]) <= margin
            explained = through & could & (none | near)
            along.append((int(explained.sum()), int(could.sum())))
    return Through(int(through.sum()), int(has.sum()), tuple(along))


def see_nearer(map_points: np.ndarray, points: np.ndarray, pose: Pose, *, least: int = 10, margin: float = 0.1,
               bins: int = 180, reach: float = 1.2, radius: float = 0.4, turns: tuple[float, ...] = (-0.05, 0.0, 0.05),
               sd: float = 0.02, correlation: float = 4.0) -> Nearer:
    """The mirror of :func:`see_through`: how many bearings of a revolution ``points`` (robot
    frame) seen from ``pose`` see a surface more than ``margin`` (m) *nearer* than the map's
    nearest point there (``bins`` bearings a turn; map points within ``reach``), and, when at
    least ``least`` do, whether the whole revolution says the robot stands elsewhere.

    A robot pushed towards surfaces (issue #36: ``overtaking`` 34/0 at ``harsh`` without the
    gyro, pushed 0.3 m back along its corridor beside the box) sees them nearer than its map,
    not past it, and nothing of what :func:`see_through_along` weighs. But a surface seen
    nearer is common for innocent reasons too — a moving body, an obstacle newly seen — so
    the bearings alone do not judge: the revolution is placed at every pose within ``radius``
    m of ``pose`` (every 2 cm, at its heading turned by each of ``turns`` rad, 0 among them; :func:`~clomp.runtime.estimation._gridfit.misfit_grid`
    over the map points within ``reach`` + ``radius``, the revolution's within ``reach``) and
    the misfit at ``pose`` is compared with the best. One object nearer (a body that moved)
    leaves the rest of the view where the map holds it: moving the robot to explain that
    object misplaces every other surface the move changes, and the estimate stays the best
    or nearly. A displacement of the whole view is explained by one pose elsewhere
    (``shift``), far better than by the estimate (``gain``): 116 and 61 in 34/0's two
    revolutions after the push, 0-16 in the revolutions where the estimate was right.

    >>> room = np.array([[x, y] for x in (-1.0, 1.0) for y in np.linspace(-0.6, 0.6, 61)]
    ...                 + [[x, y] for y in (-0.6, 0.6) for x in np.linspace(-1.0, 1.0, 101)])
    >>> seen = see_nearer(room, room - [0.25, 0.0], Pose(0.0, 0.0, 0.0))    # truly 0.25 m towards +x
    >>> seen.near >= 10, seen.gain > 40, round(seen.shift, 2)
    (True, True, 0.24)
    >>> see_nearer(room, room, Pose(0.0, 0.0, 0.0))                          # where it believes: nothing
    Nearer(near=0, both=180, gain=0.0, shift=0.0)
    """
    if not len(map_points) or not len(points):
        return Nearer(0, 0, 0.0, 0.0)
    every = np.asarray(map_points, dtype=float).reshape(-1, 2)
    drawn = _drawn(every, pose, reach, bins)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    r = np.hypot(pts[:, 0], pts[:, 1])
    seen = _profile(pts[:, 0], pts[:, 1], r, bins)
    both = np.isfinite(seen) & np.isfinite(drawn)
    near = both & (seen < drawn - margin)
    n, nb = int(near.sum()), int(both.sum())
    if n < least:
        return Nearer(n, nb, 0.0, 0.0)
    box = reach + radius + 1e-6
    ref = every[(np.abs(every[:, 0] - pose.x) <= box) & (np.abs(every[:, 1] - pose.y) <= box)]
    mine = pts[r <= reach]
    if len(ref) < least or len(mine) < least:
        return Nearer(n, nb, 0.0, 0.0)
    grid = misfit_grid(ref, mine, pose, radius=radius, headings=turns, sd=sd, correlation=correlation)
    cost, offs = grid.cost, grid.offsets
    h, a, b = np.unravel_index(int(np.argmin(cost)), cost.shape)
    mid = len(offs) // 2
    return Nearer(n, nb, float(cost[turns.index(0.0), mid, mid] - cost[h, a, b]), float(math.hypot(offs[a], offs[b])))
