"""The closed loop's model (``clomp.formal.retry.loop_model``, ``clomp export --closed-loop``):
an interruption is replanned from, not a collision; PRISM and Storm read it alike and
check the shipped ``specs/properties/closed_loop/`` files on it."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from clomp.formal import CognitiveMap, Disturbance, DisturbanceKind, Pose, State, TaskKind
from clomp.formal.checking import read_properties, shipped_property_files
from clomp.formal.export import export_model
from clomp.formal.prism import find_prism, run_prism
from clomp.formal.retry import GAVE_UP, INTERRUPTED, OFF_LABEL, RETRY, loop_model, map_offs, map_stops

stormpy = pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")
needs_prism = pytest.mark.skipif(find_prism() is None, reason="PRISM not found: set CLOMP_PRISM or keep shared/tools/prism-*/ beside the repo")


def _loop_files() -> dict[str, object]:
    files = [read_properties(p) for p in shipped_property_files() if p.parent.name == "closed_loop"]
    return {pf.model: pf for pf in files}


def _quarters() -> CognitiveMap:
    """q0's STRAIGHT: 1/4 each the nominal q1 (then the goal surely), a stop q2, a
    contact q3 and q4, an outcome off the map's prediction aimed at q1."""
    g = Disturbance.goal(1.0, 0.0)
    box = Disturbance(DisturbanceKind.OBSTACLE, 0.5, 0.0)
    o = Pose(0, 0)
    m = CognitiveMap.from_parts([
        State(0, TaskKind.STRAIGHT, g, None, o, o),
        State(1, TaskKind.STRAIGHT, g, None, o, Pose(0.5, 0)),
        State(2, TaskKind.STRAIGHT, g, box, o, Pose(0.1, 0)),
        State(3, TaskKind.STRAIGHT, g, box, o, Pose(0.4, 0)),
        State(4, TaskKind.STRAIGHT, g, None, o, Pose(0.5, 0.2)),
        State(5, TaskKind.STRAIGHT, g, None, Pose(0.5, 0), Pose(1, 0), reached_goal=True),
    ], [], goal=g)
    for k in (1, 2, 3, 4):
        m.add_transition(0, k, TaskKind.STRAIGHT, Fraction(1, 4))
    m.add_transition(1, 5, TaskKind.STRAIGHT)
    m.metadata.update({"plan": [0, 1, 5], "stops": {"2": 0}, "offs": {"4": 1}})
    return m


def test_loop_model_labels_the_lost_states_in_every_layer_and_they_are_dead_ends(tmp_path):
    """The whole run's term: a push that left the estimate lost (``metadata["lost"]``,
    clomp.planner.pushes) is labelled ``estimate_lost`` in each replan layer, never
    retried nor a goal; Storm gives the shipped closed-loop properties on it (the goal's
    chance halved: q1's STRAIGHT ends lost half the time); without lost states the
    label is there, empty."""
    from clomp.formal.checking import check_properties, load_storm_model
    from clomp.formal.export import write_prism
    from clomp.formal.retry import LOST_LABEL, map_lost

    q = _quarters()
    m = CognitiveMap.from_parts([*q.states(), State(6, TaskKind.STRAIGHT, q.goal, None, Pose(0.5, 0), Pose(0.5, 0))], [], goal=q.goal)
    for k in (1, 2, 3, 4):
        m.add_transition(0, k, TaskKind.STRAIGHT, Fraction(1, 4))
    m.add_transition(1, 5, TaskKind.STRAIGHT, Fraction(1, 2))
    m.add_transition(1, 6, TaskKind.STRAIGHT, Fraction(1, 2))
    m.metadata.update({**q.metadata, "lost": {"6": 1}})
    r = loop_model(export_model(m, "dtmc"), map_stops(m.metadata), 1, map_offs(m.metadata), map_lost(m.metadata))
    assert sorted(r.states[k].ident for k in r.labels[LOST_LABEL]) == [6, 6 + 7]
    assert not r.labels[LOST_LABEL] & (r.labels[INTERRUPTED] | r.labels["goal"])
    assert loop_model(export_model(q, "dtmc"), map_stops(q.metadata), 1, map_offs(q.metadata)).labels[LOST_LABEL] == frozenset()
    write_prism(r, tmp_path / "lost.prism", "dtmc")
    specs = {s.name: s for s in _loop_files()["dtmc"].properties}  # type: ignore[attr-defined]
    names = ["lost_is_not_goal", "lost_is_not_interrupted", "p_goal_with_replans", "p_estimate_lost"]
    got = {c.spec.name: c for c in check_properties(load_storm_model(tmp_path / "lost.prism"), [specs[n] for n in names])}
    assert got["lost_is_not_goal"].passed and got["lost_is_not_interrupted"].passed
    # q1 is reached 1/4 directly, 1/4 by the off's replan, 1/16 by the stop's (q0 again, then q1): 9/16, then half each way
    assert got["p_estimate_lost"].value == pytest.approx(9 / 32, abs=1e-9)
    assert got["p_goal_with_replans"].value == pytest.approx(9 / 32, abs=1e-9)


