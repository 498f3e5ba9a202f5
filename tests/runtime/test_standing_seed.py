"""Issue #36: a robot moved while it stands building its map's seed must not claim the goal
(clomp.runtime.estimation.standing). At ``harsh`` the world's seed 19 pushes every layout
0.22 m at 0.05 s: the seed was drawn at the pushed pose while the estimate held the start,
and four families ended GOAL_REACHED 0.20-0.26 m off without the gyro."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.estimation.odometry import ScanOdometry
from clomp.runtime.estimation.standing import moved_standing

PERIOD = 0.18  # s: one revolution


def _revolution(at: tuple[float, float], rng: np.random.Generator, walker: tuple[float, float, float] | None = None,
                noise: float = 0.02) -> np.ndarray:
    """One revolution (robot frame, heading 0) from ``at`` in a 2.4 × 2.0 m room centred on the
    start, 1° a ray, ``noise`` m of range noise; ``walker``: a body (x, y, radius) in the room."""
    a = np.radians(np.arange(0.0, 360.0, 1.0))
    c, s = np.cos(a), np.sin(a)
    x0, y0 = at
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (1.2 - x0) / c, np.where(c < 0, (-1.2 - x0) / c, np.inf))
        ty = np.where(s > 0, (1.0 - y0) / s, np.where(s < 0, (-1.0 - y0) / s, np.inf))
    r = np.minimum(tx, ty)
    if walker is not None:
        wx, wy, wr = walker[0] - x0, walker[1] - y0, walker[2]
        along = wx * c + wy * s
        miss2 = wx * wx + wy * wy - along * along
        hit = (along > 0) & (miss2 < wr * wr)
        r = np.where(hit, np.minimum(r, along - np.sqrt(np.maximum(wr * wr - miss2, 0.0))), r)
    r = r + rng.normal(0.0, noise, r.size)
    out: np.ndarray = np.c_[r * c, r * s]
    return out


def _standing(odo: ScanOdometry, revolutions: list[np.ndarray]) -> None:
    for k, pts in enumerate(revolutions):
        odo.update(ScanFrame(pts, PERIOD * (k + 1)))


# -- the test itself -------------------------------------------------------------------------------
def test_noise_alone_is_no_move() -> None:
    rng = np.random.default_rng(0)
    seed = [_revolution((0.0, 0.0), rng) for _ in range(3)]
    assert not moved_standing(seed, _revolution((0.0, 0.0), rng))
    assert not moved_standing(seed[:1], _revolution((0.0, 0.0), rng))  # against one revolution too


@settings(max_examples=30, deadline=None)
@given(st.floats(math.radians(10.0), math.radians(170.0)), st.booleans(), st.floats(0.15, 0.3))
def test_a_push_changes_most_bearings(direction: float, down: bool, size: float) -> None:
    """Pushed 0.15-0.3 m in any direction but within 10° of the room's long axis. Along it the
    side walls' bearings keep their ranges and only the end walls' change (45 % of them here):
    that push is not seen (a limit of the test, measured, not hidden)."""
    rng = np.random.default_rng(1)
    seed = [_revolution((0.0, 0.0), rng) for _ in range(2)]
    direction = -direction if down else direction
    assert moved_standing(seed, _revolution((size * math.cos(direction), size * math.sin(direction)), rng))
    along = _revolution((size, 0.0), rng)
    assert not moved_standing(seed, along)


@settings(max_examples=30, deadline=None)
@given(st.floats(-0.9, 0.9), st.floats(0.45, 0.9), st.floats(0.1, 0.25))
def test_a_walker_in_view_is_not_the_robot_moved(x: float, y: float, radius: float) -> None:
    """A body walking past, as near as 0.45 m and 0.5 m wide, covers a minority of the bearings."""
    rng = np.random.default_rng(2)
    seed = [_revolution((0.0, 0.0), rng) for _ in range(2)]
    assert not moved_standing(seed, _revolution((0.0, 0.0), rng, walker=(x, y, radius)))


def test_too_few_shared_bearings_say_nothing() -> None:
    pts = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert not moved_standing([pts], pts + 0.5)
    assert not moved_standing([], pts)


# -- the estimator ---------------------------------------------------------------------------------
def test_moved_within_the_first_revolutions_raises_the_doubt_and_restarts_the_seed() -> None:
    """Pushed 0.2 m after the first revolution: the doubt is a kick's, the seed restarts from the
    revolution that showed it, and the map drawn from it may not vouch (each surface carries
    the doubt: none counts as drawn before it)."""
    rng = np.random.default_rng(3)
    odo = ScanOdometry(0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    _standing(odo, [_revolution((0.0, 0.0), rng)] + [_revolution((0.15, -0.13), rng) for _ in range(9)])
    assert odo.doubt.sd == pytest.approx(odo.doubt.kick_sd)
    assert [e[1] for e in odo.doubt.events] == ["moved standing"]
    assert "9 still revolutions fused" in odo.records[-1].reason
    assert odo._map_sds is not None and float(odo._map_sds[:, 0].min()) >= odo.doubt.kick_sd - 1e-9
    assert odo.position_sd() >= odo.doubt.kick_sd
    assert odo.confirm_doubt(_revolution((0.15, -0.13), rng)) is None and odo.doubt.sd == pytest.approx(odo.doubt.kick_sd)


def test_moved_after_clean_revolutions_keeps_their_seed_to_relocalise_against() -> None:
    """Pushed after four still revolutions: their seed is the map drawn before the doubt, and
    once the robot drives the first revolution is re-localised against it (as after a kick)."""
    rng = np.random.default_rng(4)
    odo = ScanOdometry(0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    _standing(odo, [_revolution((0.0, 0.0), rng) for _ in range(4)] + [_revolution((0.2, 0.1), rng) for _ in range(4)])
    assert odo.doubt.sd == pytest.approx(odo.doubt.kick_sd) and odo._before_doubt is not None
    t = PERIOD * 9
    odo.advance(t, (0.0, 0.0))
    odo.advance(t + 0.05, (0.02, 0.02))  # it drives 1 mm: the seed is fixed
    rec = odo.update(ScanFrame(_revolution((0.201, 0.1), rng), t + 0.05))
    assert "after a kick" in rec.reason, rec.reason
    assert math.hypot(odo.pose.x - 0.2, odo.pose.y - 0.1) < 0.03 and odo.doubt.sd < 0.05, (odo.pose, odo.doubt.sd)


def test_a_walker_crossing_while_standing_leaves_the_seed_alone() -> None:
    """A body walks across the view, 0.5 m from the robot, while it stands: no doubt, and every
    revolution joins the seed."""
    rng = np.random.default_rng(5)
    odo = ScanOdometry(0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    _standing(odo, [_revolution((0.0, 0.0), rng, walker=(-0.8 + 0.18 * k, 0.5, 0.2)) for k in range(10)])
    assert odo.doubt.sd == 0.0 and not odo.doubt.events
    assert "10 still revolutions fused" in odo.records[-1].reason


# -- the run ---------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("family", ["doorway", "stopper"])
def test_pushed_before_the_first_revolution_ends_does_not_claim_the_goal(family: str) -> None:
    """The world's seed 19 at ``harsh``, without the gyro: pushed 0.22 m at 0.05 s. Before this
    check both runs ended GOAL_REACHED 0.258 and 0.224 m off."""
    from clomp.runtime.experiment.onerun import run_once
    from clomp.runtime.experiment.runspec import RunSpec, movers_for, noise_seed, scene_for

    spec = RunSpec(family, 19, 0, "planning", "harsh", gyro=False)
    scene, expect = scene_for(spec)
    r = run_once(scene, "planning", noise_seed(19, 0), run=0, noise="harsh", expect=expect, gyro=False,
                 movers=movers_for(spec))
    assert r.end_state != "GOAL_REACHED", (r.end_state, r.final_distance, r.reason)
