"""Exporters: every format renders the same intermediate model, Storm accepts the PRISM
and DRN exports with the map's states and transitions, and round trips hold."""

from __future__ import annotations

import io
import shutil
import subprocess
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clomp.formal import CognitiveMap, Disturbance, Pose, State, TaskKind
from clomp.formal.export import (
    FORMATS,
    STAY,
    ExportError,
    drn_adds_holder,
    export_model,
    render_svg,
    write,
    write_dot,
    write_drn,
    write_prism,
    write_prism_explicit,
)
from clomp.planner.scenarios import builtin_scenarios

stormpy = pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")

from clomp.formal.checking import build_storm_model, load_storm_model  # noqa: E402

SCANS = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scans" / "corridor-2023-10-25"






def _idents_and_labels(sm) -> dict[int, set[str]]:
    return {sm.idents[s]: sm.labels_of(s) - {f"q{sm.idents[s]}"} for s in range(sm.n_states)}


def _assert_storm_matches(cmap: CognitiveMap, via: str) -> None:
    m = export_model(cmap, "mdp")
    sm = build_storm_model(cmap, "mdp", via)
    # every map state and transition, plus one absorbing self-loop per state without
    # successors (a DRN may add one unreachable state declaring labels no state carries)
    assert sm.reachable_size() == (len(cmap), cmap.n_transitions + len(m.self_loops))
    assert sm.n_states - len(cmap) == (1 if via == "drn" and drn_adds_holder(m) else 0)
    reach = sm.reachable()
    assert sorted(sm.idents[s] for s in reach) == [s.ident for s in cmap.states()]
    # matched by label/valuation, never by index: Storm's successors are the map's
    for s in reach:
        q = sm.idents[s]
        succ = {sm.idents[t] for t in sm.successors(s)}
        assert succ == ({x.ident for x in cmap.successors(q)} or {q})
        labels = sm.labels_of(s)
        assert ("collision" in labels) == cmap[q].interrupted
        assert ("goal" in labels) == (cmap[q].reached_goal and not cmap[q].interrupted)
        assert ("init" in labels) == (q == cmap.initial_id)
    d = build_storm_model(cmap, "dtmc", via)
    plan = cmap.metadata["plan"]
    assert sorted(d.idents[s] for s in d.reachable()) == sorted(plan)
    assert d.reachable_size()[1] == len(plan)  # plan steps + the self-loop at its end


@pytest.mark.parametrize("via", ["prism", "drn"])
@pytest.mark.parametrize("name", builtin_scenarios())
def test_storm_builds_scenario_maps_with_the_same_states_and_transitions(scenario_map, name, via):
    _assert_storm_matches(scenario_map(name), via)


@pytest.mark.parametrize("via", ["prism", "drn"])
def test_storm_builds_scan_maps_with_the_same_states_and_transitions(scan_maps, via):
    for name, cmap in scan_maps():
        try:
            _assert_storm_matches(cmap, via)
        except AssertionError as exc:
            raise AssertionError(f"{name}: {exc}") from exc


def test_drn_round_trip_state_labels_match_by_label(scenario_map, tmp_path):
    cmap = scenario_map("overtaking@0.8,-0.3")  # a map with a goal state (no label-holder state)
    path = tmp_path / "ov.drn"
    write_drn(cmap, path)
    sm = load_storm_model(path)
    m = export_model(cmap)
    expected = {s.ident: set(m.state_labels(k)) for k, s in enumerate(m.states)}
    assert _idents_and_labels(sm) == expected


def test_json_round_trip(scenario_map, tmp_path):
    cmap = scenario_map("overtaking")
    buf = io.StringIO()
    write(cmap, buf, "json")
    buf.seek(0)
    assert CognitiveMap.read_json(buf) == cmap
    write(cmap, tmp_path / "m.json", "json")
    back = CognitiveMap.read_json(tmp_path / "m.json")
    assert back == cmap and back.metadata["plan"] == cmap.metadata["plan"]


def test_writers_take_a_path_or_a_file_object(scenario_map, tmp_path):
    cmap = scenario_map("open")
    for writer in (write_prism, write_drn, write_dot):
        buf = io.StringIO()
        writer(cmap, buf)
        path = tmp_path / f"out.{writer.__name__}"
        writer(cmap, path)
        assert path.read_text(encoding="utf-8") == buf.getvalue()


def test_prism_explicit_files_describe_the_map(scenario_map, tmp_path):
    cmap = scenario_map("overtaking")
    m = export_model(cmap)
    written = write_prism_explicit(cmap, tmp_path / "ov.tra")
    assert sorted(Path(p).name for p in written) == sorted(
        ["ov.tra", "ov.sta", "ov.lab", "ov.srew", "ov.trew", "ov.time.srew", "ov.time.trew"]
    )
    tra = (tmp_path / "ov.tra").read_text().splitlines()
    n, choices, entries = map(int, tra[0].split())
    assert (n, choices, entries) == (len(cmap), m.n_choices, cmap.n_transitions + len(m.self_loops))
    rows: dict[tuple[int, int], Fraction] = {}
    sta = dict(line.split(":") for line in (tmp_path / "ov.sta").read_text().splitlines()[1:])
    edges = set()
    for line in tra[1:]:
        src, ch, dst, p, action = line.split()
        rows[(int(src), int(ch))] = rows.get((int(src), int(ch)), Fraction(0)) + Fraction(p)
        if action != STAY:
            edges.add((int(sta[src].strip("()")), int(sta[dst].strip("()")), action))
    assert all(total == 1 for total in rows.values())
    assert edges == {(t.source, t.target, t.label.value) for t in cmap.transitions()}
    lab = (tmp_path / "ov.lab").read_text().splitlines()
    assert '1="goal"' in lab[0] and '2="collision"' in lab[0]
    trew = (tmp_path / "ov.trew").read_text().splitlines()
    assert trew[:2] == ['# Reward structure "distance"', "# Transition rewards"]
    assert sum(float(x.split()[3]) for x in trew[3:]) == pytest.approx(sum(s.distance for s in cmap.states()))


