"""What the estimate cannot vouch for after evidence that the robot moved unlike its model.

Scan matching corrects the estimate only within its reach (correspondences end at a few
centimetres): a robot kicked 0.2 m is matched near its prediction, the surfaces it then
sees join the map where the wrong estimate draws them, and from then on every match agrees
with that map; its covariance, shrunk by those matches, stays small (issue #36: kicked
0.12 m, it ended 0.17 m off believing 1 cm). So the filter's covariance cannot be the only
judge of what the estimate may vouch for. :class:`Doubt` keeps a *floor* under the
position's standard deviation that ordinary matches do not lower, raised by

- a **shock** the IMU's accelerometer measured (:meth:`Doubt.shock`): more than a drive can
  do (its wheels accelerate the body at most at their limit, 1 m/s², plus the centripetal
  v·ω) means an outside force — a kick (tens of m/s²: the body slides 0.1–0.3 m), or a
  jolt (a few m/s²: a collision, or a body stopping dead while its wheels spin, a slip);
- a revolution that matched nothing the map holds, so that the map was re-seeded from a
  dead-reckoned pose, and well-matched revolutions that disagreed with the prediction
  several times in a row (:meth:`Doubt.raise_to`);
- a revolution seen standing at the start that differs from the map's seed on most
  bearings: the robot was moved before it drove, and the start pose it was told no longer
  holds (:mod:`~clomp.runtime.estimation.standing`, the event ``"moved standing"``).

Only a wider search (:func:`~clomp.runtime.estimation.confirm.ambiguity`, several starting
guesses) against the surfaces drawn *before* the doubt — those whose own uncertainty is
below :attr:`Doubt.trust` — lowers it (:meth:`Doubt.confirmed`): to how far a pose the
trusted surfaces explain as well lies from the estimate. Surfaces drawn while in doubt
carry it (:class:`~clomp.runtime.estimation.odometry.ScanOdometry` draws them with the
floor), so they are not trusted for it. After a shock, the map as it was when the shock
was felt re-localises the robot (:mod:`~clomp.runtime.estimation.relocalise`): on unique,
well-paired evidence the floor falls to what that evidence leaves, and the surfaces drawn
in doubt are dropped.

>>> d = Doubt()
>>> d.shock(1.2, 3.0)                     # a drive's own acceleration: nothing
(0.0, False)
>>> d.shock(7.9, 6.0)                     # a jolt (a slip's stop): 5 cm
(0.05, True)
>>> d.shock(120.0, 10.4)                  # a kick: the floor, and the gain opened as wide
(0.15, True)
>>> d.sd, d.events[-1]
(0.15, (10.4, 'kick', 120.0))
>>> d.confirmed(0.02); d.sd               # the trusted surfaces pin the pose within 2 cm
0.02
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from clomp.formal.model import Pose
from clomp.runtime.estimation.confirm import ambiguity
from clomp.runtime.estimation.icp import ReferenceScan, match_scans
from clomp.runtime.estimation.seethrough import see_nearer, see_through, see_through_along
from clomp.runtime.estimation.vouch import trusted_surfaces

__all__ = ["Doubt", "grid_check", "see_through", "trusted_check"]



@dataclass
class Doubt:
    """The floor under the position's standard deviation (m, :attr:`sd`) and why it was
    raised (:attr:`events`: ``(time, kind, size)``); see the module docstring.

    ``jolt`` (m/s²): a peak acceleration above this is a shock (3: three times what the
    drive does; the world's drive peaks at 1.9 in normal driving, a slip event at 7.9, a
    kick at 100–200). ``kick`` (m/s²): a shock above this slid the body by up to a push's
    size, ``kick_sd`` (m, one standard deviation); a smaller one (a slip, a bump) by up
    to ``jolt_sd`` (a slip event of 0.5 s at 0.1 m/s). Either opens the filter's
    uncertainty as wide and is a floor (without it a slipped ``u-trap`` run ended
    GOAL_REACHED 0.105 m off, believing 1 cm). ``trust`` (m): surfaces drawn at most this
    uncertain count as drawn before the doubt (0.01: the start's seed and what was drawn
    soon after. At 0.05, surfaces drawn while a heading drifted unseen, 0.1-0.3 m off,
    carried 0.02-0.05 and were trusted: three runs at ``harsh`` without the gyro cleared
    a doubt that was right against them and ended GOAL_REACHED 0.14-0.27 m off).
    ``through_least``, ``through_share``,
    ``through_after``: when a revolution contradicts the map, and after how many in a row
    the robot is taken to stand elsewhere (:meth:`seen`; 10 bearings and a fifth: the
    world's harsh runs saw past at most 6 of 31 where the estimate was right, a robot
    moved 0.15 m unseen 15-48 of 110-120) — a fifth of every bearing with a surface, or
    of the bearings that could show one push-sized displacement and see past as it would
    (:func:`~clomp.runtime.estimation.seethrough.see_through_along`: pushed 0.19 m along
    a room, ``stopper`` 37/0 saw past 13-20 of 135-160 bearings, the side walls parallel to
    the push among them, but 11-16 of the 48-52 that could show it). ``goal_through``: at the goal, the revolutions
    fused standing there may see past at most this many bearings of the map for the
    estimate to vouch for the goal (:func:`~clomp.runtime.supervision.goal.at_goal`; 8:
    at ``harsh`` without the gyro, standing at the goal, the estimate right saw past at
    most 5, the estimate 0.10-0.26 m off after a push nothing felt or a drift 10-20 of
    150-170, with no share asked: a fused revolution is not one noisy pass). ``posts_moved``
    (m): at the goal, the start's small posts, paired by their centres with those seen now
    (:func:`~clomp.runtime.estimation.posts.posts_shift`), may move the estimate at most this
    far for it to vouch for the goal (a post's centre is about 1-2 cm off, and two or three
    posts turn the robot by that over their spread). ``faces_turned`` (rad): the start's
    straight faces, read from either side (:meth:`~clomp.runtime.estimation.faces.FaceCompass.measure`),
    may turn the estimate at most this much (and three of their standard deviations) for it
    to vouch for the goal (a heading 6° off moves what it sees 0.1 m at 1 m). ``nearer_gain``,
    ``nearer_shift`` (m): a revolution seeing surfaces nearer than the map holds them
    (:func:`~clomp.runtime.estimation.seethrough.see_nearer`: a push *towards* them, which
    nothing above sees) contradicts the map when the whole revolution fits a pose at least
    ``nearer_shift`` from the estimate better by ``nearer_gain`` (chi-square units; 40: the
    revolutions of five harsh runs whose estimate was right gained at most 16, those after a
    push of 0.15-0.3 m 60-155); it counts in the same row as seeing through."""

    jolt: float = 3.0
    kick: float = 30.0
    kick_sd: float = 0.15
    jolt_sd: float = 0.05
    trust: float = 0.01
    through_least: int = 10
    through_share: float = 0.2
    through_after: int = 2
    goal_through: int = 8
    posts_moved: float = 0.08
    faces_turned: float = math.radians(6.0)
    nearer_gain: float = 40.0
    nearer_shift: float = 0.1
    sd: float = 0.0
    through_in_a_row: int = 0
    pinned: tuple[float, float] | None = None
    _past_in_row: int = 0
    events: list[tuple[float, str, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        for name in ("jolt", "kick", "kick_sd", "jolt_sd", "trust", "through_least", "through_share", "through_after",
                     "goal_through", "posts_moved", "faces_turned", "nearer_gain", "nearer_shift"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"Doubt: {name} must be a positive number, got {v!r}")

    def shock(self, peak: float, t: float) -> tuple[float, bool]:
        """The accelerometer peaked at ``peak`` m/s² at time ``t``: how far (m, one standard
        deviation) the body may have been moved unseen (0: not a shock; the floor rises to
        it), and whether it was a shock."""
        if not (math.isfinite(peak) and peak > self.jolt):
            return 0.0, False
        self.pinned = None
        if peak >= self.kick:
            self.events.append((t, "kick", round(float(peak), 1)))
            self.sd = max(self.sd, self.kick_sd)
            return self.kick_sd, True
        self.events.append((t, "jolt", round(float(peak), 1)))
        self.sd = max(self.sd, self.jolt_sd)
        return self.jolt_sd, True

    def seen(self, through: int, both: int, t: float, along: tuple[tuple[int, int], ...] = (),
             nearer: tuple[float, float] = (0.0, 0.0)) -> tuple[bool, bool]:
        """A revolution saw past ``through`` of the ``both`` bearings where the map holds a
        surface (:func:`see_through`) at time ``t``, and ``along`` gives, per displacement the
        robot may have undergone, (of those, the ones that could show it; how many could,
        :func:`~clomp.runtime.estimation.seethrough.see_through_along`); ``nearer``: (gain,
        shift) of :func:`~clomp.runtime.estimation.seethrough.see_nearer`. Whether it contradicts
        the map (at least ``through_least`` bearings and ``through_share`` of them, or of those
        that could show one displacement; or the whole revolution fits a pose ``nearer_shift``
        away better by ``nearer_gain``: its surfaces must not join the map), and whether
        that is the ``through_after``-th in a row (the robot stands elsewhere than its
        estimate: the floor rises to ``kick_sd``, as after a kick; the event ``"seen through"``,
        or ``"seen nearer"`` when only the surfaces seen nearer said so).

        >>> d = Doubt()
        >>> d.seen(14, 150, 1.0), d.seen(14, 150, 1.2)            # a tenth of the room: not enough
        ((False, False), (False, False))
        >>> d.seen(14, 150, 1.4, ((14, 45),)), d.seen(12, 150, 1.6, ((11, 50),))   # a third of what could show it
        ((True, False), (True, True))
        >>> d.sd, d.events[-1][1]
        (0.15, 'seen through')
        >>> d = Doubt()
        >>> d.seen(0, 150, 1.0, (), (117.0, 0.18)), d.seen(0, 150, 1.2, (), (61.0, 0.22))   # pushed towards a box
        ((True, False), (True, True))
        >>> d.events[-1][1]
        'seen nearer'
        """
        past = self._contradicts(through, both) or any(self._contradicts(a, c) for a, c in along)
        bad = past or (nearer[0] >= self.nearer_gain and nearer[1] >= self.nearer_shift)
        self.through_in_a_row = self.through_in_a_row + 1 if bad else 0
        self._past_in_row = self._past_in_row + 1 if past else 0
        moved = self.through_in_a_row == self.through_after
        if moved:
            self.raise_to(self.kick_sd, t, "seen through" if self._past_in_row else "seen nearer")
        return bad, moved

    def judge(self, map_points: np.ndarray, points: np.ndarray, pose: Pose, t: float) -> tuple[bool, bool]:
        """:meth:`seen` of a revolution ``points`` (robot frame) seen from the estimate ``pose``
        against ``map_points`` at time ``t``: what
        :func:`~clomp.runtime.estimation.seethrough.see_through_along` finds (weighed by
        displacement only when ``through_least`` bearings see past) and what
        :func:`~clomp.runtime.estimation.seethrough.see_nearer` finds (searched only when
        ``through_least`` bearings see nearer)."""
        s = see_through_along(map_points, points, pose, least=self.through_least)
        n = see_nearer(map_points, points, pose, least=self.through_least)
        return self.seen(s.through, s.both, t, s.along, (n.gain, n.shift))

    def _contradicts(self, through: int, could: int) -> bool:
        """``through`` bearings seeing past, of ``could``: at least ``through_least`` and ``through_share``."""
        return through >= self.through_least and through >= self.through_share * could

    def raise_to(self, sd: float, t: float, why: str) -> None:
        """The estimate may be ``sd`` m off for a reason its filter does not see (``why``)."""
        self.pinned = None
        if math.isfinite(sd) and sd > self.sd:
            self.events.append((t, why, round(float(sd), 3)))
            self.sd = float(sd)

    def confirmed(self, sd: float) -> None:
        """A wider search against the trusted surfaces found the estimate explained, no pose
        farther than ``sd`` (m) explaining them as well: the floor is that."""
        self.sd = max(0.0, float(sd))

    def take_pinned(self, pose: Pose, near: float = 0.01) -> bool:
        """Whether the last wide search pinned the estimate, standing at ``pose`` (within ``near``
        m of where it pinned it), by a unique fit to the surfaces drawn before the doubt
        (:func:`grid_check`; :attr:`pinned`: where); cleared once read, and by any raise.
        Standing at the goal, what sees past the map then says the world or the map drawn
        since changed, not where the robot stands (the goal's ``seen_past``).

        >>> d = Doubt(pinned=(1.0, 0.0))
        >>> d.take_pinned(Pose(1.0, 0.0, 0.3)), d.take_pinned(Pose(1.0, 0.0, 0.3))
        (True, False)
        >>> Doubt(pinned=(1.0, 0.0)).take_pinned(Pose(1.1, 0.0, 0.0))          # moved since: stale
        False
        """
        was, self.pinned = self.pinned, None
        return was is not None and math.hypot(pose.x - was[0], pose.y - was[1]) <= near


def trusted_check(doubt: Doubt, map_points: np.ndarray, map_sds: np.ndarray, points: np.ndarray, pose: Pose, *,
                  min_points: int = 10, sd: float = 0.02, correlation: float = 4.0, sigmas: float = 2.45,
                  least_inliers: float = 0.5) -> Pose | None:
    """A revolution ``points`` (robot frame) seen standing at the estimate ``pose``, searched
    for widely (:func:`~clomp.runtime.estimation.confirm.ambiguity`) against the map points
    drawn at most :attr:`Doubt.trust` uncertain (``map_sds[:, 0]``) and, when ``map_sds[:, 2]``
    gives the bearing each was seen along, seen from the side the robot faces them from now
    (a box's front face, seen from the start, once matched the view of its back face from
    the goal: 0.19 m off, vouched for within 1 cm): where they put the robot
    when they fit clearly better elsewhere (the caller relocates), else None; when they
    match at the estimate, ``doubt`` falls to the farther of the match's own offset and the
    farthest pose explaining them as well, as a ``sigmas`` bound. Too few trusted points,
    no match, or a match that pairs less than ``least_inliers`` of the revolution: the
    doubt stays (0.5: a third of a revolution paired at the estimate once cleared a kick's
    doubt at a corridor's goal, truly 0.34 m off with a 0.043 m bound; on 72 harsh runs
    every claim the check let through paired 58 % or more).

    >>> room = np.array([[0.8, y] for y in np.linspace(-0.6, 0.6, 61)] + [[x, 0.6] for x in np.linspace(-0.6, 0.6, 61)])
    >>> d = Doubt(sd=0.15)
    >>> trusted_check(d, room, np.zeros((len(room), 2)), room, Pose(0.0, 0.0, 0.0)), d.sd < 0.01
    (None, True)
    """
    doubt.pinned = None
    sds = np.asarray(map_sds)
    keep = trusted_surfaces(map_points, sds, pose, doubt.trust)  # seen from this side: a box's front face is not its back
    if int(keep.sum()) < min_points:
        return None
    ref = ReferenceScan(np.asarray(map_points)[keep])
    amb = ambiguity(ref, points, pose, min_points=min_points, sd=sd, correlation=correlation)
    if amb.better is not None:
        return amb.better
    if not amb.matched or amb.inliers < least_inliers:
        return grid_check(doubt, np.asarray(map_points)[keep], sds[keep], points, pose, sd=sd,
                          correlation=correlation, sigmas=sigmas)
    here = match_scans(ref, points, pose, gate=None, min_points=min_points)
    off = math.hypot(here.pose.x - pose.x, here.pose.y - pose.y)
    doubt.confirmed(max(off, amb.distance) / sigmas)
    return None


def grid_check(doubt: Doubt, map_points: np.ndarray, map_sds: np.ndarray, points: np.ndarray, pose: Pose, *,
               radius: float = 0.55, sd: float = 0.02, correlation: float = 4.0, sigmas: float = 2.45,
               least_inliers: float = 0.5, least_paired: int = 40, bound_margin: float = 6.0) -> Pose | None:
    """The trusted surfaces (``map_points``, drawn before the doubt) searched exhaustively for
    the revolution ``points`` (robot frame), at every pose within ``radius`` m of the estimate
    ``pose`` (:func:`~clomp.runtime.estimation.relocalise.relocalise`: a push's range of up to
    0.5 m and the estimate's own error): when a *unique* best fit (no pose farther than its
    ``apart`` as good within its ``unique``; not on the search's edge) pairs ``least_paired``
    points and ``least_inliers`` of the revolution (as the ICP's check above: a unique fit of a
    third of a revolution is no evidence, the rest may fall where the trusted surfaces were never
    seen and the best fit be the pose that lands most points on their drawn extent; at ``harsh``
    unique fits at the goal paired 26-47 %, so this rarely adds a confirmation), and lies within
    its ``sigmas`` bound of the estimate, the doubt falls to
    what it shows (its ``sd``, the poses within ``bound_margin`` of its misfit as a ``sigmas``
    bound, plus the estimate's distance from it over ``sigmas``) and :attr:`Doubt.pinned` says
    so. A fit elsewhere is returned (the caller may relocate); an ambiguous one (a corridor's
    axis) or too little paired leaves the doubt. None unless elsewhere.

    >>> room = np.array([[0.8, y] for y in np.linspace(-0.6, 0.6, 61)] + [[x, 0.6] for x in np.linspace(-0.6, 0.8, 71)])
    >>> seen = np.vstack([room, [[-0.5, y] for y in np.linspace(-0.5, 0.5, 60)]])   # and a wall the map lacks
    >>> d = Doubt(sd=0.15)
    >>> grid_check(d, room, np.zeros((len(room), 2)), seen, Pose(0.0, 0.0, 0.0)), d.sd < 0.02, d.pinned is not None
    (None, True, True)
    >>> wall = np.array([[x, 0.5] for x in np.linspace(-3.0, 3.0, 301)])
    >>> d = Doubt(sd=0.15)
    >>> grid_check(d, wall, np.zeros((301, 2)), wall[100:200], Pose(0.0, 0.0, 0.0)), d.sd   # along a wall: anywhere
    (None, 0.15)
    """
    from clomp.runtime.estimation.relocalise import relocalise  # it imports this module

    res = relocalise(map_points, map_sds, points, pose, radius=radius, sd=sd, correlation=correlation,
                     least_inliers=least_inliers, least_paired=least_paired, sigmas=sigmas, bound_margin=bound_margin)
    if res.pose is None:
        return None
    off = math.hypot(res.pose.x - pose.x, res.pose.y - pose.y)
    if off > sigmas * res.sd:
        return res.pose
    doubt.confirmed(res.sd + off / sigmas)
    doubt.pinned = (pose.x, pose.y)
    return None
