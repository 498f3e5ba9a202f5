"""A stop modelled as the supervisor's retry (clomp.formal.retry): the exported model with the
retry is read alike by PRISM and Storm, and retrying never lowers the value of a safe
arrival (it raises it where stops are false alarms)."""

from __future__ import annotations

from fractions import Fraction

import pytest

from clomp.formal import CognitiveMap, Disturbance, DisturbanceKind, Pose, State, TaskKind
from clomp.formal.export_model import ExportError, export_model
from clomp.formal.retry import RETRY, STOP_LABEL, map_stops, retry_model
from clomp.formal.supervisory import Plan

G = Disturbance.goal(1.0, 0.0)
BOX = Disturbance(DisturbanceKind.OBSTACLE, 0.5, 0.0)


def _coin_map() -> CognitiveMap:
    """q0's STRAIGHT reaches the goal (q1) or is stopped (q2), each 1/2."""
    m = CognitiveMap(goal=G)
    m.add_state(State(0, TaskKind.STRAIGHT, G, None, Pose(0, 0), Pose(0, 0)))
    m.add_state(State(1, TaskKind.STRAIGHT, G, None, Pose(0, 0), Pose(1, 0), distance=1.0, reached_goal=True))
    m.add_state(State(2, TaskKind.STRAIGHT, G, BOX, Pose(0, 0), Pose(0.3, 0), distance=0.3))
    m.add_transition(0, 1, TaskKind.STRAIGHT, Fraction(1, 2))
    m.add_transition(0, 2, TaskKind.STRAIGHT, Fraction(1, 2))
    m.metadata["plan"] = [0, 1]
    m.metadata["stops"] = {"2": 0}
    return m


def test_retry_product_has_the_layers_and_labels_it_names():
    m = export_model(_coin_map(), "mdp")
    r = retry_model(m, map_stops(_coin_map().metadata), retries=2)
    # layer 0 keeps the model's indices and idents; a copy in layer k is ident + 3k
    assert [s.ident for s in r.states[:3]] == [0, 1, 2]
    assert sorted(s.ident for s in r.states) == list(range(9))
    assert [c.action for c in r.choices[2]] == [RETRY]
    assert r.states[r.choices[2][0].branches[0][0]].ident == 3  # back to q0, one retry used
    assert sorted(r.states[k].ident for k in r.labels["collision"]) == [8]  # only the last stop is final
    assert sorted(r.states[k].ident for k in r.labels[STOP_LABEL]) == [2, 5, 8]
    assert sorted(r.states[k].ident for k in r.labels["goal"]) == [1, 4, 7]
    assert r.labels["init"] == frozenset({0})
    assert retry_model(m, {2: 0}, retries=0).choices == m.choices


def test_retry_refuses_bad_input():
    m = export_model(_coin_map(), "mdp")
    with pytest.raises(ExportError, match="retries"):
        retry_model(m, {2: 0}, retries=-1)
    with pytest.raises(ExportError, match="re-enters q9"):
        retry_model(m, {2: 9}, retries=1)
    with pytest.raises(ExportError, match="not interrupted"):
        retry_model(m, {1: 0}, retries=1)


stormpy = pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")


@pytest.mark.parametrize("retries", [0, 1, 3])
def test_storm_values_a_retried_coin_as_a_geometric_series(retries):
    from clomp.formal.scheduler import plan_probability, robust_plan

    m = _coin_map()
    want = 1 - 0.5 ** (retries + 1)  # the goal on the first try or one of the retries
    assert robust_plan(m, retries=retries).probability == pytest.approx(want, abs=1e-12)
    assert plan_probability(m, Plan((0, 1)), retries=retries) == pytest.approx(want, abs=1e-12)


