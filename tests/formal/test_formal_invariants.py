"""The invariant checker: it passes every map the Configurator builds, and finds each
invariant broken on purpose (so every check is shown able to fail)."""

from __future__ import annotations

from fractions import Fraction

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from clomp.formal import CognitiveMap, Disturbance, Plan, Pose, State, TaskKind, Transition
from clomp.formal.invariants import Invariant, InvariantError, assert_map_valid, check_map
from clomp.formal.supervisory import Guard, Reset, ResetUndefined, extract_plan
from clomp.planner import Configurator, PlanningError
from clomp.formal.strategies import GOAL, OBSTACLE, cognitive_maps
from clomp.planner.scenarios import builtin_scenarios, load_scenario
from clomp.planner.strategies import goals, robot_models, scans

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# -- strategies: the public ones (clomp.planner.strategies, clomp.formal.strategies) ------------------
scenes = lambda: st.tuples(scans(), goals())  # noqa: E731 - a scan and a goal in range
robots = robot_models()
grown_maps = cognitive_maps


def _state(ident: int, task: TaskKind, interrupted: bool, cost: float, d_i: Disturbance | None = GOAL) -> State:
    return State(ident, task, d_i, OBSTACLE if interrupted else None, Pose(0, 0), Pose(0.1 * ident, 0), cost=cost)


def _configurator_map(name: str = "overtaking"):
    conf = Configurator()
    scene = load_scenario(name)
    return conf.plan(scene.scan(max_range=conf.robot.sensor_range), tuple(scene.goal_in_robot_frame()))


def _rebuild(m: CognitiveMap, states=None, transitions=None) -> CognitiveMap:
    out = CognitiveMap.from_parts(
        m.states() if states is None else states,
        m.transitions() if transitions is None else transitions,
        goal=m.goal,
        initial=m.initial_id,
    )
    return out


# -- every Configurator map is good -----------------------------------------------------
@pytest.mark.parametrize("name", builtin_scenarios())
def test_builtin_scenario_maps_hold_every_invariant(name):
    r = _configurator_map(name)
    assert check_map(r.map, r.plan, r.psi) == []


def test_recorded_scans_hold_every_invariant(scans_dir):
    conf = Configurator()
    files = sorted(scans_dir.glob("*.dat"))[:20]
    assert files
    for f in files:
        r = conf.plan(f, (1.0, 0.0))
        assert check_map(r.map, r.plan, r.psi) == [], f.name


@SETTINGS
@given(scenes(), robots)
def test_generated_scenes_hold_every_invariant(scene, robot):
    scan, goal = scene
    try:
        r = Configurator(robot=robot, max_states=120).plan(scan, goal)
    except PlanningError:
        assume(False)
    assert check_map(r.map, r.plan, r.psi) == []
    assert check_map(r.map) == []  # the recorded plan (metadata) is the same


@SETTINGS
@given(grown_maps(probabilistic=True))
def test_hand_grown_maps_hold_every_invariant(m):
    assert check_map(m) == []
    assert_map_valid(m)


# -- each invariant broken on purpose -------------------------------------------------
def _found(m, plan=None, psi=None) -> set[Invariant]:
    return {v.invariant for v in check_map(m, plan, psi)}


def test_invariant_1_empty_map_and_unreachable_state():
    assert _found(CognitiveMap(goal=GOAL)) == {Invariant.INITIAL}
    r = _configurator_map()
    m = r.map
    m.add_state(_state(len(m), TaskKind.STRAIGHT, False, 0.9))
    (v,) = [v for v in check_map(m) if v.invariant is Invariant.INITIAL]
    assert v.states == (len(m) - 1,)


def test_invariant_1_no_initial_state():
    m = CognitiveMap.from_dict({**_configurator_map().map.to_dict(), "initial": None})
    assert [v.invariant for v in check_map(m)] == [Invariant.INITIAL]
    with pytest.raises(InvariantError, match="no initial state"):
        assert_map_valid(m)


def test_invariant_2_transition_out_of_a_collision():
    m = _configurator_map().map
    hit = next(s for s in m.states() if s.interrupted)
    m.add_transition(hit.ident, 1)
    (v,) = [v for v in check_map(m) if v.invariant is Invariant.INTERRUPTED_ABSORBING]
    assert v.states == (hit.ident,)
    with pytest.raises(ResetUndefined):
        Reset(m)(Transition(hit.ident, 1, TaskKind.STRAIGHT))


def test_invariant_3_successor_not_contingent_on_the_goal():
    m = _configurator_map().map
    s = m[5]
    m.replace_state(State(**{**{f: getattr(s, f) for f in State.__dataclass_fields__}, "d_i": OBSTACLE}))
    (v,) = [v for v in check_map(m) if v.invariant is Invariant.RESET]
    assert v.states == (5,)


def test_invariant_4_guard_enables_a_transition_off_the_plan():
    r = _configurator_map()
    psi = dict(r.psi)
    off = next(t for t, v in psi.items() if v == 0)
    psi[off] = 1
    assert Invariant.GUARD in _found(r.map, r.plan, psi)


