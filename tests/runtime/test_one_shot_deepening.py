"""A one-shot ``clomp plan`` deepens a spent budget as the supervisor does (issue #39): one
function, :func:`clomp.planner.deepening.plan_deepening`, for both.

On a U open towards the robot with the goal behind its floor (layout family ``u-trap``, seed 1, run 0),
the paper's budget of 50 states runs out with the plan's end inside the U: neither at the
goal nor at the frontier. ``clomp plan`` on that scan searches deeper as the runtime does.
Since the known-free rule the deeper search ends at a frontier (the goal stands in the floor's
shadow) — still inside the U on this layout: the rule marks a spot near the U's inner corner as
the edge of what the rays crossed (a doubt noted in issue #39's closing note)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from clomp.planner import Configurator
from clomp.runtime.cli import main


def _u_trap() -> tuple[np.ndarray, tuple[float, float], dict[str, Any]]:
    from clomp.runtime.experiment.layouts import make_layout

    layout = make_layout("u-trap", 1, 0)
    g = layout.scene.goal_in_robot_frame()
    return layout.scene.scan(), (float(g[0]), float(g[1])), layout.params


def _inside(end: list[float], p: dict[str, Any]) -> bool:
    return bool(p["back_x"] - p["arm"] < end[0] < p["back_x"] and abs(end[1] - p["y"]) < p["inner_width"] / 2)


def test_the_one_shot_plan_gets_out_of_the_u_as_the_runtime_does(tmp_path: Path, capsys: Any) -> None:
    scan, goal, p = _u_trap()
    first = Configurator().plan(scan, goal)  # Algorithm 1 alone: the budget is spent inside the U
    assert first.stop_reason == "budget" and _inside(first.map[first.plan.end].end.as_list(), p)
    f = tmp_path / "u.txt"
    np.savetxt(f, scan)
    # 1: the goal behind the floor stands in its shadow, so the deeper search ends at a frontier
    # (issue #39's known-free rule) instead of spending its budget; it never claims the goal
    assert main(["plan", "--scan", str(f), "--goal", f"{goal[0]!r},{goal[1]!r}", "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    assert d["states"] > 50 and d["stop_reason"] == "frontier" and not d["reached_goal"], (d["states"], d["stop_reason"])
    # the runtime's own function gives the very same plan (one place)
    from clomp.planner.deepening import plan_deepening
    from clomp.runtime.supervision import replanning
    from clomp.runtime.supervision.planwatch import plan_deepening as runtime_deepening

    assert runtime_deepening is plan_deepening and replanning.plan_deepening is plan_deepening
    same = runtime_deepening(Configurator(), np.loadtxt(f), goal)
    assert [s["state"] for s in d["plan"]] == list(same.plan.states[1:])


def test_a_search_within_its_budget_is_not_searched_again(tmp_path: Path, capsys: Any) -> None:
    assert main(["plan", "--scenario", "overtaking", "--json"]) == 1  # its goal stands in the box's shadow
    d = json.loads(capsys.readouterr().out)
    assert d["stop_reason"] == "frontier" and d["states"] <= 50