def test_a_policys_value_counts_its_retries_whatever_plan_the_map_records():
    """policy_probability keeps the map's stops, not its recorded plan: a policy that
    starts nothing has value 0 (the plan q0 -> q1 it does not take is no error)."""
    from clomp.formal.scheduler import policy_probability

    m = _coin_map()
    assert policy_probability(m, {}, retries=1) == 0
    assert policy_probability(m, {0: TaskKind.STRAIGHT}, retries=1) == pytest.approx(0.75, abs=1e-12)
    assert policy_probability(m, {0: TaskKind.STRAIGHT}) == pytest.approx(0.5, abs=1e-12)


def _sampled_corridor():
    from clomp.planner import load_scenario
    from clomp.planner.probabilistic import SUPERVISOR_TOLERANCE, sample_map
    from clomp.planner.robust import SUPERVISOR_HAZARD

    scene = load_scenario("corridor")
    pm = sample_map(scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame()), samples=10, noise="harsh", seed=0,
                    tolerance=SUPERVISOR_TOLERANCE, hazard=SUPERVISOR_HAZARD)
    return pm.map


def test_sampled_stops_are_hazard_stops_that_reenter_their_task_start():
    cmap = _sampled_corridor()
    stops = map_stops(cmap.metadata)
    assert stops, "harsh range noise at 10 samples stops the corridor's straight in some rollouts"
    for stop, source in stops.items():
        assert cmap[stop].interrupted
        assert any(t.target == stop and t.label is cmap[stop].task for t in cmap.out_transitions(source))
    from clomp.planner import load_scenario
    from clomp.planner.probabilistic import sample_map

    scene = load_scenario("corridor")
    plain = sample_map(scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame()), samples=10, noise="harsh", seed=0)
    assert map_stops(plain.map.metadata) == {}  # without the hazard rule there are only contacts


def test_a_retried_stop_raises_the_value_of_the_sampled_map():
    from clomp.formal.scheduler import plan_probability, robust_plan

    cmap = _sampled_corridor()
    values = [robust_plan(cmap, retries=k).probability for k in (0, 1, 2)]
    planned = [plan_probability(cmap, retries=k) for k in (0, 1, 2)]
    assert values[0] < values[1] <= values[2] + 1e-12
    assert planned[0] < planned[1] <= planned[2] + 1e-12
    assert all(p <= v + 1e-12 for p, v in zip(planned, values))


_SAFE = {"mdp": 'Pmax=? [!"collision" U "goal"]', "dtmc": 'P=? [!"collision" U "goal"]'}


@pytest.mark.skipif(__import__("clomp.formal.prism", fromlist=["find_prism"]).find_prism() is None,
                    reason="PRISM not found: set CLOMP_PRISM or keep shared/tools/prism-*/ beside the repo")
@pytest.mark.parametrize("kind", ["mdp", "dtmc"])
def test_four_loads_agree_on_the_model_with_the_retry(kind, tmp_path):
    from clomp.formal.checking import default_property_files, read_properties
    from clomp.formal.crosscheck import cross_check

    extra = tmp_path / f"safe_{kind}.pctl"
    extra.write_text(f'// @model {kind}\n"safe_goal": {_SAFE[kind]}\n', encoding="utf-8")
    files = [read_properties(p) for p in default_property_files()] + [read_properties(extra)]
    cmap = _sampled_corridor()
    base = export_model(cmap, kind)
    with_retry = retry_model(base, map_stops(cmap.metadata), retries=1)
    assert with_retry.n_states > base.n_states and any(c.action == RETRY for row in with_retry.choices for c in row)
    before = cross_check(base, kind, files, title="corridor")
    after = cross_check(with_retry, kind, files, title="corridor with a retry")
    for cc in (before, after):
        assert cc.sizes_agree, {k: v[:2] for k, v in cc.loads.items()}
        assert not cc.disagreements(), cc.disagreements()
        assert len(cc.loads) == 4 and all(len(v[2]) == len(cc.names) > 1 for v in cc.loads.values())
    k = after.names.index("safe_goal")
    for load, (_, _, vals) in after.loads.items():
        assert vals[k] > before.loads[load][2][k] + 1e-6, (load, before.loads[load][2][k], vals[k])
