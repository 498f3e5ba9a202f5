"""PRISM and Storm side by side: the PRISM-language file in PRISM and in Storm, the
explicit files in PRISM and the DRN in plain Storm give the same model (reachable states
and transitions) and the same value (≤ 1e-9) for every property of specs/properties/.

The default run covers a one-state model, a probabilistic map and two scenarios (PRISM
costs about a second per load on a loaded machine); ``-m slow`` covers every scenario
and ten recorded scans."""

from __future__ import annotations

import pytest

from clomp.formal.crosscheck import cross_check
from clomp.formal.prism import find_prism
from clomp.planner.scenarios import builtin_scenarios

pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")
pytestmark = pytest.mark.skipif(
    find_prism() is None, reason="PRISM not found: set CLOMP_PRISM or keep shared/tools/prism-*/ beside the repo"
)


def _assert_agree(cmap, title):
    for kind in ("mdp", "dtmc"):
        cc = cross_check(cmap, kind, title=title)
        assert cc.sizes_agree, (title, kind, {k: v[:2] for k, v in cc.loads.items()})
        assert not cc.disagreements(), cc.disagreements()
        assert len(cc.loads) == 4 and all(len(v[2]) == len(cc.names) > 0 for v in cc.loads.values())


@pytest.mark.parametrize("which", ["one-state", "probabilistic"])
def test_four_loads_agree_on_hand_built_models(which, one_state_map, branching_map):
    _assert_agree(one_state_map if which == "one-state" else branching_map, which)


@pytest.mark.parametrize("name", ["overtaking", "blocked"])
def test_four_loads_agree_on_scenarios(scenario_map, name):
    _assert_agree(scenario_map(name), name)


@pytest.mark.slow
@pytest.mark.parametrize("name", builtin_scenarios())
def test_four_loads_agree_on_every_scenario(scenario_map, name):
    _assert_agree(scenario_map(name), name)


@pytest.mark.slow
def test_four_loads_agree_on_ten_recorded_scans(scan_maps):
    maps = scan_maps()[:10]
    assert len(maps) == 10
    for name, cmap in maps:
        _assert_agree(cmap, name)


def test_four_loads_agree_on_a_sampled_probabilistic_map():
    from clomp.planner import load_scenario
    from clomp.planner.probabilistic import sample_map

    scene = load_scenario("doorway")
    pm = sample_map(scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame()), samples=30, seed=0)
    assert any(0 < t.probability < 1 for t in pm.map.transitions())
    _assert_agree(pm.map, "doorway --samples 30")


@pytest.mark.slow
def test_four_loads_agree_on_a_map_learned_from_recorded_scans(scans_dir):
    from clomp.planner.probabilistic import learn_from_scans

    learned = learn_from_scans(sorted(scans_dir.glob("*.dat"))[:10], (1.0, 0.0))
    assert any(0 < t.probability < 1 for t in learned.transitions())
    _assert_agree(learned, "learned from 10 scans")