def _probabilistic_map(weights: list[int]) -> CognitiveMap:
    g = Disturbance.goal(1.0, 0.0)
    states = [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5)]
    for k, _ in enumerate(weights, 1):
        states.append(State(k, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.1 * k, 0), distance=0.1 * k, cost=0.4))
    total = sum(weights)
    m = CognitiveMap.from_parts(states, [], goal=g)
    for k, w in enumerate(weights, 1):
        m.add_transition(0, k, TaskKind.STRAIGHT, Fraction(w, total))
    return m


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(weights=st.lists(st.integers(1, 9), min_size=1, max_size=6))
def test_probabilities_are_printed_exactly_and_sum_to_one(weights, tmp_path_factory):
    cmap = _probabilistic_map(weights)
    tmp = tmp_path_factory.mktemp("p")
    write_prism_explicit(cmap, tmp / "m")
    rows: dict[tuple[str, str], Fraction] = {}
    for line in (tmp / "m.tra").read_text().splitlines()[1:]:
        src, ch, _, p, _ = line.split()
        rows[(src, ch)] = rows.get((src, ch), Fraction(0)) + Fraction(p)
    assert set(rows.values()) == {Fraction(1)}
    sm = build_storm_model(cmap, "mdp", "drn")
    init = int(sm.model.initial_states[0])
    got = {sm.idents[t.column]: Fraction(t.value).limit_denominator(1000) for a in sm.model.states[init].actions for t in a.transitions}
    assert got == {k: Fraction(w, sum(weights)) for k, w in enumerate(weights, 1)}


def test_exporter_refuses_probabilities_that_do_not_sum_to_one():
    cmap = _probabilistic_map([1, 1])
    cmap.add_state(State(3, TaskKind.STRAIGHT, cmap.goal, None, Pose(0, 0), Pose(0, 0)))
    cmap.add_transition(0, 3, TaskKind.STRAIGHT, Fraction(1, 3))
    for fmt in ("prism", "drn", "prism-explicit"):
        with pytest.raises(ExportError, match="sum to 4/3"):
            write(cmap, io.StringIO() if fmt != "prism-explicit" else {"tra": io.StringIO()}, fmt)


@pytest.mark.parametrize("bad", ["empty", "no-initial"])
def test_exporter_refuses_maps_without_an_initial_state(scenario_map, bad):
    cmap = CognitiveMap(goal=Disturbance.goal(1, 0))
    if bad == "no-initial":
        cmap = CognitiveMap.from_dict({**scenario_map("open").to_dict(), "initial": None})
    for fmt in ("prism", "drn", "dot"):
        with pytest.raises(ExportError):
            write(cmap, io.StringIO(), fmt)
    with pytest.raises(ExportError, match="unknown format"):
        write(scenario_map("open"), io.StringIO(), "graphml")


def test_every_format_renders_the_same_fixture(scenario_map, tmp_path):
    cmap = scenario_map("overtaking")
    for fmt in FORMATS:
        if fmt == "svg" and shutil.which("dot") is None:
            continue
        dest = tmp_path / f"ov.{fmt}"
        write(cmap, dest, fmt)
        if fmt != "prism-explicit":
            assert dest.stat().st_size > 0, fmt


def test_dot_marks_plan_collisions_and_initial_state(scenario_map):
    cmap = scenario_map("overtaking")
    buf = io.StringIO()
    write_dot(cmap, buf)
    text = buf.getvalue()
    plan = cmap.metadata["plan"]
    bold = [line for line in text.splitlines() if "style=bold" in line]
    assert len(bold) == len(plan) - 1
    n_hits = sum(s.interrupted for s in cmap.states())
    assert text.count("shape=octagon") == n_hits > 0
    assert text.count("peripheries=2") == 1
    assert ":" not in "".join(line.split("[")[0] for line in text.splitlines() if "->" in line)


@pytest.mark.skipif(shutil.which("nop") is None, reason="Graphviz is not installed (apt-get install graphviz)")
@pytest.mark.parametrize("name", builtin_scenarios())
def test_dot_parses_with_graphviz(scenario_map, name, tmp_path):
    path = tmp_path / "m.dot"
    write_dot(scenario_map(name), path)
    done = subprocess.run(["nop", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz is not installed (apt-get install graphviz)")
def test_overtaking_map_renders_to_svg(scenario_map, tmp_path):
    cmap = scenario_map("overtaking")
    engine = render_svg(cmap, tmp_path / "ov.svg")
    svg = (tmp_path / "ov.svg").read_text()
    last = cmap.states()[-1]
    assert engine == "dot" and "<svg" in svg and f"q{last.ident} {last.task.value}" in svg


def test_printed_probabilities_are_checked_after_printing():
    """A branch too small to survive printing is refused, not written as probability 0."""
    from fractions import Fraction

    from clomp.formal.export import ExportError, _printed

    tiny = Fraction(1, 3 * 10**40)  # not a finite decimal: printed to a fixed number of places
    assert _printed([Fraction(1, 3), Fraction(2, 3)], exact_rationals=True) == ["1/3", "2/3"]
    printed = _printed([Fraction(1, 3), Fraction(1, 3), Fraction(1, 3)], exact_rationals=False)
    assert sum(Fraction(t) for t in printed) == 1
    with pytest.raises(ExportError, match="do not sum to 1"):
        _printed([1 - tiny, tiny], exact_rationals=False)
