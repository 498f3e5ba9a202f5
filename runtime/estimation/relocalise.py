"""Where the robot stands after a kick, by the map drawn before it: :func:`relocalise`.

A kick (issue #36) slides the body 0.1-0.3 m between two revolutions; the matcher, whose
correspondences reach a few centimetres, pairs what it sees after the kick near the
prediction, and the surfaces seen from then on join the map where that estimate draws
them. So the map drawn *after* the kick cannot tell where the robot is, and the doubt
(:class:`~clomp.runtime.estimation.doubt.Doubt`) keeps a floor of a kick's size under
the bound (0.37-0.41 m at the goal in every pushed pty run of session 6, even one truly
0.022 m off). The map drawn *before* the kick can: :func:`relocalise` places the
revolution at every pose of a grid around the estimate (as wide as a push, a few headings
about the IMU's) and scores each by how far its points fall from that map (a distance
field, so thousands of poses cost one lookup each; point-to-point, so a face's *ends*
count, not only its line: one 20 cm face seen from the start is all the ``overtaking``
scene gives). The best is *well supported* only when

- it pairs enough of the revolution (``least_inliers``, and ``least_paired`` points),
- it is *unique*: no pose farther than ``apart`` from it explains the revolution within
  ``unique`` of its misfit (chi-square units, ``correlation`` neighbouring points counted
  as one; 30, as the ``better`` of :func:`~clomp.runtime.estimation.confirm.ambiguity`):
  a corridor's axis, or a scene that matches twice, leaves the doubt where it is,
- and it is not on the search's edge.

Its ``sd`` is how far that pose may be off: the farthest pose explaining the revolution
nearly as well (within ``unique``, as a 95 % bound), and the uncertainty of the map points it met
(each drawn as uncertain as the estimate that drew it).

>>> room = np.array([[1.0, y] for y in np.linspace(-0.6, 0.6, 61)] + [[x, 0.6] for x in np.linspace(-0.6, 1.0, 81)]
...                 + [[-0.6, y] for y in np.linspace(-0.6, 0.6, 61)])
>>> sds = np.zeros((len(room), 2))
>>> seen = room - [0.2, -0.1]                  # kicked: it stands at (0.2, -0.1), believing (0, 0)
>>> r = relocalise(room, sds, seen, Pose(0.0, 0.0, 0.0))
>>> r.pose is not None and abs(r.pose.x - 0.2) < 0.01 and abs(r.pose.y + 0.1) < 0.01, r.sd < 0.01
(True, True)
>>> wall = np.array([[x, 0.5] for x in np.linspace(-3.0, 3.0, 301)])
>>> relocalise(wall, np.zeros((301, 2)), wall[100:200], Pose(0.0, 0.0, 0.0)).pose is None   # along a wall: anywhere
True
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from clomp.formal.geometry import compose, points_from_frame, relative
from clomp.formal.model import Pose
from scipy.spatial import cKDTree

from clomp.runtime.estimation._gridfit import misfit_grid
from clomp.runtime.estimation.doubt import Doubt
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.estimation.icp import ReferenceScan, match_scans

__all__ = ["HEADINGS", "KickMemory", "Relocalisation", "SEEN_MOVED", "relocalise"]

HEADINGS: tuple[float, ...] = (-0.1, -0.05, 0.0, 0.05, 0.1)
"""The headings (rad, about the estimate's) searched: the IMU keeps the heading, a push off
the centre turns the body a little."""
SEEN_MOVED: tuple[str, ...] = ("seen through", "seen nearer")
"""The doubt's events (:meth:`~clomp.runtime.estimation.doubt.Doubt.seen`) that keep the map drawn
before them for the wide search (:meth:`KickMemory.seen_moved`), as a shock does."""


@dataclass(frozen=True)
class Relocalisation:
    """The outcome of :func:`relocalise`. ``pose``: the well-supported pose (None: none is);
    ``sd`` (m): how far it may be off (inf without one); ``inliers``: the share of the
    revolution it pairs; ``spread`` (m): the farthest pose from it explaining the revolution
    about as well; ``rival`` (m): the nearest pose farther than ``apart`` explaining it
    nearly as well (inf: none); ``why``: in words; ``edge``: the best lay on the search's edge
    (a wider search may find it)."""

    pose: Pose | None
    sd: float
    inliers: float
    spread: float
    rival: float
    why: str
    edge: bool = False


def relocalise(map_points: np.ndarray, map_sds: np.ndarray, points: np.ndarray, pose: Pose, *,
               radius: float = 0.4, step: float = 0.02, headings: tuple[float, ...] = HEADINGS,
               min_points: int = 10, sd: float = 0.02, correlation: float = 4.0, reach: float = 3.0,
               apart: float = 0.15, unique: float = 30.0, least_inliers: float = 0.6,
               least_paired: int = 20, sigmas: float = 2.45, most_points: int = 100,
               bound_margin: float | None = None) -> Relocalisation:
    """The revolution ``points`` (robot frame), believed seen from ``pose``, placed at every
    pose of a grid (``step`` m, within ``radius`` m of ``pose``, at each of ``headings``)
    over ``map_points`` (map frame; ``map_sds[:, 0]``: how wrong each may be, m); see the
    module docstring. Each pose's misfit: each point's squared distance to the map in
    ``sd`` (at most ``reach``), over ``correlation``. Well supported: the best pairs at
    least ``least_inliers`` of the points (``least_paired`` of them) within ``reach`` sd,
    no pose farther than ``apart`` from it is within ``unique`` of its misfit, and it is
    not on the search's edge (the grid scores every k-th point, at most ``most_points``:
    a wall-rich revolution's 400 points cost 0.5 s on a busy machine); then its ``sd`` counts the farthest pose within ``unique``
    (as a ``sigmas`` bound: conservative, ``unique`` is five times chi-square's 95 % point
    with two degrees of freedom), the map's uncertainty where it meets it, and the grid.
    ``bound_margin`` (default ``unique``): the misfit margin of the poses whose reach sets
    ``sd`` (6, chi-square's 95 % point with two degrees of freedom: the goal's wide search,
    :func:`~clomp.runtime.estimation.doubt.trusted_check`, whose ``unique`` still guards
    against a rival)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    ref = np.asarray(map_points, dtype=float).reshape(-1, 2)
    if len(pts) < min_points or len(ref) < min_points:
        return Relocalisation(None, math.inf, 0.0, math.inf, math.inf, "too few points")
    cap = reach * sd
    grid = misfit_grid(ref, pts, pose, radius=radius, step=step, headings=headings, sd=sd, correlation=correlation,
                       reach=reach, most_points=most_points)
    cost, offs = grid.cost, grid.offsets
    h, a, b = np.unravel_index(int(np.argmin(cost)), cost.shape)
    dx, dy = offs, offs
    gx, gy = np.meshgrid(dx, dy, indexing="ij")
    far = np.hypot(gx - dx[a], gy - dy[b])  # each grid pose's distance from the best
    best = float(cost[h, a, b])
    rivals = far[None, :, :] * np.ones((len(headings), 1, 1))
    near_as_well = cost <= best + unique
    rival = float(rivals[near_as_well & (rivals > apart)].min()) if np.any(near_as_well & (rivals > apart)) else math.inf
    spread = float(rivals[near_as_well].max())  # the poses as good, conservatively: how far they reach
    reach_sd = spread if bound_margin is None else float(rivals[cost <= best + bound_margin].max())
    at = Pose(pose.x + float(dx[a]), pose.y + float(dy[b]), pose.theta + headings[h])
    d_best, idx = cKDTree(ref).query(points_from_frame(pts, at), distance_upper_bound=cap)
    met = np.isfinite(d_best)
    inl = float(met.mean())
    if inl < least_inliers or int(met.sum()) < least_paired:
        return Relocalisation(None, math.inf, inl, spread, rival,
                              f"best pairs {inl:.0%} of {len(pts)} points within {cap * 100:.0f} cm: too little")
    if rival < math.inf:
        return Relocalisation(None, math.inf, inl, spread, rival,
                              f"a pose {rival:.2f} m from the best explains it nearly as well: not unique")
    if max(abs(a - len(offs) // 2), abs(b - len(offs) // 2)) >= len(offs) // 2:
        return Relocalisation(None, math.inf, inl, spread, rival, "the best lies on the search's edge", True)
    refined = match_scans(ReferenceScan(ref), pts, at, gate=None, min_points=min_points)
    if refined.ok and math.hypot(refined.pose.x - at.x, refined.pose.y - at.y) <= 2 * step:  # within the grid's own blur
        at = refined.pose
    map_sd = float(np.median(np.asarray(map_sds, dtype=float).reshape(len(ref), -1)[idx[met], 0]))
    out = math.sqrt(map_sd ** 2 + (max(reach_sd, step) / sigmas) ** 2)
    return Relocalisation(at, out, inl, spread, rival,
                          f"pairs {inl:.0%} of {len(pts)} points, poses as good within {spread * 100:.0f} cm, "
                          f"none farther")


class KickMemory:
    """The kick half of :class:`~clomp.runtime.estimation.odometry.ScanOdometry` (a mixin: it
    reads and writes the odometry's map, filter and doubt): the map as it was when a shock
    was felt (:meth:`remember_before_doubt`), and the re-localisation against it
    (:meth:`relocalise_after_kick`) that lowers the doubt's floor, or moves the estimate,
    when the evidence supports it."""

    min_points: int
    match_sd: float
    noise_factor: float
    range_sd: float | None
    correlation: float
    relocalised: int
    pose: Pose
    _t: float
    _map_points: np.ndarray | None
    _map_sds: np.ndarray | None
    _before_doubt: tuple[np.ndarray, np.ndarray] | None
    _kicked_at: float
    _map: ReferenceScan | None
    _map_tree: cKDTree | None
    _history: deque[tuple[float, Pose]]
    filter: OdometryFilter
    doubt: Doubt
    last_relocalisation: Relocalisation | None
    last_map_sd: tuple[float, float]

    _seen_moved_at = -math.inf  # the doubt's last seen-through event taken (seen_moved)
    _seen_kept = False  # the map before the doubt was kept by seen_moved, not by a shock
    keep_on_seen = False  # seen_moved on: off by default (session 14: on the harsh sample it re-localised
    # doorway 0/0 with the gyro from a map holding surfaces drawn after the push, 0.085 -> 0.40 m off, and gained
    # no claim; truly at the goal 35 -> 34 and 23 -> 22 of 50)
    kick_radius = 0.55  # m searched when 0.4 m found its best on the edge: a push of up to 0.5 m (a wider
    # search first met more of a doorway's walls: doorway 5/0 kicked 0.3 m, found at 0.29 m within 0.4 m, lay on
    # the edge of 0.55 m and ended lost, 0.56 m off)
    slide_sensing = False  # the IMU measures a kick's slide (clomp run --imu): the revolutions in it are not matched
    _slide_span: tuple[float, float] | None = None  # (from, to) odometry s: a kick's slide, to inf until measured

    def felt(self, sd: float) -> None:
        """A shock of ``sd`` (m) was felt now; a kick's (the doubt's ``kick_sd``) starts a slide
        whose revolutions are not matched (:meth:`in_slide`) when the IMU will measure it."""
        if self.slide_sensing and sd >= self.doubt.kick_sd:
            self._slide_span = (self._t - 0.1, math.inf)  # a revolution ending just before it was felt: in it

    def in_slide(self, stamp: float, longest: float = 1.0) -> bool:
        """Whether a revolution stamped ``stamp`` was taken while a kick slid the body: from just
        before it was felt until its slide was measured (:meth:`slid`; at most ``longest`` s).
        Its points were de-skewed by a prediction without the slide and it would be matched
        from a pose the slide then moves (session 8: one such match undid a measured 0.1 m
        slide, the run ended 0.148 m off), so it is neither matched nor drawn."""
        span = self._slide_span
        return span is not None and span[0] <= stamp <= min(span[1], span[0] + longest)

    def remember_before_doubt(self) -> None:
        """A shock was felt: keep the map as it is now (drawn before it), once per doubt (kept
        since revolutions saw through it, :meth:`seen_moved`: that older map, searched from
        this shock on)."""
        if self._before_doubt is not None and self._seen_kept:
            self._kicked_at, self._seen_kept = self._t, False
        if self._before_doubt is None and self._map_points is not None and self._map_sds is not None:
            self._before_doubt = (self._map_points, self._map_sds)
            self._kicked_at = self._t

    def kick_pending(self, stamp: float, settle: float = 0.3, search: float = 5.0) -> bool:
        """Whether a revolution stamped ``stamp``, while driving, is searched against the map
        drawn before the shock: from ``settle`` s after it (the slide is over) to ``search`` s
        after it (near where it was kicked, the robot still sees what it saw before). A doubt
        raised by revolutions that saw through or nearer than the map (:meth:`seen_moved`)
        counts as a shock felt when it was raised."""
        self.seen_moved()
        return self._before_doubt is not None and self._kicked_at + settle <= stamp <= self._kicked_at + search

    def seen_moved(self) -> None:
        """The doubt's newest event says revolutions saw through, or nearer than, the map
        (:meth:`~clomp.runtime.estimation.doubt.Doubt.seen`: a push nothing felt, or a world
        that changed): the map as it is now is the one drawn before it (the revolutions that
        contradicted it were not drawn), kept as after a shock, so the wide search re-localises
        against it (a flagged push was not re-localised: the goal's search had only the start's
        surfaces, and from the goal they rarely pinned a pose). Only with :attr:`keep_on_seen`
        (off by default: the map then may hold surfaces drawn after a push nothing felt)."""
        events = self.doubt.events
        if not self.keep_on_seen or not events:
            return
        t, kind, _ = events[-1]
        if kind in SEEN_MOVED and t > self._seen_moved_at:
            self._seen_moved_at = t
            if self._before_doubt is None and self._map_points is not None and self._map_sds is not None:
                self._before_doubt = (self._map_points, self._map_sds)
                self._kicked_at, self._seen_kept = t, True

    def relocalise_after_kick(self, points: np.ndarray, at: Pose | None = None, sigmas: float = 2.45) -> Pose | None:
        """In doubt after a shock, a revolution ``points`` (robot frame) believed seen from
        ``at`` (default: the estimate now) matched against the map drawn before the shock
        (:func:`relocalise`; only surfaces seen from the side the robot faces them from now).
        Well supported, the doubt falls to that evidence: to the re-localisation's ``sd``
        plus the estimate's distance from it over ``sigmas`` when it lies within the
        re-localisation's own ``sigmas`` bound (the estimate stays), else the estimate moves
        by the difference (the pose now is returned). Either way the surfaces drawn in doubt
        are dropped (they were drawn from an estimate of unknown error) and this revolution
        is drawn anew. Not supported: None, the doubt stays (:attr:`last_relocalisation`)."""
        doubt = self.doubt
        self.last_relocalisation = None
        if self._before_doubt is None or doubt.sd <= 0:
            return None
        seen = self.pose if at is None else at
        ref, ref_sds = self._before_doubt
        keep = np.cos(np.arctan2(ref[:, 1] - seen.y, ref[:, 0] - seen.x) - ref_sds[:, 2]) > 0.0
        sd = max(2 * self.match_sd, self.noise_factor * (self.range_sd or 0.0))
        res = relocalise(ref[keep], ref_sds[keep], points, seen, min_points=self.min_points, sd=sd,
                         correlation=self.correlation)
        if res.pose is None and res.edge:  # pushed farther than 0.4 m, perhaps: the wider search
            res = relocalise(ref[keep], ref_sds[keep], points, seen, radius=self.kick_radius,
                             min_points=self.min_points, sd=sd, correlation=self.correlation)
        self.last_relocalisation = res
        if res.pose is None:
            return None
        off = math.hypot(res.pose.x - seen.x, res.pose.y - seen.y)
        stays = off <= sigmas * res.sd
        floor = res.sd + off / sigmas if stays else res.sd
        moved = None if stays else compose(res.pose, relative(seen, self.pose))
        self._settle_kick(moved, floor, ref, ref_sds)
        drawn = seen if stays else res.pose
        self._add(points, drawn, reseed=False)  # type: ignore[attr-defined]  # LocalMap's
        self.last_map_sd = self._map_sd(points, drawn)  # type: ignore[attr-defined]
        doubt.events.append((self._t, "relocalised" if moved is not None else "confirmed", round(floor, 3)))
        return moved

    def slid(self, distance: float, bearing: float, turned: float, duration: float, latency: float = 0.1,
             sd: float = 0.0) -> Pose | None:
        """A kick's slide as the IMU measured it (:class:`~clomp.runtime.devices.bno08x_slide.Slide`):
        ``distance`` m towards ``bearing`` (rad, in the body frame at the kick), the body
        having turned ``turned`` rad since, over ``duration`` s. The wheels' prediction
        never saw it, and in a scene with little to match (``overtaking``: one small box) the
        scans do not either, so the estimate moves by it now (the poses since the kick too,
        ``latency`` s allowed for the report's delay), and the map goes back to what was
        drawn before the kick (what the matcher drew since, it drew from the unmoved
        estimate). ``sd`` (m): how far the measured displacement may be off (one standard
        deviation, the slide's own): the filter's position variance, the gain's and the
        vouching one, grows by it. The doubt's floor stays: only the re-localisation lowers
        it. Returns the pose now (None: nothing to move by). ``distance`` 0 with an ``sd``: a
        slide measured but not believed (:attr:`~clomp.runtime.devices.bno08x_slide.SlideWatch.farthest`):
        the estimate stays, its position variance and its doubt open by ``sd``.

        >>> from clomp.runtime.estimation.odometry import ScanOdometry
        >>> o = ScanOdometry(0.15)
        >>> p = o.slid(0.2, math.pi / 2, 0.0, 0.25)
        >>> round(p.x, 3), round(p.y, 3), o.doubt.events[-1][1]
        (0.0, 0.2, 'slid')
        """
        if not (math.isfinite(distance) and distance >= 0 and math.isfinite(bearing) and math.isfinite(turned)):
            return None
        if distance == 0:  # a slide not believed (SlideWatch.farthest): where it went is not known
            if not (math.isfinite(sd) and sd > 0):
                return None
            self.filter.widen_position(sd)
            self.doubt.raise_to(sd, self._t, "slide not believed")  # only a re-localisation lowers it
            if self._slide_span is not None and self._slide_span[1] == math.inf:
                self._slide_span = (self._slide_span[0], self._t)
            return self.pose
        at = self.pose.theta - turned + bearing  # the kick's direction in the estimate's frame
        dx, dy = distance * math.cos(at), distance * math.sin(at)
        moved = Pose(self.pose.x + dx, self.pose.y + dy, self.pose.theta)
        self.filter.shift(moved)
        self.filter.widen_position(sd)
        self.pose = moved
        since = self._t - duration - latency
        self._history = deque((t, Pose(p.x + dx, p.y + dy, p.theta)) if t >= since else (t, p) for t, p in self._history)
        if self._before_doubt is not None:
            self._map_points, self._map_sds = self._before_doubt
            self._map_tree = None
            self._map = ReferenceScan(self._before_doubt[0])
        if self._slide_span is not None and self._slide_span[1] == math.inf:
            self._slide_span = (self._slide_span[0], self._t)
        self.doubt.events.append((self._t, "slid", round(distance, 3)))
        return moved

    def _settle_kick(self, pose: Pose | None, sd: float, ref: np.ndarray, ref_sds: np.ndarray) -> None:
        """The doubt is settled at ``sd`` (m), the estimate moved to ``pose`` (None: it
        stays): the filter's position uncertainty, the gain's and the vouching one, is set to
        it (the kick's share of it was what the doubt held), the map is the one drawn
        before the doubt."""
        f = self.filter
        if pose is not None:
            f.shift(pose)
            self.pose = pose
            self._history = deque([(self._t, pose)])
            self.relocalised += 1
        for m in (f.P, f.honest):
            m[:2, :] = 0.0
            m[:, :2] = 0.0
            m[:2, :2] = np.eye(2) * sd * sd
        self.doubt.confirmed(sd)
        self._map_points, self._map_sds = ref, ref_sds
        self._map_tree = None
        self._map = ReferenceScan(ref)
        self._before_doubt = None
