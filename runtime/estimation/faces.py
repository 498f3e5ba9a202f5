"""Straight faces as a compass: the heading measured against surfaces fixed in the start frame.

Scan matching against a self-built map leaves the heading to drift where the scene is one
small box: turning about it looks like stepping sideways, so the match observes the
position and leaves the heading to the wheels (which, at the ``harsh`` noise, curve a
straight by up to 30°/m), and the surfaces the map adds on the way are placed with that
drifted heading, so later matches confirm it. Fed the true heading, the same estimator
ends within 5 cm of the truth in 39 of 40 harsh ``overtaking`` runs; as it is, in 15.

A straight face's *direction* does not depend on where the robot stands. The first faces
are found in the still revolutions at the start, whose pose defines the frame, so their
directions carry no estimation error; each later revolution that sees one of them again
measures the heading directly, as a compass would, whatever the position's error (the
faces are told apart by where they are, with the estimated pose, and a face is read only
from the side it was seen from). Faces first seen on the way (a box's side and back) join
from several revolutions at once when they meet a known face at a square corner: they
take its direction turned by 90° (or 0°), not the heading of the moment, which in 180
recorded harsh runs put the faces that joined otherwise 7.4° off (median; 28° at the
90th percentile).

The start's faces are found in the still revolutions fused (median range per bearing),
then refitted on all their raw points within 3.5 standard deviations of the range noise:
a narrower band around a first, tilted guess keeps a tilted parallelogram of points and
the fit stays tilted. The robot stands for ten revolutions before it first moves
(:class:`~clomp.runtime.supervision.supervisor.Supervisor` ``start_scans``): with the three it
used to, a 0.2 m face's direction came out 5-18° off in one harsh run in ten, and the
compass then read that error as the heading for the rest of the run.

:func:`find_faces` finds the faces of a noisy point set (sequential RANSAC, then a total
least-squares fit per face, deterministic for given points); :class:`FaceCompass` keeps
the faces and measures the heading. :class:`~clomp.runtime.estimation.odometry.ScanOdometry`
fuses each measurement into its filter (which learns the wheels' curvature from them).

>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> wall = np.c_[np.full(40, 0.5), np.linspace(-0.2, 0.2, 40)] + rng.normal(0, 0.005, (40, 2))
>>> [abs(math.degrees(f.angle) % 180 - 90) < 2 for f in find_faces(wall, 0.015)]  # one face, across the x axis
[True]
>>> compass = FaceCompass()
>>> compass.seed([wall], Pose(0.0, 0.0, 0.0), 0.005)
1
>>> turned = wall @ np.array([[math.cos(0.1), -math.sin(0.1)], [math.sin(0.1), math.cos(0.1)]])  # seen 0.1 rad turned
>>> offset, sd, n = compass.measure(turned, Pose(0.0, 0.0, 0.0), 0.005)  # the estimate still says 0
>>> round(offset, 2), n
(0.1, 1)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from clomp.formal.geometry import points_from_frame, points_to_frame, wrap_angle
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import eigh, mean, mean_rows, median
from clomp.runtime.estimation.fusion import fuse_revolutions

__all__ = ["Face", "FaceCompass", "find_faces", "fit_line", "refine_line"]


@dataclass(frozen=True)
class Face:
    """A straight face (supervisor frame): through ``centre`` along the unit ``direction``,
    from ``start`` to ``end`` (m along it from the centre); ``rms`` (m) of its points about
    the line, ``points`` fitted, ``sd`` (rad) the
    standard deviation of its direction in this frame (fit and, for a face found on the
    way, the heading it was placed with)."""

    centre: tuple[float, float]
    direction: tuple[float, float]
    start: float
    end: float
    rms: float
    points: int
    sd: float = 0.0

    @property
    def normal(self) -> tuple[float, float]:
        """The unit normal (the direction turned a quarter to the left)."""
        return -self.direction[1], self.direction[0]

    @property
    def angle(self) -> float:
        """The direction's angle (rad)."""
        return math.atan2(self.direction[1], self.direction[0])