def test_loop_model_labels_what_happened_not_the_maps_interrupted_flag():
    m = _quarters()
    r = loop_model(export_model(m, "dtmc"), map_stops(m.metadata), 1, map_offs(m.metadata))
    name = {k: s.ident for k, s in enumerate(r.states)}
    span = 6
    assert sorted(name[k] for k in r.labels["collision"]) == [3, 3 + span]  # contacts only, in both layers
    assert sorted(name[k] for k in r.labels[INTERRUPTED]) == [2, 4, 2 + span, 4 + span]
    assert sorted(name[k] for k in r.labels[GAVE_UP]) == [2 + span, 4 + span]  # no replan left
    assert sorted(name[k] for k in r.labels[OFF_LABEL]) == [4, 4 + span]
    by_ident = {s.ident: k for k, s in enumerate(r.states)}
    retry = {name[k]: [name[j] for j, _ in r.choices[k][0].branches] for k in by_ident.values() if r.choices[k][0].action == RETRY}
    assert retry == {2: [0 + span], 4: [1 + span]}  # a stop re-enters its task's start, an off the state aimed at


@pytest.mark.parametrize("replans", [0, 1, 2])
def test_storm_and_prism_value_the_replans_alike(replans):
    """Four loads (PRISM language and explicit files in PRISM, the PRISM language and the
    DRN in Storm) give the shipped closed-loop properties the values worked out by hand:
    with r replans, V_r = 1/4 (q1) + 1/4 V_(r-1) (stop) + 1/4 (off, then q1) and V with
    none left 1/4; contacts 1/4 per try."""
    from clomp.formal.crosscheck import LOADS, cross_check

    m = _quarters()
    model = loop_model(export_model(m, "dtmc"), map_stops(m.metadata), replans, map_offs(m.metadata))
    loads = LOADS if find_prism() is not None else tuple(x for x in LOADS if not x.endswith("in PRISM"))
    cc = cross_check(model, "dtmc", [_loop_files()["dtmc"]], title="quarters", loads=loads)  # type: ignore[list-item]
    assert cc.sizes_agree and not cc.disagreements(), cc.disagreements()
    v, c, gave = 0.25, 0.25, 0.5  # no replan: q1 then the goal; the contact; a stop or an off ends the run
    for _ in range(replans):
        v, c, gave = 0.25 + 0.25 * v + 0.25, 0.25 + 0.25 * c, 0.25 * gave
    want = {"interrupted_is_not_collision": True, "p_goal_with_replans": v, "p_collision": c, "p_interrupted": 0.5,
            "p_gave_up": gave}
    for load, (_, _, values) in cc.loads.items():
        got = dict(zip(cc.names, values))
        for key, value in want.items():
            assert got[key] == pytest.approx(value, abs=1e-9), (load, key, got[key], value)


def _cli(*argv: str) -> int:
    import clomp.runtime.cli as cli

    return cli.main(list(argv))


