"""Issue #36, the robot *with* a gyro at ``harsh``: a gyro whose gain is wrong turns the heading
off by the gain's error times the rotation. Matches against surfaces the turning estimate drew
show only part of it, and those that do not pin the heading within ``learn_heading_sd`` taught
the filter nothing: clutter 15/0 turned its heading 10° off in one turn on the spot (a gain
8.9 % high) while the honest heading said 1-1.7°, and claimed the goal 0.155 m off. Two
answers, each tested here: what the filter vouches for covers what the unlearnt gain can
make of a turn (:meth:`~clomp.runtime.estimation.ekf.OdometryFilter._floor_turn`), and the gain
is learnt from matches pinning the heading within ``turn_learn_sd`` once the robot has turned
``turn_learn_after``. All in simulated time."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Pose
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.experiment.runrecords import run_spec
from clomp.runtime.experiment.runspec import RunSpec

DT = 0.1
MATCH_SD = math.radians(1.2)  # what the clutter's posts gave a match: 0.9-1.6°


def _turn(f: OdometryFilter, gain: float, rate: float, seconds: float, shown: float) -> float:
    """Turn on the spot at ``rate`` (rad/s) for ``seconds``, the gyro reading ``gain`` times the
    truth; every 0.2 s (a revolution) a match fixes the position and measures ``shown`` of the
    heading's true error (a map drawn by the turning estimate pulls the rest to the
    prediction), its heading good to MATCH_SD. First it stands 3 s, the gyro reading its
    offset (0: at a steady rate an offset and a gain turn the heading alike). Returns the true
    heading."""
    for _ in range(30):
        f.zero_rate(0.0, DT)
    truth = 0.0
    for step in range(round(seconds / DT)):
        truth += rate * DT
        f.predict(0.0, rate, DT, turned=gain * rate * DT)
        if step % 2 == 1:
            err = wrap_angle(f.pose.theta - truth)
            info = np.diag([1e6, 1e6, 1.0 / MATCH_SD**2])
            f.correct((-f.pose.x, -f.pose.y, -shown * err), info, map_sd=(0.0, math.radians(0.2)))
    return truth


@settings(max_examples=25, deadline=None)
@given(gain=st.floats(0.90, 1.10), rate=st.sampled_from([-0.5, -0.3, 0.3, 0.5]), shown=st.floats(0.0, 0.5),
       learn=st.booleans())
def test_a_wrong_gain_is_admitted_in_the_honest_heading(gain: float, rate: float, shown: float, learn: bool) -> None:
    """After a turn of up to 1.5 rad the honest heading's 95 % bound covers the true heading
    error, the gain learnt or not (``turn_learn_sd`` None: no learning at all). Before the floor
    it stayed near the matches' 1.2° while the error reached 0.1 x 1.5 rad = 8.6°. Learning, the
    matches show at least a tenth of the error: matches that show none of it and still teach the
    gain make it look learnt, and the bound is then short by a little (2.56 sd at worst)."""
    assume(shown >= 0.1 or not learn)
    f = OdometryFilter(0.15, calibration_sd=(0.06, 0.06, 0.3, 0.02), turn_learn_sd=math.radians(1.5) if learn else None)
    truth = _turn(f, gain, rate, 3.0, shown)
    err = abs(wrap_angle(f.pose.theta - truth))
    if not learn:
        assert f.calibration[1] == 0.0  # nothing learnt
    # 2.45 sd (the 95 % bound of the goal rule) of the honest heading, with the gain's error
    # within 2 of its prior sd (0.06): a gain 10 % off is 1.7 sd
    assert err <= 2.45 * math.sqrt(f.honest[2, 2]) + 1e-9, (math.degrees(err), math.degrees(math.sqrt(f.honest[2, 2])))


def test_matches_within_the_turn_learning_bound_teach_the_gain() -> None:
    """The gyro reads 9 % high; matches pin the heading to 1.2° (too coarse to learn the wheels
    from) and show half of its error: after a turn the gain is learnt (k near 1/1.09 - 1 = -0.083)
    and the next turn ends within a degree, where the unlearnt filter is 7° off."""
    errors = {}
    for learn in (True, False):
        f = OdometryFilter(0.15, calibration_sd=(0.06, 0.06, 0.3, 0.02),
                           turn_learn_sd=math.radians(1.5) if learn else None)
        _turn(f, 1.09, 0.5, 3.0, 0.5)
        f.shift(Pose(0.0, 0.0, 0.0))  # the second turn starts from a known heading
        truth = 0.0
        for _ in range(round(3.0 / DT)):  # a second turn, no match: the gain alone
            truth += 0.5 * DT
            f.predict(0.0, 0.5, DT, turned=1.09 * 0.5 * DT)
        errors[learn] = abs(wrap_angle(f.pose.theta - truth))
        if learn:
            assert -0.12 < f.calibration[1] < -0.04, f.calibration
        else:
            assert f.calibration[1] == 0.0
    assert errors[True] < math.radians(2.0) < math.radians(5.0) < errors[False], {k: math.degrees(v) for k, v in errors.items()}


def test_a_sharp_heading_fix_restarts_the_count() -> None:
    """A match pinning the heading within ``learn_heading_sd`` fixes it: the rotation the gain
    may have spoilt counts from there (the floor falls back to what the matches say)."""
    f = OdometryFilter(0.15, calibration_sd=(0.06, 0.06, 0.3, 0.02), turn_learn_sd=None)
    _turn(f, 1.0, 0.5, 3.0, 0.0)
    assert abs(f.turn_unfixed) > 1.4
    f.correct((0.0, 0.0, 0.0), np.diag([1e6, 1e6, 1.0 / math.radians(0.2) ** 2]))
    assert f.turn_unfixed == 0.0


def test_without_a_gyro_nothing_is_floored_nor_learnt_from_turns() -> None:
    """The wheels' turn scale is not the gyro's gain: without ``turned`` the count stays 0."""
    f = OdometryFilter(0.15)
    for _ in range(30):
        f.predict(0.0, 0.5, DT)
    assert f.turn_unfixed == 0.0


@pytest.mark.slow
def test_clutter_15_with_the_gyro_claims_no_goal_it_is_not_at() -> None:
    """clutter seed 15 run 0 at ``harsh`` with the gyro (gain 1.089): GOAL_REACHED 0.155 m off
    before (the heading 10° off, honest 0.9°). Now the gain is learnt (the estimate 0.03 m off
    where it claimed before) and the turns' floor keeps the goal unconfirmed; standing, a push
    later moves the robot 0.3 m, and the run ends GOAL_UNCONFIRMED."""
    rec = run_spec(RunSpec("clutter", 15, 0, "planning", "harsh", gyro=True))
    assert not rec["false_success"], (rec["end_state"], rec["final_error_m"], rec["reason"])
