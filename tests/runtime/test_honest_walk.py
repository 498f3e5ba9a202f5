"""Issue #36, the robot without a heading sensor at ``harsh`` with the unmodelled error sources:
what its estimate admits (``honest``) must cover what it truly is, or it claims goals it is not
at. Two causes, each with its figure: a walk its model and its matches cannot show
(:data:`~clomp.runtime.estimation.prior.UNSEEN_WALK`), and map points met from behind
(:data:`~clomp.runtime.estimation._localmap.BEHIND_SD`). All in simulated time."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from clomp.formal.model import Pose
from clomp.runtime.estimation._localmap import BEHIND_SD
from clomp.runtime.estimation.odometry import ScanOdometry
from clomp.runtime.estimation.prior import UNSEEN_WALK, OdometryPrior
from clomp.runtime.experiment.runrecords import run_spec
from clomp.runtime.experiment.runspec import RunSpec


def _wall_drawn_from_the_start(walk: bool) -> ScanOdometry:
    """A map of one wall across x = 1 m (y from -0.5 to 0.5), drawn from the origin with a
    position sd of 1 mm; a robot whose prior admits the walk or not."""
    prior = dataclasses.replace(OdometryPrior.worst(), honest_walk=UNSEEN_WALK if walk else (0.0, 0.0, 0.0))
    odo = ScanOdometry(0.15, prior=prior)
    ys = np.arange(-0.5, 0.501, 0.01)
    odo._map_points = np.c_[np.full(len(ys), 1.0), ys]
    odo._map_sds = np.c_[np.full(len(ys), 0.001), np.zeros(len(ys)), np.arctan2(ys, 1.0)]
    return odo


def test_a_wall_met_from_behind_vouches_for_no_better_than_an_objects_depth() -> None:
    wall = np.c_[np.full(21, 1.0), np.linspace(-0.2, 0.2, 21)]
    front, behind = Pose(0.2, 0.0, 0.0), Pose(1.8, 0.0, math.pi)
    seen_front = np.c_[wall[:, 0] - front.x, wall[:, 1]]  # robot frame: heading 0
    seen_behind = np.c_[behind.x - wall[:, 0], -wall[:, 1]]  # robot frame: heading pi
    odo = _wall_drawn_from_the_start(walk=True)
    assert odo._map_sd(seen_front, front)[0] == pytest.approx(0.001)
    assert odo._map_sd(seen_behind, behind)[0] >= BEHIND_SD
    # a surface drawn after the start carries the walked figure that drew it, seen from anywhere
    drawn_later = _wall_drawn_from_the_start(walk=True)
    assert drawn_later._map_sds is not None
    drawn_later._map_sds[:, 0] = 0.01
    assert drawn_later._map_sd(seen_behind, behind)[0] == pytest.approx(0.01)
    # a robot that admits no unseen walk keeps the figure as drawn (with the gyro: unchanged)
    assert _wall_drawn_from_the_start(walk=False)._map_sd(seen_behind, behind)[0] == pytest.approx(0.001)


@pytest.mark.slow
@pytest.mark.parametrize("family,seed,run", [
    # crept 0.02 → 0.09 m along a doorless room, the end wall drawn nearer as it went, while the
    # admitted uncertainty grew to 0.017 m: GOAL_REACHED 0.103 / 0.104 m off, bound 0.041 / 0.042 m
    ("stopper", 0, 3),
    ("appearing", 0, 3),
    # the heading right, the position drifted 0.09 m while the map grew by 250 points: 0.123 m off
    ("appearing", 4, 1),
    # a 20° heading drift among boxes, confirmed standing with a bound of 0.092 m: 0.280 m off
    ("slalom", 4, 2),
])
def test_an_unseen_walk_is_admitted_so_no_false_success(family: str, seed: int, run: int) -> None:
    rec = run_spec(RunSpec(family, seed, run, "planning", "harsh", gyro=False))
    assert not rec["false_success"], (rec["end_state"], rec["final_error_m"], rec["reason"])


@pytest.mark.slow
def test_past_the_u_trap_the_start_seen_from_behind_does_not_vouch() -> None:
    """u-trap seed 0 run 3: past the trap every point met was the start's seed seen from
    behind (0 m of map error), the honest figure fell to 7 mm while the estimate drifted 0.1 m
    sideways, and the goal was claimed 0.109 m off (bound 0.017 m)."""
    rec = run_spec(RunSpec("u-trap", 0, 3, "planning", "harsh", gyro=False))
    assert not rec["false_success"], (rec["end_state"], rec["final_error_m"], rec["reason"])