@pytest.mark.parametrize("kind", ["mdp", "dtmc"])
def test_the_closed_loop_export_passes_its_property_file_in_both_tools(kind, tmp_path, capsys):
    """``clomp export --samples 10 --noise harsh --closed-loop`` on the overtaking scenario,
    in the PRISM language, the DRN and PRISM's explicit files: the shipped closed-loop file
    of its kind gives the same values in every load and its requirement holds; the
    collision (an unforeseen contact) is no likelier than the open-loop export's."""
    from clomp.formal.checking import check_properties, load_storm_model
    from clomp.formal.export import prism_import_args
    from clomp.formal.prism import run_prism

    pf = _loop_files()[kind]
    specs = list(pf.properties)  # type: ignore[attr-defined]
    base = ["--scenario", "overtaking", "--samples", "10", "--noise", "harsh", "--seed", "3", "--model", kind]
    stem = tmp_path / f"loop-{kind}"
    for fmt, out in (("prism", stem.with_suffix(".prism")), ("drn", stem.with_suffix(".drn")), ("prism-explicit", stem)):
        assert _cli("export", *base, "--closed-loop", "-f", fmt, "-o", str(out)) == 0
    assert "closed loop with 1 replan" in capsys.readouterr().out
    loads = {"PRISM language in Storm": [r.value for r in check_properties(load_storm_model(stem.with_suffix(".prism")), specs)],
             "DRN in Storm": [r.value for r in check_properties(load_storm_model(stem.with_suffix(".drn")), specs)]}
    if find_prism() is not None:
        named = [f'"{p.name}": {p.formula}' for p in specs]
        loads["PRISM language in PRISM"] = run_prism([str(stem.with_suffix(".prism"))], named).values
        loads["explicit files in PRISM"] = run_prism(prism_import_args(stem, kind), named).values  # type: ignore[arg-type]
    ref = loads["DRN in Storm"]
    for load, values in loads.items():
        assert values == pytest.approx(ref, abs=1e-9), load
    got = dict(zip([p.name for p in specs], ref))
    assert got["interrupted_is_not_collision"] is True
    open_loop = tmp_path / "open.prism"
    assert _cli("export", *base, "-f", "prism", "-o", str(open_loop)) == 0
    formula = 'Pmin=? [F "collision"]' if kind == "mdp" else 'P=? [F "collision"]'
    p_open = check_properties(load_storm_model(open_loop), [type(specs[0])(formula, "c")])[0].value
    assert got["p_collision"] <= p_open + 1e-9  # type: ignore[operator]
    assert _cli("check", str(stem.with_suffix(".prism")), "--specs", pf.source,  # type: ignore[attr-defined]
                "--tool", "both" if find_prism() is not None else "storm") == 0


@pytest.mark.parametrize("argv, message", [
    (["--closed-loop"], "give --samples N"),
    (["--samples", "5", "--replans", "2"], "--replans applies to --closed-loop"),
    (["--samples", "5", "--closed-loop", "--replans", "-1"], "--replans: expected a whole number"),
    (["--samples", "5", "--closed-loop", "--model", "dtmc", "--policy", "storm"], "not supported"),
])
def test_closed_loop_options_that_do_not_apply_are_refused(argv, message, tmp_path, capsys):
    code = _cli("export", "--scenario", "overtaking", "-f", "drn", "-o", str(tmp_path / "x.drn"), *argv)
    assert code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "x.drn").exists()


def test_the_closed_loop_files_are_shipped_for_both_kinds():
    files = _loop_files()
    assert set(files) == {"mdp", "dtmc"}
    assert all(Path(pf.source).parent.name == "closed_loop" for pf in files.values())  # type: ignore[attr-defined]


def _table(out: str) -> dict[tuple[str, str], list[str]]:
    """``clomp check``'s table: (model, property) -> the values and the verdict."""
    rows = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 4 and parts[0] in ("mdp", "dtmc"):
            rows[(parts[0], parts[1])] = parts[2:]
    return rows


def test_check_closed_loop_gives_the_values_of_the_export_in_plain_storm_and_prism(tmp_path, capsys):
    """``clomp check --samples N --closed-loop --replans 2`` checks the shipped closed-loop
    files on the model ``clomp export`` writes for the same options: each value it prints
    (Storm's and, when found, PRISM's) is what plain stormpy gives on the exported DRN and
    PRISM on the exported PRISM file; every requirement passes."""
    opts = ["--scenario", "overtaking", "--goal", "0.8,-0.3", "--samples", "6", "--noise", "harsh", "--seed", "2",
            "--closed-loop", "--replans", "2"]
    both = find_prism() is not None
    assert _cli("check", *opts, "--tool", "both" if both else "storm") == 0
    out = capsys.readouterr().out
    assert "(closed loop, 2 replans)" in out and "distance:" not in out
    rows = _table(out)
    files = _loop_files()
    assert {(k, p.name) for k, pf in files.items() for p in pf.properties} == set(rows)  # type: ignore[attr-defined]
    for kind, pf in files.items():
        stem = tmp_path / f"loop-{kind}"
        for fmt in ("drn", "prism"):
            assert _cli("export", *opts, "--model", kind, "-f", fmt, "-o", str(stem.with_suffix(f".{fmt}"))) == 0
        model = stormpy.build_model_from_drn(str(stem.with_suffix(".drn")))
        named = [f'"{p.name}": {p.formula}' for p in pf.properties]  # type: ignore[attr-defined]
        prism = run_prism([str(stem.with_suffix(".prism"))], named).values if both else None
        for k, p in enumerate(pf.properties):  # type: ignore[attr-defined]
            result = stormpy.model_checking(model, stormpy.parse_properties(p.formula)[0])
            init = model.initial_states[0]
            value = result.at(init) if hasattr(result, "at") else result[init]
            printed = rows[(kind, p.name)]
            assert _same(printed[0], value), (kind, p.name, printed, value)
            if prism is not None:
                assert _same(printed[1], prism[k]), (kind, p.name, printed, prism[k])
            assert printed[-1] in ("pass", "-"), (kind, p.name, printed)


