"""``bench/calibration_gap.py``: how it splits a bin's runs by outcome (the runs themselves
are measured, not tested: see docs/calibration.md)."""

from __future__ import annotations

import doctest
from collections.abc import Callable
from types import ModuleType

import pytest


@pytest.fixture
def gap(bench_script: Callable[[str], ModuleType]) -> ModuleType:
    return bench_script("calibration_gap")


def _run(ok: int, end: str, distance: float, false: int = 0, pushes: list[float] | None = None,
         episodes: list[list[object]] | None = None) -> dict[str, object]:
    return {"ok": ok, "end": end, "distance": distance, "false_success": false, "pushes": pushes or [],
            "episodes": episodes or [], "estimate_error": 0.0}


def test_a_bin_counts_the_truth_the_claim_and_each_failure_apart(gap: ModuleType) -> None:
    """Success is the truth (within 0.1 m, no collision of the robot's own): a run at the
    goal that did not claim it is a success and unconfirmed; a claim 0.15 m off is a false
    success; a contact 1 s after a push is the push's."""
    runs = [_run(1, "GOAL_REACHED", 0.03), _run(1, "GOAL_UNCONFIRMED", 0.08), _run(0, "GOAL_REACHED", 0.15, false=1),
            _run(0, "GOAL_UNCONFIRMED", 0.3, pushes=[4.0]),
            _run(0, "UNREACHABLE", 0.9, pushes=[2.0], episodes=[[3.0, 3.5, 0.01, False]])]
    row = gap.outcome_row(runs, [0.9] * 5)
    assert (row["n"], row["ok"], row["reached"], row["claimed"], row["false"]) == (5, 2, 2, 2, 1)
    assert (row["unconfirmed at the goal"], row["unconfirmed off"], row["pushed"]) == (1, 1, 2)
    assert (row["false success"], row["unconfirmed, off the goal"], row["contact after a push"], row["UNREACHABLE"]) == (1, 1, 1, 0)
    assert row["inside"] is False  # 0.9 above 2/5's interval [12 %, 77 %]


@pytest.mark.parametrize(("p", "b"), [(0.0, 0), (0.19, 0), (0.2, 1), (0.79, 3), (0.8, 4), (1.0, 4)])
def test_bins_are_closed_below_and_the_top_one_holds_one(p: float, b: int, gap: ModuleType) -> None:
    assert gap.bins_of([p])[b] == [0]


def test_the_patience_variant_scales_the_whole_run_p_by_the_replans_and_stays_a_probability(gap: ModuleType) -> None:
    assert gap.patience({"whole": 0.2, "p1": 0.4, "p6": 0.8}) == pytest.approx(0.4)
    assert gap.patience({"whole": 0.9, "p1": 0.5, "p6": 1.0}) == 1.0
    assert gap.patience({"whole": 0.1, "p1": 0.0, "p6": 0.5}) == 0.1


def test_the_module_doctests_pass(gap: ModuleType) -> None:
    assert doctest.testmod(gap, optionflags=doctest.ELLIPSIS).failed == 0
