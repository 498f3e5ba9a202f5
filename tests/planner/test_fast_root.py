"""The search whose first task reaches the goal, built without the queue
(:meth:`clomp.planner._search._Search._straight_to_goal`), against the general search: the
same maps, plans, stop reasons, guards and metadata, on generated scenes and on the shared scans."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.planner import Configurator, RobotModel, ScanWarning, _search, load_scan
from clomp.planner.configurator import PlanResult

SCANS = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scans"


def _summary(r: PlanResult) -> dict[str, Any]:
    d = r.to_dict()
    d.pop("planning_time_s")
    meta = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in r.map.metadata.items()}
    states = [(s.ident, s.task, s.d_i, s.d_n, s.start, s.end, s.distance, s.duration, s.cost, s.reached_goal, s.extra)
              for s in r.map.states()]
    return {"result": d, "states": states, "transitions": r.map.transitions(), "psi": r.psi, "meta": meta}


def _both(conf: Configurator, scan: np.ndarray, goal: tuple[float, float]) -> tuple[Any, Any, int]:
    """The plan with the fast root and without it, and how often the fast root built the map."""
    built = []
    fast = _search._Search._straight_to_goal

    def counted(self: _search._Search) -> bool:
        got = fast(self)
        built.append(got)
        return got

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ScanWarning)
            _search._Search._straight_to_goal = counted  # type: ignore[method-assign]
            a = conf.plan(scan, goal)
            _search.FAST_ROOT = False
            b = conf.plan(scan, goal)
    finally:
        _search._Search._straight_to_goal = fast  # type: ignore[method-assign]
        _search.FAST_ROOT = True
    return _summary(a), _summary(b), sum(built)


# posts and wall pieces anywhere in the disc (some in the lane, some beside it, some behind
# one another: shadows), points rounded to 1 cm as a recorded scan's
_post = st.tuples(st.floats(-1.2, 1.2), st.floats(-1.2, 1.2), st.floats(0.0, 0.3), st.floats(-3.2, 3.2), st.integers(1, 30))


def _scene(posts: list[tuple[float, float, float, float, int]]) -> np.ndarray:
    parts = [np.zeros((0, 2))]
    for x, y, length, heading, n in posts:
        t = np.linspace(0.0, length, n)
        parts.append(np.c_[x + t * np.cos(heading), y + t * np.sin(heading)])
    return np.round(np.concatenate(parts), 2)


@settings(max_examples=250, deadline=None)
@given(
    st.lists(_post, max_size=8),
    st.floats(0.1, 2.0),
    st.sampled_from([0.0, 0.02, -0.05, 0.05, 0.051, 0.3]),
    st.sampled_from([RobotModel(), RobotModel(step_length=None), RobotModel(free_turns=False), RobotModel(sensor_range=1.5)]),
    st.sampled_from([50, 2, 1]),
)
def test_the_fast_root_builds_the_general_searchs_map(posts, gx, gy, robot, budget):
    fast, general, _ = _both(Configurator(robot=robot, max_states=budget), _scene(posts), (gx, gy))
    assert fast == general


def test_the_fast_root_is_taken_on_a_free_way_and_not_past_a_post():
    # the property above means nothing if the fast root never builds a map: it does on a free
    # way to a goal dead ahead, and leaves a post in the lane to the general search
    free = np.c_[np.linspace(0.0, 1.0, 21), np.full(21, 0.4)]
    fast, general, built = _both(Configurator(), free, (1.0, 0.0))
    assert built == 1 and fast == general and len(fast["states"]) == 2
    post = np.array([[0.5, -0.01], [0.5, 0.0], [0.5, 0.01]])
    fast, general, built = _both(Configurator(), post, (1.0, 0.0))
    assert built == 0 and fast == general and len(fast["states"]) > 2


@pytest.mark.skipif(not SCANS.is_dir(), reason="the shared recorded scans are not here")
def test_the_fast_root_builds_the_general_searchs_map_on_the_shared_scans():
    conf = Configurator()
    taken = 0
    for f in sorted(SCANS.glob("*/*.dat"))[::3]:
        for goal in ((1.0, 0.0), (0.5, 0.04), (2.5, 0.0)):
            fast, general, built = _both(conf, load_scan(f), goal)
            assert fast == general, (f.name, goal)
            taken += built
    assert taken > 100