def _same(text: str, value: object) -> bool:
    if isinstance(value, bool):
        return text == str(value).lower()
    return abs(float(text) - float(value)) <= 1e-5  # type: ignore[arg-type]  # the table prints 6 significant digits


@pytest.mark.parametrize("argv, message", [
    (["--scenario", "overtaking", "--closed-loop"], "give --samples N"),
    (["--scenario", "overtaking", "--samples", "3", "--replans", "1"], "--replans applies to --closed-loop"),
    (["--scenario", "overtaking", "--samples", "3", "--closed-loop", "--replans", "21"], "from 0 to 20"),
    # --induced applies to --closed-loop (the closed loop's scheduler); its format is the suffix's
    (["--scenario", "overtaking", "--samples", "3", "--closed-loop", "--induced", "x.txt"], "give a .drn or .prism file"),
    (["MODEL", "--closed-loop"], "is a model already"),
])
def test_check_closed_loop_options_that_do_not_apply_are_refused(argv, message, tmp_path, capsys):
    model = tmp_path / "m.prism"
    model.write_text("dtmc\nmodule m q : [0..1] init 0; [] q=0 -> (q'=1); endmodule\n")
    code = _cli("check", *[str(model) if a == "MODEL" else a for a in argv])
    assert code == 2 and message in capsys.readouterr().err


def test_a_model_file_is_checked_against_the_files_meant_for_it(tmp_path, capsys):
    """``clomp check FILE`` without --specs: the closed loop's export gets the closed
    loop's files only (the map's "sure" requirements are not about it), a map's plain
    export the map's files only."""
    base = ["--scenario", "overtaking", "--goal", "0.8,-0.3", "--samples", "4", "--noise", "harsh", "--seed", "1", "-f", "prism"]
    assert _cli("export", *base, "--closed-loop", "-o", str(tmp_path / "loop.prism")) == 0
    assert _cli("export", *base, "-o", str(tmp_path / "open.prism")) == 0
    capsys.readouterr()
    _cli("check", str(tmp_path / "loop.prism"))
    loop = {name for _, name in _table(capsys.readouterr().out)}
    _cli("check", str(tmp_path / "open.prism"))
    plain = {name for _, name in _table(capsys.readouterr().out)}
    assert loop == {p.name for p in _loop_files()["mdp"].properties}  # type: ignore[attr-defined]
    assert "goal_possible" in plain and not plain & loop


def test_a_plans_stop_whose_reentry_lies_off_the_plan_ends_the_run():
    """Before: ExportError ("the retry of q2 re-enters q3, which the model does not hold"),
    and the robust planner's run HALTED on it (calibration bench, clutter 18). The plan's
    DTMC has no task at a re-entry off its plan: the stop is the run's end (gave_up, not a
    collision). The MDP holds every state: a re-entry it lacks is still an error."""
    from clomp.formal.export import ExportError

    g = Disturbance.goal(1.0, 0.0)
    box = Disturbance(DisturbanceKind.OBSTACLE, 0.5, 0.0)
    o = Pose(0, 0)
    m = CognitiveMap.from_parts([
        State(0, TaskKind.STRAIGHT, g, None, o, o),
        State(1, TaskKind.STRAIGHT, g, None, o, Pose(1, 0), reached_goal=True),
        State(2, TaskKind.STRAIGHT, g, box, o, Pose(0.2, 0)),
        State(3, TaskKind.LEFT, g, None, o, Pose(0, 0, 0.5)),
    ], [], goal=g)
    m.add_transition(0, 1, TaskKind.STRAIGHT, Fraction(1, 2))
    m.add_transition(0, 2, TaskKind.STRAIGHT, Fraction(1, 2))
    m.add_transition(0, 3, TaskKind.LEFT)
    m.metadata.update({"plan": [0, 1], "stops": {"2": 3}})
    r = loop_model(export_model(m, "dtmc"), map_stops(m.metadata), 1)
    name = {k: s.ident for k, s in enumerate(r.states)}
    assert sorted(name[k] for k in r.labels[INTERRUPTED]) == [2] == sorted(name[k] for k in r.labels[GAVE_UP])
    assert not r.labels["collision"] and all(c.action != RETRY for row in r.choices for c in row)
    with pytest.raises(ExportError, match="re-enters q9"):
        loop_model(export_model(m, "mdp"), {2: 9}, 1)
