"""At the goal by the estimate: whether the estimate can vouch for it (issue #36).

The supervisor (:mod:`clomp.runtime.supervision.supervisor`) calls :func:`relocated_at_goal`
before it declares the goal on a settled estimate, and :func:`at_goal` to end the run:
GOAL_REACHED when the distance plus the position's 95 % bound is within ``vouch_radius``,
else GOAL_UNCONFIRMED, both with the distance and the bound in the reason and the log.

>>> from clomp.planner import load_scenario
>>> from clomp.runtime.backends.sim import SimRobot
>>> from clomp.runtime.supervision.supervisor import Supervisor
>>> scene = load_scenario("open")
>>> sup = Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame())
>>> relocated_at_goal(sup, 0.0)     # no revolution seen yet: nothing to search with
False
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from clomp.runtime.supervision.states import Event as E

if TYPE_CHECKING:  # pragma: no cover
    from clomp.runtime.supervision.supervisor import Supervisor

__all__ = ["at_goal", "relocated_at_goal"]


def relocated_at_goal(sup: Supervisor, now: float) -> bool:
    """At the goal by the estimate: before it vouches, a wider search (several starting
    guesses) asks whether the revolutions seen standing here fit the map clearly better
    elsewhere — in doubt, the map drawn before the doubt, which lowers the doubt when
    they do not (:meth:`~clomp.runtime.supervision.sensing.Sensing.confirm_doubt`); if
    so the estimate moves there (at most ``relocate_at_goal`` times a run, 0 by default)
    and the robot plans on from it. True when it moved."""
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


def at_goal(sup: Supervisor, dist: float, what: str) -> None:
    """The estimate is ``dist`` m from the goal, within ``goal_radius``: GOAL_REACHED when
    the distance plus the position's 95 % bound is within ``vouch_radius`` (or no bound
    is asked for or known), else GOAL_UNCONFIRMED; both say the distance and the bound."""
    cfg = sup.config
    bound = sup.sensing.position_bound(cfg.vouch_sigmas)
    sup._goal_end = (dist, bound)
    if bound is None or cfg.vouch_radius is None:
        sup._fire(E.AT_GOAL, f"{what} ({dist:.3f} m)")
    elif dist + bound <= cfg.vouch_radius:
        sup._fire(E.AT_GOAL, f"{what} ({dist:.3f} m, 95 % bound {bound:.3f} m)")
    else:
        sup._fire(E.GOAL_UNCONFIRMED, f"{what} by the estimate ({dist:.3f} m), but its 95 % bound {bound:.3f} m "
                                       f"cannot vouch for {cfg.vouch_radius:g} m: unconfirmed")
