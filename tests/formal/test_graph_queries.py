"""The graph questions of the formal layer — reachable, co-reachable
(non-blocking), shortest path — against tiny references computed here by fixpoint, on
hand-made maps, on generated maps with extra transitions (cycles, shared successors), and
on the supervisor's closed loop with mutated transitions."""

from __future__ import annotations

import networkx as nx
import pytest
from hypothesis import given
from hypothesis import strategies as st

from clomp.formal import CognitiveMap, MapError, Pose, State, TaskKind
from clomp.formal.control import PLANT, SUPERVISOR, Machine, closed_loop, closed_loop_graph, nonblocking
from clomp.formal.strategies import GOAL, cognitive_maps


def _map(n: int, edges: list[tuple[int, int]]) -> CognitiveMap:
    m = CognitiveMap(goal=GOAL)
    for i in range(n):
        m.add_state(State(i, TaskKind.STRAIGHT, GOAL, None, Pose(0, 0), Pose(0.1 * i, 0)))
    for s, t in edges:
        m.add_transition(s, t)
    return m


# -- tiny references: fixpoints over the transitions, no search ------------------------------
def _forward(m: CognitiveMap, start: int) -> set[int]:
    reach = {start}
    while True:
        more = reach | {t.target for t in m.transitions() if t.source in reach}
        if more == reach:
            return reach
        reach = more


def _backward(m: CognitiveMap, targets: set[int]) -> set[int]:
    good = set(targets)
    while True:
        more = good | {t.source for t in m.transitions() if t.target in good}
        if more == good:
            return good
        good = more


def _distances_to(m: CognitiveMap, target: int) -> dict[int, int]:
    """Fewest transitions from each state to ``target`` (Bellman-Ford on unit weights)."""
    dist = {target: 0}
    for _ in range(len(m)):
        for t in m.transitions():
            if t.target in dist and dist[t.target] + 1 < dist.get(t.source, len(m) + 1):
                dist[t.source] = dist[t.target] + 1
    return dist


def _lexmin_shortest_path(m: CognitiveMap, source: int, target: int) -> list[int] | None:
    """The shortest path that is least in lexicographic order (greedy: the lowest
    successor that is one step closer), which the documented tie-break picks."""
    dist = _distances_to(m, target)
    if source not in dist:
        return None
    path = [source]
    while path[-1] != target:
        path.append(min(t.target for t in m.out_transitions(path[-1]) if dist.get(t.target) == dist[path[-1]] - 1))
    return path


# -- hand-made maps ----------------------------------------------------------------------------
def test_reachable_coreachable_and_path_on_a_small_map():
    #   0 → 1 → 3 → 4      2 → 3 (2 unreachable), 5 isolated, 4 → 1 a cycle
    m = _map(6, [(0, 1), (1, 3), (3, 4), (2, 3), (4, 1)])
    assert m.reachable() == {0, 1, 3, 4}
    assert m.reachable(2) == {1, 2, 3, 4}
    assert m.coreachable([4]) == {0, 1, 2, 3, 4}
    assert m.coreachable([0]) == {0}
    assert m.coreachable([]) == set()
    assert m.path(4) == [0, 1, 3, 4]
    assert m.path(1, source=4) == [4, 1]
    assert m.path(0) == [0]
    with pytest.raises(MapError, match="q2 is not reachable from q0"):
        m.path(2)
    with pytest.raises(MapError):
        m.coreachable([99])


def test_path_breaks_ties_towards_lower_idents():
    # two shortest paths 0 → 3 → 4 and 0 → 1 → 4 (1 added last): the lower ident wins
    m = _map(5, [(0, 3), (3, 4), (0, 2), (0, 1), (1, 4)])
    assert m.path(4) == [0, 1, 4]


def test_the_graph_view_is_kept_until_the_map_changes():
    m = _map(3, [(0, 1)])
    g = m.to_networkx()
    assert g is m.to_networkx() and nx.is_frozen(g)
    with pytest.raises(nx.NetworkXError):
        g.add_edge(0, 2)
    assert m.reachable() == {0, 1}
    m.add_transition(1, 2)  # a change drops the view: the next question sees the new transition
    assert m.to_networkx() is not g
    assert m.reachable() == {0, 1, 2} and m.path(2) == [0, 1, 2]
    assert list(m.to_networkx().edges(keys=True)) == [(0, 1, "STRAIGHT"), (1, 2, "STRAIGHT")]


