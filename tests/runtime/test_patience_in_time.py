"""UNREACHABLE judged on progress in time as well as in plans (``stall_time``, ``real_progress``):
deep plans that each creep a few centimetres on no longer run a dead end into the time limit."""

from __future__ import annotations

import pytest

from clomp.runtime.supervision.config import SupervisorConfig
from clomp.runtime.supervision.progress import Progress


def test_plans_that_creep_on_for_the_stall_time_give_up():
    p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1))
    # every plan 4 cm closer than the last: enough for the count of plans (3 cm), never 10 cm in 30 s
    verdicts = [p.planned(False, 1.0 - 0.04 * k, 15.0 * k) for k in range(6)]
    assert verdicts[:2] == [None, None] and verdicts[2] is not None and "0.08 m closer in the last 30 s" in verdicts[2]


def test_real_progress_plans_reaching_the_goal_and_a_changed_world_do_not_give_up():
    p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1))
    assert [p.planned(False, 1.0 - 0.12 * k, 12.0 * k) for k in range(6)] == [None] * 6  # 12 cm a plan
    p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1))
    assert [p.planned(True, 1.0, 12.0 * k) for k in range(6)] == [None] * 6  # each plan ends at the goal
    p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1, patience=50))
    assert [p.planned(False, 1.0, t) for t in (0.0, 20.0)] == [None, None]
    p.world_changed()  # a WAIT timed out: the plans before were for another world
    assert [p.planned(False, 1.0, t) for t in (40.0, 60.0)] == [None, None]
    assert p.planned(False, 1.0, 71.0) is not None
    p = Progress(SupervisorConfig(stall_time=0.0, patience=50))  # 0: never judged in time
    assert [p.planned(False, 1.0, 30.0 * k) for k in range(6)] == [None] * 6


@pytest.mark.slow
def test_a_shut_door_at_harsh_ends_unreachable_not_halted_at_the_time_limit():
    """shut seed 0 run 1 at harsh: 9 plans in 120 s, each a little closer, then HALTED at the
    time limit (before the rule in time); now UNREACHABLE, within the limit, no collision."""
    from clomp.runtime.experiment.runrecords import run_spec
    from clomp.runtime.experiment.runspec import RunSpec

    rec = run_spec(RunSpec("shut", 0, 1, "planning", "harsh"))
    assert rec["end_state"] == "UNREACHABLE" and rec["time_s"] < 120.0, (rec["end_state"], rec["reason"])
    assert "closer in the last" in rec["reason"] and rec["collisions"] == 0