def fit_line(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Total least-squares line through ``points`` (N×2): centre, unit direction, unit
    normal, and the rms distance of the points from it (m).

    >>> c, d, n, rms = fit_line(np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]))
    >>> [round(float(abs(v)), 3) for v in d], round(rms, 6)
    ([0.707, 0.707], 0.0)
    """
    c = mean_rows(points)  # points.mean(axis=0) and np.linalg.eigh, bit for bit, cheaper (issue #41)
    q = points - c
    w, v = eigh(q.T @ q)
    return c, v[:, 1], v[:, 0], math.sqrt(max(float(w[0]), 0.0) / len(points))


def refine_line(points: np.ndarray, centre: np.ndarray, direction: np.ndarray, tolerance: float,
                iterations: int = 8) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float] | None:
    """The line through ``points`` (N×2) near the one through ``centre`` along
    ``direction``: the points within ``tolerance`` (m) of the current line are chosen
    again from all of them after every refit (a fit on points chosen by distance from a
    tilted guess would otherwise stay tilted towards it) and refitted (total least
    squares; a median-based fit would snap to the 1 cm grid a LiDAR's coordinates are
    rounded to). Returns the centre, unit direction, the inliers (bool mask), the rms
    (m) and the direction's standard deviation (rad); None with fewer than 3 inliers.

    >>> pts = np.c_[np.linspace(0, 0.3, 31), 0.1 * np.linspace(0, 0.3, 31)]  # a line at atan(0.1)
    >>> c, d, sel, rms, sd = refine_line(pts, np.array([0.15, 0.0]), np.array([1.0, 0.0]), 0.02)
    >>> round(math.degrees(math.atan(d[1] / d[0])), 2), int(sel.sum())
    (5.71, 31)
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    c, d = np.asarray(centre, dtype=float), np.asarray(direction, dtype=float)
    d = d / math.hypot(d[0], d[1])
    sel = np.zeros(len(pts), dtype=bool)
    for _ in range(iterations):
        n = np.array([-d[1], d[0]])
        q = pts - c
        new = np.abs(q @ n) <= tolerance
        if np.count_nonzero(new) < 3:
            return None
        if (new == sel).all():
            break
        sel = new
        c, d, _n, _rms = fit_line(pts[sel])
    n = np.array([-d[1], d[0]])
    q = pts[sel] - c
    s, y = q @ d, q @ n
    rms = math.sqrt(mean(y * y))  # np.mean / np.sum bit for bit without their wrappers (issue #41)
    spread = float(np.add.reduce((s - mean(s)) ** 2))
    sd = max(rms, 1e-4) / math.sqrt(spread) if spread > 0 else math.inf
    return c, d, sel, rms, sd


def find_faces(points: np.ndarray, tolerance: float, *, min_points: int = 10, min_length: float = 0.15,
               max_gap: float = 0.06, hypotheses: int = 150, max_faces: int = 8) -> list[Face]:
    """The straight faces of ``points`` (N×2): sequential RANSAC (a line through two points
    5–40 cm apart, scored by the points within ``tolerance`` m), refined by total least
    squares on its inliers; a face is the longest run of inliers without a gap over
    ``max_gap`` m, kept when it has ``min_points`` points over ``min_length`` m. Its points
    are removed and the search repeats. Deterministic: the random draws are seeded.

    >>> square = np.array([[x, 0.0] for x in np.linspace(0, 0.3, 31)] + [[0.3, y] for y in np.linspace(0.01, 0.3, 30)])
    >>> sorted(round(math.degrees(f.angle) % 180) for f in find_faces(square, 0.01))
    [0, 90]
    """
    rng = np.random.default_rng(0)
    left = np.asarray(points, dtype=float).reshape(-1, 2)
    out: list[Face] = []
    while len(left) >= min_points and len(out) < max_faces:
        i, j = rng.integers(0, len(left), hypotheses), rng.integers(0, len(left), hypotheses)
        d = left[j] - left[i]
        length = np.hypot(d[:, 0], d[:, 1])
        ok = (length > 0.05) & (length < 0.4)
        if not ok.any():
            break
        a, normals = left[i][ok], np.c_[-d[ok, 1], d[ok, 0]] / length[ok, None]
        dist = np.abs(np.einsum("hnk,hk->hn", left[None, :, :] - a[:, None, :], normals))
        score = (dist <= tolerance).sum(axis=1)
        h = int(np.argmax(score))
        if score[h] < min_points:
            break
        got = refine_line(left, a[h], d[ok][h], tolerance)
        if got is None:
            break
        c, dv, inliers, _rms, _sd = got
        idx = np.flatnonzero(inliers)
        order = idx[np.argsort((left[idx] - c) @ dv)]
        along = (left[order] - c) @ dv
        run = max(np.split(order, np.flatnonzero(np.diff(along) > max_gap) + 1), key=len)
        face = None
        if len(run) >= min_points:
            fit = refine_line(left[run], c, dv, tolerance)
            if fit is not None and fit[2].sum() >= min_points:
                rc, rd, rsel, rms, sd = fit
                s = (left[run][rsel] - rc) @ rd
                if s.max() - s.min() >= min_length:
                    face = Face((float(rc[0]), float(rc[1])), (float(rd[0]), float(rd[1])), float(s.min()),
                                float(s.max()), rms, int(rsel.sum()), sd)
                    c, dv = rc, rd
        # every point of this line's stretch goes (not only the fitted ones: the noise's
        # tails left behind would otherwise draw a second, crossing line through the face)
        q = left - c
        along_all = q @ dv
        lo, hi = ((left[run] - c) @ dv).min() - max_gap, ((left[run] - c) @ dv).max() + max_gap
        gone = (np.abs(q @ np.array([-dv[1], dv[0]])) <= 1.5 * tolerance) & (along_all >= lo) & (along_all <= hi)
        gone[run] = True
        if face is None:
            gone[idx] = True
        if face is not None and not any(_crosses(face, f) or FaceCompass._same(face, f) for f in out):
            out.append(face)
        left = left[~gone]
    return out