# -- generated maps -----------------------------------------------------------------------------
@st.composite
def _maps_with_extra_transitions(draw: st.DrawFn) -> CognitiveMap:
    """A generated map with extra transitions between any two states (cycles, shared
    successors, unreachable parts): graph questions need no valid map."""
    m = draw(cognitive_maps(probabilistic=draw(st.booleans())))
    idents = st.integers(0, len(m) - 1)
    for s, t in draw(st.lists(st.tuples(idents, idents), max_size=6)):
        m.add_transition(s, t, TaskKind.RIGHT)
    m.set_initial(draw(idents))
    return m


@given(_maps_with_extra_transitions())
def test_networkx_answers_equal_the_fixpoint_references(m: CognitiveMap):
    q0 = m.initial.ident
    for s in m.states():
        assert m.reachable(s.ident) == _forward(m, s.ident)
        assert m.coreachable([s.ident]) == _backward(m, {s.ident})
        expected = _lexmin_shortest_path(m, q0, s.ident)
        if expected is None:
            with pytest.raises(MapError):
                m.path(s.ident)
        else:
            assert m.path(s.ident) == expected
    ends = {s.ident for s in m.states() if not m.out_transitions(s.ident)}
    assert m.coreachable(ends) == _backward(m, ends)
    assert m.reachable() == _forward(m, q0)


# -- the supervisor's closed loop ---------------------------------------------------------------
def _product_reference(sup: Machine, plant: Machine) -> tuple[set[tuple[str, str]], set[tuple[str, str]]]:
    """(reachable, blocking) states of sup × plant by fixpoint."""
    ts, tp = sup.table(), plant.table()
    steps = {((s, p), (ts[(s, e)], tp[(p, e)])) for s in sup.states for p in plant.states for e in (x.name for x in sup.events)
             if (s, e) in ts and (p, e) in tp}
    reach = {(sup.initial, plant.initial)}
    while (more := reach | {b for a, b in steps if a in reach}) != reach:
        reach = more
    good = {(s, p) for s in sup.terminal for p in plant.terminal}
    while (more := good | {a for a, b in steps if b in good}) != good:
        good = more
    return reach, reach - good


_EVENTS = [e.name for e in SUPERVISOR.events]


@given(st.lists(st.tuples(st.sampled_from(SUPERVISOR.states), st.sampled_from(_EVENTS),
                          st.none() | st.sampled_from(SUPERVISOR.states)), max_size=4))
def test_closed_loop_and_nonblocking_equal_the_fixpoint_references(changes):
    sup = SUPERVISOR
    for source, event, target in changes:
        sup = sup.with_transition(source, event, target)
    reach, blocking = _product_reference(sup, PLANT)
    paths = closed_loop(sup, PLANT)
    assert set(paths) == reach
    ts, tp = sup.table(), PLANT.table()
    for (s, p), path in paths.items():  # each path leads there, and is a shortest one
        x, y = sup.initial, PLANT.initial
        for e in path:
            x, y = ts[(x, e)], tp[(y, e)]
        assert (x, y) == (s, p)
    lengths = {len(path) for path in paths.values()}
    assert lengths == set(range(len(lengths)))  # breadth-first: no level missing
    result = nonblocking(sup, PLANT)
    assert {paths[x] for x in blocking} == {path for path, _ in result.counterexamples}
    assert result.ok == (not blocking)


def test_the_closed_loop_graph_keys_edges_by_event_in_the_machines_order():
    g = closed_loop_graph(SUPERVISOR, PLANT)
    out = list(g.out_edges(("EXECUTING", "DRIVING", None), keys=True))
    assert [e for _, _, e in out] == sorted((e for _, _, e in out), key=_EVENTS.index)
    assert g.graph["start"] == ("IDLE", "OFF", None)
