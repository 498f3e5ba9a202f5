"""At the goal by the estimate: whether the estimate can vouch for it (issue #36).

The supervisor (:mod:`clomp.runtime.supervision.supervisor`) calls :func:`relocated_at_goal`
before it declares the goal on a settled estimate, and :func:`at_goal` to decide: GOAL_REACHED
when the distance plus the position's 95 % bound is within ``vouch_radius``; otherwise it
does not give up at once but *confirms* (CONFIRMING, wheels stopped, :func:`confirm_tick`):

- it stands and looks: each revolution the estimator corrects the estimate, and in doubt
  (an IMU shock, a revolution seeing past the map) the wide search against the map drawn
  before the doubt may clear the doubt's floor (:func:`relocated_at_goal`);
- the goal is declared as soon as the settled estimate vouches for it, by the same rule with
  two more terms (:func:`standing_bound`): standing, the same surfaces are matched again and
  again, and their own error does not average out, so the bound is at least ``vouch_sigmas``
  times how wrong the map the revolutions meet may be
  (:attr:`~clomp.runtime.estimation.odometry.ScanOdometry.last_map_sd`); and when a revolution
  seen standing leaves a direction of the position unobserved (a corridor's axis), standing
  cannot have taught the filter anything there, so the filter's part of the bound is not
  credited below what it was when confirming began (a robot set down 0.1 m along a corridor,
  a bound of 0.102 m at the goal, was otherwise declared there after 12 revolutions of
  shrinking by correlation alone, truly 0.109 m off);
- when the settled (or re-localised) estimate has left the goal, it approaches again
  (``approach`` → REPLANNING: a plan to the goal from there), at most ``confirm_approaches``
  times a run;
- after ``confirm_looks`` revolutions standing still not vouched, the run ends
  GOAL_UNCONFIRMED, the distance and the bound in its reason and the log.

Evidence that does not share the map's errors (:func:`seen_past`): a robot pushed where
nothing felt it, or whose heading drifted with the surfaces it drew, is matched near its
estimate against a map that drew what it saw there, so the matches agree with it and its
bound stays small (at ``harsh`` without the gyro, 9 of 120 runs ended GOAL_REACHED
0.10-0.27 m off, believing a bound of 0.01-0.08 m). Standing at the goal, the fused
revolutions then see *past* the surfaces the map drew before (behind the robot, beside
it): at :attr:`~clomp.runtime.estimation.doubt.Doubt.goal_through` bearings or more the
estimate cannot vouch for the goal, whatever its bound; the doubt rises as after a kick,
and only the wide search against the surfaces drawn before the doubt lowers it.

>>> from clomp.planner import load_scenario
>>> from clomp.runtime.backends.sim import SimRobot
>>> from clomp.runtime.supervision.supervisor import Supervisor
>>> scene = load_scenario("open")
>>> sup = Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame())
>>> relocated_at_goal(sup, 0.0)     # no revolution seen yet: nothing to search with
False
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from clomp.formal.geometry import relative
from clomp.runtime.estimation.vouch import blind_floor
from clomp.runtime.supervision.states import Event as E

if TYPE_CHECKING:  # pragma: no cover
    from clomp.runtime.supervision.supervisor import Supervisor

__all__ = ["at_goal", "bound_parts", "bound_words", "claim_floor", "confirm_tick", "relocated_at_goal", "seen_past",
           "standing_bound"]


def relocated_at_goal(sup: Supervisor, now: float) -> bool:
    """At the goal by the estimate: before it vouches, a wider search (several starting
    guesses) asks whether the revolutions seen standing here fit the map clearly better
    elsewhere — in doubt, the map drawn before the doubt, which lowers the doubt when
    they do not (:meth:`~clomp.runtime.supervision.sensing.Sensing.confirm_doubt`); if
    so the estimate moves there (at most ``relocate_at_goal`` times a run, 0 by default)
    and the robot plans on from it. True when it moved. After a shock, first the map drawn
    before it re-localises the robot (:meth:`~clomp.runtime.estimation.relocalise.KickMemory.relocalise_after_kick`):
    well supported, the doubt falls to what it shows and, when it puts the robot elsewhere,
    the estimate moves there (whatever ``relocate_at_goal``: the evidence is unique)."""
    settled = _after_kick(sup)
    if settled is not None:
        return settled
    better = sup.sensing.confirm_doubt()  # in doubt: searched widely against the map drawn before it
    if better is None and sup._relocations < sup.config.relocate_at_goal:
        better = sup.sensing.better_pose()
    if better is None or sup._relocations >= sup.config.relocate_at_goal:
        return False
    was = sup.pose
    sup.sensing.relocate(better)
    sup.pose = sup.sensing.pose
    sup._relocations += 1
    sup._log("relocated", before=was.as_list(), pose=sup.pose.as_list())
    return True


def _after_kick(sup: Supervisor) -> bool | None:
    """In doubt after a shock, the revolutions fused standing here re-localised against the
    map drawn before it: True when that moved the estimate (the poses follow it), False
    when it settled the doubt where the estimate is, None when it did not settle it."""
    est = sup.estimator
    if est is None or sup.sensing.scan is None:
        return None
    was = sup.pose
    moved = est.relocalise_after_kick(sup.sensing.planning_scan(), sigmas=sup.config.vouch_sigmas)
    res = est.last_relocalisation
    if res is not None and res.pose is not None:
        sup._log("relocalised after a kick" if moved is not None else "confirmed after a kick",
                 before=was.as_list(), pose=est.pose.as_list(), sd=round(est.doubt.sd, 4), why=res.why)
    if res is None or res.pose is None:
        return None
    if moved is None:
        return False
    sup.sensing.pose = sup.pose = est.pose
    return True


def seen_past(sup: Supervisor) -> int:
    """Standing at the goal by the estimate: how many bearings of the revolutions fused here
    look past the surfaces the map holds (:meth:`~clomp.runtime.estimation._localmap.LocalMap.sees_past`)
    when they are :attr:`~clomp.runtime.estimation.doubt.Doubt.goal_through` or more (the
    doubt then rises to a kick's, :attr:`~clomp.runtime.estimation.doubt.Doubt.kick_sd`),
    else 0; 0 without scan feedback or a revolution. Evidence the matches cannot hide: they
    pair what is seen with the map near the estimate, while a robot that stands elsewhere
    sees through surfaces the map drew from where it was."""
    est = sup.estimator
    if est is None or sup.sensing.scan is None:
        return 0
    if est.doubt.take_pinned(est.pose):  # the wide search just pinned it to the surfaces drawn before the doubt
        return 0
    scan = sup.sensing.planning_scan()
    through, _ = est.sees_past(scan)
    if through >= est.doubt.goal_through:
        est.doubt.raise_to(est.doubt.kick_sd, sup.clock.now(), "seen past at the goal")
        return through
    before = est.stands_before(scan)  # or short of them: what is not drawn stands before what is
    if before >= est.doubt.goal_through:
        why = f"it sees {before} bearings stand before surfaces the map drew"
        est.doubt.raise_to(est.doubt.kick_sd, sup.clock.now(), why)
        if not est.doubt.events or est.doubt.events[-1][1] != why:
            est.doubt.events.append((sup.clock.now(), why, est.doubt.sd))
        return before
    moved = est.start_posts_shift(scan)  # seen from any side, the start's posts (issue #36)
    turned = est.compass.measure(scan, est.pose, est.range_sd, either_side=True) \
        if est.compass is not None and est.compass.seeded else None  # and the start's faces, from behind too
    if moved is not None and moved > est.doubt.posts_moved:
        why = f"the start's posts put it {moved:.3f} m away"
    elif turned is not None and abs(turned[0]) > max(3.0 * turned[1], est.doubt.faces_turned):
        why = f"the start's faces turn it by {math.degrees(turned[0]):.1f}°"
    else:
        return 0
    est.doubt.raise_to(est.doubt.kick_sd, sup.clock.now(), why)
    if not est.doubt.events or est.doubt.events[-1][1] != why:  # already in doubt: said all the same
        est.doubt.events.append((sup.clock.now(), why, est.doubt.sd))
    return est.doubt.goal_through


def _past_words(sup: Supervisor, past: int) -> str:
    """What :func:`seen_past` found, in words."""
    events = [] if sup.estimator is None else sup.estimator.doubt.events
    if events and str(events[-1][1]).startswith(("the start's", "it sees")):
        return str(events[-1][1])
    return f"it sees past {past} bearings of the map"


def at_goal(sup: Supervisor, dist: float, what: str) -> None:
    """The estimate is ``dist`` m from the goal, within ``goal_radius``: GOAL_REACHED when
    the distance plus the position's 95 % bound is within ``vouch_radius`` (or no bound
    is asked for or known), else CONFIRMING (stand and look, :func:`confirm_tick`); both
    say the distance and the bound."""
    cfg = sup.config
    past = seen_past(sup) if cfg.vouch_radius is not None else 0
    bound = sup.sensing.position_bound(cfg.vouch_sigmas)
    floored = ""
    if bound is not None and cfg.vouch_radius is not None:
        floor = claim_floor(sup)
        if floor > bound:
            bound, floored = floor, _floor_words(sup)
    sup._goal_end = (dist, bound)
    if bound is None or cfg.vouch_radius is None:
        sup._fire(E.AT_GOAL, f"{what} ({dist:.3f} m)")
    elif dist + bound <= cfg.vouch_radius and not past:
        sup._fire(E.AT_GOAL, f"{what} ({dist:.3f} m, 95 % bound {bound:.3f} m)")
    else:
        sup.sensing.stopped()  # the revolutions seen standing are counted from here
        sup._confirm_seen = 0
        sup._confirm_blind = False
        est = sup.estimator
        sup._confirm_honest = 0.0 if est is None else est.vouched_sd()
        sup._confirm_from = 0 if est is None else len(est.records)
        why = (f"{what} by the estimate ({dist:.3f} m), but its 95 % bound {bound:.3f} m"
               f"{f', {floored},' if floored else ''} cannot vouch for {cfg.vouch_radius:g} m")
        if past:
            why += f" (standing, {_past_words(sup, past)}: it may stand elsewhere)"
        sup._fire(E.GOAL_UNCONFIRMED, f"{why}: confirming")
        if cfg.confirm_looks == 0:  # no looking asked for: unconfirmed at once
            sup._fire(E.GOAL_UNCONFIRMED, f"{why}: unconfirmed")


def standing_bound(sup: Supervisor) -> float | None:
    """The 95 % bound a decision taken standing uses: the estimate's
    (:meth:`~clomp.runtime.supervision.sensing.Sensing.position_bound`), at least
    ``vouch_sigmas`` times how wrong the surfaces the last revolution met may be (matched
    again and again, their error does not average out), and, once a revolution seen
    standing left a direction of the position unobserved, at least ``vouch_sigmas`` times
    the filter's position uncertainty when confirming began — neither when a revolution seen
    standing since vouches for the position by itself (:func:`_fresh_evidence`: its bound counts
    the surfaces it met and does not depend on the gain); None without scan feedback."""
    sigmas = sup.config.vouch_sigmas
    bound = sup.sensing.position_bound(sigmas)
    est = sup.estimator
    if bound is None or est is None:
        return bound
    bound = max(bound, claim_floor(sup))  # what the revolution here cannot vouch for, whatever the filter says
    if _fresh_evidence(sup):  # it counts the error of the surfaces it met itself
        return bound
    floor = sigmas * float(est.last_map_sd[0])
    if sup._confirm_blind:
        floor = max(floor, sigmas * sup._confirm_honest)
    return max(bound, floor)


def claim_floor(sup: Supervisor) -> float:
    """The least 95 % bound (m) the revolutions seen at the goal leave the position, whatever
    the filter believes (:mod:`~clomp.runtime.estimation.vouch`): along a translation they
    leave unobserved, the prior's forward-scale uncertainty times the way from the start along
    it (:func:`~clomp.runtime.estimation.vouch.blind_floor`); and, once a doubt was raised in
    the run (the gain opened to it, so the estimate may have jumped onto an alias since), how
    far a pose lies that the surfaces seen first explain as well
    (:meth:`~clomp.runtime.estimation.odometry.ScanOdometry.start_ambiguity`; never doubted,
    the estimate followed the wheels and matches within its gate, and at ``paper`` that search
    would have held back 228 of 1,394 true claims, a corridor's or a doorway wall's axis
    aliased by the guesses' 0.12-0.25 m). 0 without scan feedback, a revolution or
    ``vouch_radius``; both parts are kept for :func:`bound_parts`."""
    est = sup.estimator
    sup._claim_floor = (0.0, "", 0.0)
    if est is None or sup.sensing.scan is None or sup.config.vouch_radius is None:
        return 0.0
    scan = sup.sensing.planning_scan()
    blind, along = blind_floor(scan, est.pose, est.start_pose, est.filter.calibration_sd[0],
                               sigmas=sup.config.vouch_sigmas)
    start = est.start_ambiguity(scan) if est.doubt.events else 0.0
    sup._claim_floor = (blind, along, start)
    return max(blind, start)


def _fresh_evidence(sup: Supervisor) -> bool:
    """Whether a revolution seen standing since confirming began vouches for the position by
    itself (:attr:`~clomp.runtime.estimation.odometry.ScanOdometry.evidence`: a match observing
    every direction, its bound independent of what the gain made of the blind ones, which
    :func:`standing_bound`'s floor guards against)."""
    est = sup.estimator
    ev = None if est is None else est.evidence
    return ev is not None and ev.revolution >= sup._confirm_from


def bound_parts(sup: Supervisor) -> dict[str, float]:
    """What sets the 95 % bound a decision taken standing uses (:func:`standing_bound`): each
    part as ``vouch_sigmas`` standard deviations (m) — ``filter`` (the filter's honest position
    uncertainty), ``doubt`` (the floor only a wide search lowers,
    :class:`~clomp.runtime.estimation.doubt.Doubt`), ``disagreement`` (well-matched revolutions
    rejected just now), ``map`` (how wrong the surfaces met may be), ``blind`` (the filter's
    figure when confirming began, once a revolution standing left a direction unobserved),
    ``unobserved`` (the prior along a direction the goal's revolution leaves unobserved) and
    ``start`` (a pose the surfaces seen first explain as well; both :func:`claim_floor`, as
    last computed); empty without scan feedback. The bound is the largest but for ``disagreement``, which adds.
    Why a run ended unconfirmed, in its reason and log (issue #36: on seeds 35-44 at ``harsh``
    most truly-reached runs that were not claimed stood at a doubt's floor of 0.367 m).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> from clomp.runtime.supervision.supervisor import Supervisor
    >>> scene = load_scenario("open")
    >>> sorted(bound_parts(Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame())))
    ['blind', 'disagreement', 'doubt', 'filter', 'map', 'start', 'unobserved']
    """
    est = sup.estimator
    if est is None:
        return {}
    k = sup.config.vouch_sigmas
    fresh = _fresh_evidence(sup)
    dis = est.disagreement if est.rejected_in_a_row > 0 and est.disagreement is not None else (0.0, 0.0, 0.0)
    return {"filter": k * est.vouched_sd(), "doubt": k * est.doubt.sd,
            "disagreement": k * math.hypot(dis[0], dis[1]), "map": 0.0 if fresh else k * float(est.last_map_sd[0]),
            "blind": k * sup._confirm_honest if sup._confirm_blind and not fresh else 0.0,
            "unobserved": sup._claim_floor[0], "start": sup._claim_floor[2]}


_PART_WORDS = {
    "filter": "the filter's position uncertainty",
    "disagreement": "matches that disagree with the prediction",
    "map": "how wrong the surfaces it meets may be",
    "blind": "the filter's uncertainty when confirming began (standing left a direction unobserved)",
    "unobserved": "the prior along {along}, which the revolution at the goal leaves unobserved",
    "start": "a pose as far that the surfaces seen first explain as well",
}


def _floor_words(sup: Supervisor) -> str:
    """Which part of :func:`claim_floor` is the larger, in words (as :func:`bound_words`)."""
    blind, along, start = sup._claim_floor
    name = "unobserved" if blind >= start else "start"
    return f"set by {_PART_WORDS[name].format(along=along)}"


def _doubt_source(sup: Supervisor) -> str:
    """The last event of the doubt that put its floor where it is (a shock's size is its
    acceleration: a kick's floor is ``kick_sd``, a jolt's ``jolt_sd``), or '' when none did (a
    wide search set it since); with its time.

    >>> from clomp.runtime.estimation.doubt import Doubt
    >>> class _S: pass
    >>> s = _S(); s.estimator = _S(); s.estimator.doubt = d = Doubt()
    >>> _ = d.shock(120.0, 3.0); _ = d.shock(8.0, 5.0)   # a kick, then a jolt: the kick's floor stands
    >>> _doubt_source(s)
    'kick at 3.0 s'
    """
    est = sup.estimator
    if est is None:
        return ""
    d = est.doubt
    for t, kind, size in reversed(d.events):
        floor = d.kick_sd if kind == "kick" else d.jolt_sd if kind == "jolt" else float(size)
        if abs(floor - d.sd) <= 1e-6:
            return f"{kind} at {t:.1f} s"
    return ""


def bound_words(sup: Supervisor) -> str:
    """The largest part of the bound (:func:`bound_parts`) in words, '' without scan feedback;
    the doubt's names the event that set it (:func:`_doubt_source`)."""
    parts = bound_parts(sup)
    if not parts:
        return ""
    name = max(parts, key=lambda n: parts[n])
    if parts[name] <= 0.0:
        return ""
    if name != "doubt":
        return f"set by {_PART_WORDS[name].format(along=sup._claim_floor[1])}"
    source = _doubt_source(sup)
    return "set by the doubt's floor" + (f" (raised by: {source})" if source else "")


def _blind(names: tuple[str, ...]) -> bool:
    """True when a match left a direction of the position unobserved (any but pure heading).

    >>> _blind(("heading",)), _blind(("x",)), _blind(("0.30y+0.95heading",))
    (False, True, True)
    """
    return any(n != "heading" for n in names)


def confirm_tick(sup: Supervisor, now: float) -> None:
    """CONFIRMING, one tick (wheels stopped): on each new revolution after the fused ones,
    search in doubt (:func:`relocated_at_goal`), then declare the goal when the settled
    estimate vouches for it, approach again when it left the goal, and give up
    (GOAL_UNCONFIRMED) after ``confirm_looks`` revolutions (see the module docstring)."""
    s, cfg = sup.sensing, sup.config
    if s.since_stop == sup._confirm_seen:
        return  # no new revolution
    sup._confirm_seen = s.since_stop
    looked = s.since_stop
    est = sup.estimator
    if est is not None and est.records:
        sup._confirm_blind = sup._confirm_blind or _blind(est.records[-1].unobservable)
    if looked < min(cfg.fused_revolutions, cfg.confirm_looks):
        return  # the wide search and the decision read the revolutions fused
    relocated_at_goal(sup, now)
    g = relative(sup.pose, sup.goal)
    dist = math.hypot(g.x, g.y)
    past = seen_past(sup) if cfg.vouch_radius is not None and dist <= sup.goal_radius else 0
    bound = standing_bound(sup)
    sup._goal_end = (dist, bound)
    b = math.inf if bound is None else bound
    radius = math.inf if cfg.vouch_radius is None else cfg.vouch_radius
    if dist <= sup.goal_radius and dist + b <= radius and not past:
        sup._fire(E.AT_GOAL, f"at the goal, confirmed after {looked} revolutions standing ({dist:.3f} m, "
                             f"95 % bound {b:.3f} m)")
    elif dist > sup.goal_radius and sup._approaches < cfg.confirm_approaches:
        sup._approaches += 1
        sup._fire(E.APPROACH, f"confirming: the settled estimate puts the goal {dist:.3f} m away (95 % bound "
                              f"{b:.3f} m): approach {sup._approaches} of {cfg.confirm_approaches}")
    elif dist > sup.goal_radius or looked >= cfg.confirm_looks:
        where = "at the goal" if dist <= sup.goal_radius else f"{dist:.3f} m from the goal, no approach left,"
        seen = f", and {_past_words(sup, past)}" if past else ""
        words = bound_words(sup)
        sup._log("bound", **{k: round(v, 4) for k, v in bound_parts(sup).items()})
        sup._fire(E.GOAL_UNCONFIRMED, f"{where} by the estimate ({dist:.3f} m) after {looked} revolutions standing, "
                                      f"but its 95 % bound {b:.3f} m{f', {words},' if words else ''} cannot vouch "
                                      f"for {radius:g} m{seen}: unconfirmed")