def test_invariant_4_plan_stops_before_argmin_phi():
    r = _configurator_map()
    short = Plan(r.plan.states[:-1])
    (v,) = [v for v in check_map(r.map, short) if v.invariant is Invariant.GUARD]
    assert v.states[0] == short.end and r.plan.end in v.states


def test_invariant_4_plan_not_a_path_of_the_map():
    r = _configurator_map()
    assert _found(r.map, Plan((0, r.plan.end))) == {Invariant.GUARD}


def test_invariant_5_turn_followed_by_a_turn():
    m = _configurator_map().map
    turn = next(s for s in m.states() if s.task.is_turn and not s.interrupted)
    extra = m.add_state(_state(len(m), TaskKind.LEFT, True, 1.5))
    m.add_transition(turn.ident, extra.ident)
    (v,) = [v for v in check_map(m) if v.invariant is Invariant.TURN_THEN_STRAIGHT]
    assert v.states == (turn.ident,)


def test_invariant_5_turn_without_a_straight():
    m = _configurator_map().map
    turn = next(s for s in m.states() if s.task.is_turn and not s.interrupted)
    broken = _rebuild(m, transitions=[t for t in m.transitions() if t.source != turn.ident])
    assert Invariant.TURN_THEN_STRAIGHT in _found(broken)


def test_invariant_6_probabilities_do_not_sum_to_one():
    m = _configurator_map().map
    t = m.transitions()[0]
    broken = _rebuild(m, transitions=[Transition(t.source, t.target, t.label, Fraction(1, 3))] + m.transitions()[1:])
    (v,) = [v for v in check_map(broken) if v.invariant is Invariant.PROBABILITY]
    assert v.states == (t.source,)


@st.composite
def broken_maps(draw):
    """A hand-grown map, the invariant to break, and the broken (map, plan, psi)."""
    m = draw(grown_maps(probabilistic=True))
    inv = draw(st.sampled_from(list(Invariant)))
    plan, psi = extract_plan(m), None
    n = len(m)
    if inv is Invariant.INITIAL:
        m.add_state(_state(n, TaskKind.STRAIGHT, False, 0.9))
    elif inv is Invariant.INTERRUPTED_ABSORBING:
        hit = m.add_state(_state(n, TaskKind.STRAIGHT, True, 1.5))
        m.add_transition(hit.ident, 0)  # a way out of a collision
    elif inv is Invariant.RESET:
        if not m.transitions():
            m.add_state(_state(n, TaskKind.STRAIGHT, False, 0.95))
            m.add_transition(0, n)
        t = draw(st.sampled_from(m.transitions()))  # in a good map every source is uninterrupted
        s = m[t.target]
        m = _rebuild(m, states=[q if q.ident != s.ident else _state(s.ident, s.task, s.interrupted, s.cost, d_i=OBSTACLE) for q in m.states()])
    elif inv is Invariant.GUARD:
        psi = Guard(m, plan).table()
        if any(v == 0 for v in psi.values()) and draw(st.booleans()):
            psi[draw(st.sampled_from(sorted(t for t, v in psi.items() if v == 0)))] = 1
        elif len(plan) > 1:
            plan = Plan(plan.states[:-1])
            psi = None
        else:
            plan = Plan((0, 0))
    elif inv is Invariant.TURN_THEN_STRAIGHT:
        m.add_state(_state(n, draw(st.sampled_from([TaskKind.LEFT, TaskKind.RIGHT])), False, 0.97))  # no straight after it
    else:
        q = m.add_state(_state(n, TaskKind.STRAIGHT, True, 1.2))
        m.add_transition(0, q.ident, TaskKind.STRAIGHT, Fraction(draw(st.integers(1, 4)), 7))
        plan = extract_plan(m)
    return inv, m, plan, psi


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(broken_maps())
def test_checker_finds_every_kind_of_breakage(case):
    inv, m, plan, psi = case
    found = check_map(m, plan, psi)
    assert inv in {v.invariant for v in found}, found
    assert all(set(v.states) <= {s.ident for s in m.states()} | set(plan.states) for v in found)


# -- guard and reset as objects ---------------------------------------------------------
def test_guard_object_matches_the_table_and_rejects_outsiders():
    r = _configurator_map()
    psi = Guard(r.map, r.plan)
    assert psi.table() == r.psi
    assert psi.table(like=r.psi) == r.psi  # reusing the keys of a table of the same map
    assert psi.codomain == {0, 1}
    assert sum(psi(t) for t in psi.domain) == len(r.plan) - 1
    for s in r.plan.states[:-1]:
        assert len(psi.enabled(s)) == 1
    from clomp.formal import MapError

    with pytest.raises(MapError):
        psi((0, 0))


def test_reset_object_domain_and_undefined_part():
    r = _configurator_map()
    R = Reset(r.map)
    assert R.codomain == {r.map.goal}
    assert R.undefined == [] and R.domain == r.map.transitions()
    assert all(R(t) == r.map.goal for t in R.domain)
    hit = next(s for s in r.map.states() if s.interrupted)
    with pytest.raises(ResetUndefined):
        R.inject(hit, r.map[1])
    fresh = State(99, TaskKind.LEFT, None, None, Pose(0, 0), Pose(0, 0))
    assert R.inject(r.map[1], fresh).d_i == r.map.goal