def _facing(f: Face, viewer: tuple[float, float]) -> Face:
    """``f`` with its direction chosen so that its normal points towards ``viewer``: the
    side it was seen from, the only side it can be seen from again."""
    off = np.asarray(viewer, dtype=float) - np.asarray(f.centre)
    if float(off @ np.asarray(f.normal)) >= 0.0:
        return f
    return dataclasses.replace(f, direction=(-f.direction[0], -f.direction[1]), start=-f.end, end=-f.start)


def _ends(f: Face) -> tuple[np.ndarray, np.ndarray]:
    c, d = np.asarray(f.centre), np.asarray(f.direction)
    return c + f.start * d, c + f.end * d


def _crosses(a: Face, b: Face) -> bool:
    """Whether the segments of ``a`` and ``b`` cross (two faces of one surface cannot)."""
    (p1, p2), (p3, p4) = _ends(a), _ends(b)

    def side(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> float:
        return float((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    return side(p1, p2, p3) * side(p1, p2, p4) < 0 and side(p3, p4, p1) * side(p3, p4, p2) < 0


class FaceCompass:
    """The heading measured against straight faces fixed in the supervisor frame.

    ``min_length`` (m): the shortest face kept (a short face's direction is poorly known
    under range noise); ``band`` (m): how far from a face a point may lie and still be
    taken for it; ``floor`` (rad): no face's measurement is believed closer than this (the
    face's own direction error); ``grow_revolutions``: how many revolutions together find
    a new face on the way, each taken while the heading's standard deviation is at most
    ``grow_sd`` (rad); ``tolerance`` (× the range noise, at least 2 cm): RANSAC's inlier
    distance; ``margin`` (m): how much of each end of a face a measurement leaves out;
    ``incidence``: the least cosine between a beam and a face's normal for its point to
    count in a measurement (a grazing beam's range noise runs along the face);
    ``right_angles``: a face found on the way that meets a known one at a corner (ends
    within ``corner`` m) at a right angle, or parallel, within three standard deviations
    and ``square_limit`` (rad), is squared to it (boxes and rooms have square corners),
    and may join while the heading is known to ``square_sd`` (rad) and from
    ``square_length`` (m) long: its direction then comes from the face it squares to (a
    box's side may be 0.1 m deep); ``grow_unsquared``: whether a face found on the way that squares to none joins too,
    with the direction measured under the heading of the moment. Off by default: in 180
    recorded harsh runs such faces were 7.4° off their true direction (median; 90th
    percentile 28°) against 1.0° (4.5°) for squared ones, and a compass reading a wrong
    face confirms a wrong heading. ``behind`` (m): a face is read only from the side it
    was seen from, the robot at least this far in front of its line (``depth``, m: read from
    either side, how much farther from the line a box's back face may lie); ``max_sd`` (rad): a
    revolution's reading of one face less certain than this is left out. Each face is fitted
    on the points within ``fit_band`` × the range noise of its line.
    """

    def __init__(self, *, min_length: float = 0.15, band: float = 0.06, floor: float = math.radians(1.4),
                 grow_revolutions: int = 6, grow_sd: float = math.radians(2.5), tolerance: float = 2.0,
                 margin: float = 0.02, incidence: float = 0.4, right_angles: bool = True,
                 corner: float = 0.08, square_limit: float = math.radians(12.0), behind: float = 0.05,
                 grow_unsquared: bool = False, fit_band: float = 3.5, square_sd: float = math.radians(5.0),
                 square_length: float = 0.08, max_sd: float = math.radians(6.0), depth: float = 0.12) -> None:
        self.depth = float(depth)
        self.square_sd, self.square_length = float(square_sd), float(square_length)
        self.max_sd = float(max_sd)
        self.grow_unsquared = bool(grow_unsquared)
        self.behind, self.fit_band = float(behind), float(fit_band)
        self.right_angles, self.corner, self.square_limit = bool(right_angles), float(corner), float(square_limit)
        self.min_length, self.band, self.floor, self.margin = float(min_length), float(band), float(floor), float(margin)
        self.incidence = float(incidence)
        self.grow_revolutions, self.grow_sd, self.tolerance = int(grow_revolutions), float(grow_sd), float(tolerance)
        self.faces: list[Face] = []
        self.seeded = False
        self._recent: list[np.ndarray] = []

    def reset(self) -> None:
        """Forget every face (a new start pose, a new frame)."""
        self.faces, self.seeded, self._recent = [], False, []

    def _tol(self, range_sd: float | None) -> float:
        return max(self.tolerance * (range_sd or 0.01), 0.02)

    def seed(self, revolutions: Sequence[np.ndarray], pose: Pose, range_sd: float | None) -> int:
        """The first faces: found in ``revolutions`` (robot frame) taken standing at ``pose``,
        which fixes the frame. Returns how many were found."""
        self.seeded = True
        raw = [np.asarray(r, dtype=float).reshape(-1, 2) for r in revolutions]
        raw = [r for r in raw if len(r)]
        if not raw:
            self.faces = []
            return 0
        # fused (median range per bearing): the noise of n revolutions' median is about
        # 1.25/sqrt(n) of one's, so the faces are found in a thinner cloud
        pts = fuse_revolutions(raw) if len(raw) > 1 else raw[0]
        sd = (range_sd or 0.01) * (1.25 / math.sqrt(len(raw)) if len(raw) > 1 else 1.0)
        found = find_faces(points_from_frame(pts, pose), self._tol(sd), min_length=self.min_length) if len(pts) else []
        # each face refitted on every raw point along it: n revolutions' points carry more
        # of its direction than their one fused median per bearing
        every = points_from_frame(np.concatenate(raw), pose)
        # the refit's band holds nearly all of a face's noise (3.5 sd): a band of 2 sd
        # around a tilted first guess keeps a tilted parallelogram of points, whose fit
        # stays tilted (5° on a 0.2 m face under 2.5 cm of noise)
        wide = max(self.fit_band * (range_sd or 0.01), 0.02)
        self.faces = [_facing(self._refit(f, every, wide), (pose.x, pose.y)) for f in found]
        return len(self.faces)

    @staticmethod
    def _refit(face: Face, points: np.ndarray, tolerance: float) -> Face:
        """``face`` refitted (direction, centre, sd) on the ``points`` along its stretch."""
        fc, fd = np.asarray(face.centre), np.asarray(face.direction)
        along = (points - fc) @ fd
        near = points[(along >= face.start) & (along <= face.end)]
        got = refine_line(near, fc, fd, tolerance) if len(near) >= face.points else None
        if got is None:
            return face
        c, d, sel, rms, sd = got
        if sel.sum() < face.points:
            return face
        s = (near[sel] - c) @ d
        return Face((float(c[0]), float(c[1])), (float(d[0]), float(d[1])), float(s.min()), float(s.max()), rms,
                    int(sel.sum()), sd)

    def measure(self, points: np.ndarray, pose: Pose, range_sd: float | None,
                prior_sd: float = math.inf, either_side: bool = False) -> tuple[float, float, int] | None:
        """The heading offset (rad, measured minus ``pose.theta``), its standard deviation and
        the number of faces that gave it, from one revolution ``points`` (robot frame, de-skewed)
        seen at ``pose``; None when it sees no known face well enough (8 points over 8 cm).
        A face whose offset is beyond 3 standard deviations (its own and ``prior_sd``, the
        estimate's heading) is taken for a wrong association and left out. ``either_side``:
        a face is read from behind too, where a thin wall's other side or a box's back face
        lies parallel to it (issue #36: at the goal, the start's faces seen from the far side
        tell a heading that drifted with the map: 12° in u-trap 4/2 at ``harsh`` without the
        gyro, :func:`~clomp.runtime.supervision.goal.seen_past`); its ends are kept clear of a
        box's sides and a reading beyond 2.5 × ``square_limit`` (30°) is taken for a wrong
        face. Not for steering, where a parallel face nearby would be taken for it."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if not self.faces or len(pts) < 8:
            return None
        offsets, weights = [], []
        world = points_from_frame(pts, pose)
        sd_r = max(range_sd or 0.01, 0.005)
        tol = max(self.fit_band * sd_r, 0.02)
        spread = min(3.0 * prior_sd, math.radians(25.0))  # how far the heading may be off
        ray = pts / np.maximum(np.hypot(pts[:, 0], pts[:, 1]), 1e-9)[:, None]  # each point's beam (robot frame)
        here = np.array([pose.x, pose.y])
        for f in self.faces:
            fc, fd, fn = np.asarray(f.centre), np.asarray(f.direction), np.asarray(f.normal)
            if float((here - fc) @ fn) < self.behind and not either_side:
                continue  # the robot is behind the face (or in its plane): it cannot see it
            q = world - fc
            along, across = q @ fd, q @ fn
            # the face's stretch, away from its ends (a corner's other face would tilt the
            # fit), and wide enough across for the face as it would lie were the heading off
            # by three standard deviations: a band only as wide as the noise would keep the
            # points nearest the estimate's line and so confirm the estimate
            reach = max(abs(f.start), abs(f.end)) * math.tan(spread)
            wide = max(self.band, tol + reach) + (self.depth if either_side else 0.0)  # a box's back face lies behind
            # read from behind, a box's sides reach back past the face's ends: kept clear of them
            end = self.margin + (self.depth / 2 if either_side else 0.0)
            cand = (np.abs(across) <= wide) & (along >= f.start + end) & (along <= f.end - end)
            if np.count_nonzero(cand) < 8:
                continue
            wc = world[cand]
            got = refine_line(wc, fc + median(across[cand]) * fn, fd, tol)
            if got is None:
                continue
            c, d, sel, rms, sd_fit = got
            # a beam meeting the face at a grazing angle moves its point along the face, not
            # across: those points say little about the direction and skew it
            nrm = np.array([-d[1], d[0]])
            face_n = points_to_frame(nrm[None, :], (0.0, 0.0, pose.theta))[0]  # the normal seen from the robot
            steep = np.abs(ray[cand] @ face_n) >= self.incidence
            if np.count_nonzero(sel & steep) < 8:
                continue
            if (sel & ~steep).any():  # refitted on the steep points alone
                ws = wc[steep]
                got = refine_line(ws, c, d, tol)
                if got is None or np.count_nonzero(got[2]) < 8:
                    continue
                c, d, sel, rms, sd_fit = got
                used = ws[sel]
            else:
                used = wc[sel]
            s_ = (used - c) @ d
            if s_.max() - s_.min() < 0.08:
                continue
            off = wrap_angle(f.angle - math.atan2(d[1], d[0]))
            if abs(off) > math.pi / 2:  # a line has no sense of direction
                off = wrap_angle(off + math.pi)
            sd = math.hypot(max(sd_fit, sd_r / math.sqrt(float(np.add.reduce((s_ - mean(s_)) ** 2)))), f.sd, self.floor)
            if sd > self.max_sd or abs(off) > 3.0 * math.hypot(sd, prior_sd) or (either_side and abs(off) > self.square_limit * 2.5):
                # too little of a face to tell a heading by (the few points of a short
                # face, or a corner's, are where wild readings come from), or off the prior
                continue
            offsets.append(off)
            weights.append(1.0 / sd**2)
        if not offsets:
            return None
        w = np.asarray(weights)
        return float(np.sum(w * np.asarray(offsets)) / w.sum()), 1.0 / math.sqrt(float(w.sum())), len(offsets)

    def grow(self, points: np.ndarray, pose: Pose, heading_sd: float, range_sd: float | None) -> int:
        """Collect a revolution seen at ``pose`` while the heading is known to ``heading_sd``
        (rad); every ``grow_revolutions`` of them in a row, the faces they show that no known
        face explains join. Returns how many joined."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if not self.seeded or heading_sd > max(self.grow_sd, self.square_sd) or len(pts) < 8:
            self._recent = []
            return 0
        self._recent.append(points_from_frame(pts, pose))
        if len(self._recent) < self.grow_revolutions:
            return 0
        world, self._recent = np.concatenate(self._recent), []
        for f in self.faces:  # the points of known faces
            q = world - np.asarray(f.centre)
            along = q @ np.asarray(f.direction)
            world = world[~((np.abs(q @ np.asarray(f.normal)) <= self.band) & (along >= f.start - 0.05) & (along <= f.end + 0.05))]
        if len(world) < 10:
            return 0
        added = 0
        for new in find_faces(world, self._tol(range_sd), min_points=4 * self.grow_revolutions,
                              min_length=min(self.min_length, self.square_length)):
            if not any(self._same(new, f) or _crosses(new, f) for f in self.faces):
                # placed with the heading of the moment: its direction carries that error
                new = _facing(dataclasses.replace(new, sd=math.hypot(new.sd, heading_sd)), (pose.x, pose.y))
                sq = self._square(new) if self.right_angles else new
                if sq is new and not (self.grow_unsquared and heading_sd <= self.grow_sd
                                      and new.end - new.start >= max(self.min_length, 0.12)):
                    continue  # nothing vouches for its direction but the heading of the moment
                if sq is not new and heading_sd > self.square_sd:
                    continue
                self.faces.append(sq)
                added += 1
        return added

    def _square(self, new: Face) -> Face:
        """``new`` squared to a known face it meets at a corner (an end within
        ``corner`` m of one of the other's), when their angle is within three standard
        deviations of a right angle (or of parallel) and within ``square_limit``: it then
        takes the known face's direction, turned by that right angle, and its standard
        deviation — a box's side is then as well known as the front seen at the start,
        not as the heading was when the side was first seen."""
        best: tuple[float, Face, float] | None = None
        ends_new = _ends(new)
        for f in self.faces:
            if min(math.dist(a, b) for a in ends_new for b in _ends(f)) > self.corner:
                continue
            quarter = round((new.angle - f.angle) / (math.pi / 2))
            delta = wrap_angle(new.angle - f.angle - quarter * math.pi / 2)
            if abs(delta) <= min(3.0 * math.hypot(new.sd, f.sd), self.square_limit) and (best is None or f.sd < best[0]):
                best = (f.sd, f, quarter * math.pi / 2)
        if best is None:
            return new
        sd, f, turn = best
        a = f.angle + turn
        d = np.array([math.cos(a), math.sin(a)])
        along = float(np.asarray(new.direction) @ d)  # its ends, measured along the squared direction
        s0, s1 = sorted(t * along for t in (new.start, new.end))
        return dataclasses.replace(new, direction=(float(d[0]), float(d[1])), start=s0, end=s1, sd=sd)

    @staticmethod
    def _same(a: Face, b: Face) -> bool:
        """Whether ``a`` is (part of) the known face ``b``: within 25° of its direction,
        8 cm of its line, and overlapping it (5 cm margin)."""
        da, db = np.asarray(a.direction), np.asarray(b.direction)
        off = np.asarray(a.centre) - np.asarray(b.centre)
        if abs(float(da @ db)) <= math.cos(math.radians(25)) or abs(float(off @ np.asarray(b.normal))) >= 0.08:
            return False
        mid, half = float(off @ db), (a.end - a.start) / 2
        return mid + half >= b.start - 0.05 and mid - half <= b.end + 0.05
