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
    p.world_changed(10.0)  # a WAIT timed out after 10 s: standing is not search time
    assert p.planned(False, 1.0, 39.0) is None  # 29 s of search
    assert p.planned(False, 1.0, 41.0) is not None  # 31 s
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


def test_back_offs_between_frontier_plans_are_judged_in_time() -> None:
    """cul-de-sac 17/0 (harsh, gyro): a frontier plan, a back-off, a frontier plan, a back-off …
    each ended the other's count of ``confirm`` and only the frontier plans were judged in
    time, one point in 85 s: HALTED at the time limit. Every plan counts in time now."""
    p = Progress(SupervisorConfig(stall_time=30.0, real_progress=0.1, confirm=3, patience=6))
    assert p.planned(False, 0.986, 1.9) is None
    assert p.backed_off(0.612, 56.2) is None  # 0.37 m closer than 54 s before: progress
    assert p.planned(False, 1.017, 66.6) is None
    why = p.backed_off(0.575, 87.0)  # 0.04 m closer than at 57 s
    assert why is not None and "0.04 m closer in the last 30 s" in why


def test_a_wait_timing_out_again_and_again_does_not_wipe_the_search() -> None:
    """shut 23/0 (harsh, no gyro): three WAITs timed out (the wall looked new after the
    estimate moved) and each wiped the record in time, so 30 s of search never piled up.
    A WAIT excuses the seconds it stood, not the search before it."""
    cfg = SupervisorConfig(stall_time=30.0, real_progress=0.1, patience=50, wait_timeout=4.0)
    p = Progress(cfg)
    verdicts = []
    for k in range(8):
        verdicts.append(p.planned(False, 0.7, 12.0 * k))
        p.world_changed(cfg.wait_timeout)
    first = next(i for i, v in enumerate(verdicts) if v is not None)
    assert first == 4, verdicts  # at 48 s of the run, 4 x 4 s stood: 32 s of search, 0 m closer


@pytest.mark.slow
def test_a_cul_de_sac_that_alternates_back_offs_and_frontier_plans_ends_unreachable() -> None:
    """cul-de-sac seed 17 run 0 at harsh, with the gyro: a 55 s frontier plan, then back-offs
    and frontier plans in turn, HALTED at the 120 s limit (0.61 m from the goal) when only the
    frontier plans were judged in time; now UNREACHABLE within the limit, no collision."""
    from clomp.runtime.experiment.runrecords import run_spec
    from clomp.runtime.experiment.runspec import RunSpec

    rec = run_spec(RunSpec("cul-de-sac", 17, 0, "planning", "harsh", gyro=True))
    assert rec["end_state"] == "UNREACHABLE" and rec["time_s"] < 120.0, (rec["end_state"], rec["reason"])
    assert "closer in the last" in rec["reason"] and rec["collisions"] == 0
