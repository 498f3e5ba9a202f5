"""Each exporter finding checked by the consumer a user runs: the real PRISM, plain
``stormpy.build_model_from_drn`` + ``model_checking``, or the written text parsed back.

Every test here failed before its fix (named in the test's docstring)."""

from __future__ import annotations

import io
import re
from fractions import Fraction
from pathlib import Path

import pytest

from clomp.formal import State
from clomp.formal.checking import PropertySpec, read_properties
from clomp.formal.export import FORMATS, LABEL_HOLDER, export_model, write_drn, write_prism, write_prism_explicit
from clomp.formal.prism import PrismError, check_with_prism, find_prism

stormpy = pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")
needs_prism = pytest.mark.skipif(find_prism() is None, reason="PRISM not found: set CLOMP_PRISM or keep shared/tools/prism-*/ beside the repo")


def _plain_storm(path: Path, formula: str) -> float:
    """What a user does: build the DRN with plain stormpy and check one formula at q0."""
    model = stormpy.build_model_from_drn(str(path))
    prop = stormpy.parse_properties(formula)[0]
    result = stormpy.model_checking(model, prop)
    return float(result.at(model.initial_states[0])) if hasattr(result, "at") else float(result[model.initial_states[0]])


# -- DRN declares every label (plain Storm) --------------------------------------------------
def test_plain_storm_checks_collision_on_a_collision_free_supervised_model(scenario_map, tmp_path):
    """Before: the DRN named only carried labels; Storm refused "unknown label collision"."""
    cmap = scenario_map("overtaking@0.8,-0.3")  # a goal the scan sees (the scenario's own stands in the box's shadow)
    assert not export_model(cmap, "dtmc").labels["collision"]
    write_drn(cmap, tmp_path / "s.drn", "dtmc")
    assert _plain_storm(tmp_path / "s.drn", 'P=? [F "collision"]') == 0.0
    assert _plain_storm(tmp_path / "s.drn", 'P=? [F "goal"]') == 1.0


def test_plain_storm_checks_goal_on_a_map_that_never_reaches_it(scenario_map, tmp_path):
    """Before: "goal" and "goal_in_map" were unknown labels on a blocked map."""
    cmap = scenario_map("blocked")
    m = export_model(cmap, "mdp")
    assert not m.labels["goal"]
    write_drn(cmap, tmp_path / "b.drn")
    assert _plain_storm(tmp_path / "b.drn", 'Pmax=? [F "goal"]') == 0.0
    text = (tmp_path / "b.drn").read_text()
    holder = [line for line in text.splitlines() if line.startswith("state ") and LABEL_HOLDER in line]
    assert len(holder) == 1 and "goal" in holder[0].split() and "collision" not in holder[0].split()


def test_drn_has_no_cleaner_way_to_declare_a_label_than_a_state_carrying_it(scenario_map, tmp_path):
    """Why the holder state stays (checked against Storm's DRN parser, not assumed): its
    header knows only @type, @value_type, @parameters, @placeholders, @reward_models,
    @nr_states, @nr_choices and @model and refuses any other line, and a label comes into
    being only when a ``state`` line carries it. Should a Storm release accept a label
    declaration in the header, this test fails and the holder can go."""
    cmap = scenario_map("overtaking")
    write_drn(cmap, tmp_path / "s.drn", "dtmc")
    lines = (tmp_path / "s.drn").read_text().splitlines()
    holder = next(k for k, line in enumerate(lines) if line.startswith("state ") and LABEL_HOLDER in line)
    bare = [line for line in lines[:holder] if not line.startswith("//")]
    n_states, n_choices = bare.index("@nr_states") + 1, bare.index("@nr_choices") + 1
    bare[n_states] = str(int(bare[n_states]) - 1)
    bare[n_choices] = str(int(bare[n_choices]) - 1)
    (tmp_path / "bare.drn").write_text("\n".join(bare) + "\n")
    with pytest.raises(Exception, match="unknown label 'collision'"):
        _plain_storm(tmp_path / "bare.drn", 'P=? [F "collision"]')  # without the holder
    for header in ("@labels", "@state_labels", "@label_names"):
        declared = bare[: bare.index("@model")] + [header, "collision"] + bare[bare.index("@model"):]
        (tmp_path / "declared.drn").write_text("\n".join(declared) + "\n")
        with pytest.raises(Exception, match=f"Could not parse line '{header}'"):
            stormpy.build_model_from_drn(str(tmp_path / "declared.drn"))
    assert _plain_storm(tmp_path / "s.drn", 'P=? [F "collision"]') == 0.0


def test_drn_adds_no_state_when_every_label_is_carried(branching_map):
    cmap = branching_map
    cmap.replace_state(State(**{**{f: getattr(cmap[0], f) for f in State.__dataclass_fields__}}))
    m = export_model(cmap)
    assert all(m.labels[name] for name in ("goal", "collision", "plan", "init"))
    # goal_in_map is on q0 (the map reaches the goal): every label is carried
    buf = io.StringIO()
    write_drn(m, buf)
    assert LABEL_HOLDER not in buf.getvalue()


# -- one-state models ------------------------------------------------------------------------
@needs_prism
@pytest.mark.parametrize("kind", ["mdp", "dtmc"])
def test_a_one_state_model_loads_in_prism_and_storm(kind, tmp_path, one_state_map):
    """Before: ``q : [0..0]`` (PRISM: refused) and empty rewards blocks (Storm: refused)."""
    cmap = one_state_map
    path = tmp_path / "one.prism"
    write_prism(cmap, path, kind)
    program = stormpy.parse_prism_program(str(path))
    model = stormpy.build_model(program)
    assert model.nr_states == 1
    q = "max" if kind == "mdp" else ""
    got = check_with_prism(cmap, [f'P{q}=? [F "goal"]', f'R{{"distance"}}{q}=? [C<=3]'], kind)
    assert (got.n_states, got.n_transitions) == (1, 1)
    assert got.values == [0.0, 0.0]


# -- named rewards in PRISM's explicit files ---------------------------------------------------
def test_explicit_reward_files_name_their_structure(scenario_map):
    files = {k: io.StringIO() for k in ("srew", "trew", "time.srew", "time.trew")}
    write_prism_explicit(scenario_map("overtaking"), files)
    for suffix, name in (("srew", "distance"), ("trew", "distance"), ("time.srew", "time"), ("time.trew", "time")):
        assert files[suffix].getvalue().splitlines()[0] == f'# Reward structure "{name}"'


@needs_prism
@pytest.mark.parametrize("kind", ["mdp", "dtmc"])
def test_prism_evaluates_named_rewards_from_the_explicit_files(scenario_map, kind):
    """Before: ``R{"distance"}`` failed in PRISM: "Invalid reward structure index"."""
    cmap = scenario_map("overtaking@0.8,-0.3")  # a goal the scan sees, so that the rewards are finite
    q = "min" if kind == "mdp" else ""
    got = check_with_prism(cmap, [f'R{{"distance"}}{q}=? [F "goal"]', f'R{{"time"}}{q}=? [F "goal"]'], kind, via="explicit")
    # the figures of the map itself (not of one planner version): the plan's distance and
    # time for the supervised DTMC, the cheapest path to the goal for the MDP
    assert got.values == pytest.approx([_to_goal(cmap, "distance", kind), _to_goal(cmap, "duration", kind)], abs=1e-9)


def _to_goal(cmap, attr: str, kind: str) -> float:
    import heapq

    from clomp.formal.invariants import map_plan

    if kind == "dtmc":
        return sum(getattr(cmap[i], attr) for i in map_plan(cmap).states[1:])
    best = {cmap.initial_id: 0.0}
    queue = [(0.0, cmap.initial_id)]
    while queue:
        d, u = heapq.heappop(queue)
        if cmap[u].reached_goal:
            return d
        if d > best[u]:
            continue
        for t in cmap.out_transitions(u):
            nd = d + getattr(cmap[t.target], attr)
            if nd < best.get(t.target, float("inf")):
                best[t.target] = nd
                heapq.heappush(queue, (nd, t.target))
    raise AssertionError("the goal is not reachable in the map")


@needs_prism
def test_prism_reads_mdp_transition_rewards_of_probabilistic_choices(branching_map):
    """Before: each branch of a choice had its own reward; PRISM refuses that
    ("mismatching transition rewards"). The choice's reward is the expected distance."""
    cmap = branching_map
    expected = Fraction(1, 5) * Fraction(0.2) + Fraction(3, 10) * (Fraction(0.6) + 1) + Fraction(1, 2) * Fraction(1.0)
    props = ['R{"distance"}min=? [F ("goal" | "collision")]', 'Pmax=? [!"collision" U "goal"]']
    for via in ("explicit", "prism"):
        got = check_with_prism(cmap, props, "mdp", via=via)
        assert got.values[0] == pytest.approx(float(expected), abs=1e-9), via
        assert got.values[1] == pytest.approx(0.8, abs=1e-12), via
    files = {"trew": io.StringIO()}
    write_prism_explicit(cmap, files)
    rows: dict[tuple[str, str], set[str]] = {}
    for line in files["trew"].getvalue().splitlines()[3:]:
        s, c, _, r = line.split()
        rows.setdefault((s, c), set()).add(r)
    assert all(len(v) == 1 for v in rows.values())


# -- the PRISM language's printed probabilities ---------------------------------------------------
_CMD = re.compile(r"^\s*\[(\w+)\] q=(\d+) -> (.*);$")


def _prism_distributions(text: str) -> dict[tuple[int, str], dict[int, Fraction]]:
    """Parse the commands of a written PRISM model back into exact distributions."""
    out: dict[tuple[int, str], dict[int, Fraction]] = {}
    body = text.split("module cognitive_map", 1)[1].split("endmodule", 1)[0]
    for line in body.splitlines():
        m = _CMD.match(line)
        if not m:
            continue
        dist: dict[int, Fraction] = {}
        for part in m.group(3).split(" + "):
            p, upd = part.split(":", 1)
            dist[int(re.fullmatch(r"\(q'=(\d+)\)", upd.strip()).group(1))] = Fraction(p)  # type: ignore[union-attr]
        out[(int(m.group(2)), m.group(1))] = dist
    return out


def test_prism_language_probabilities_read_back_as_the_maps(scenario_map, branching_map):
    """Before: nothing read the printed probabilities back; printing every branch as 1/2
    passed every test (and Storm accepts rows that do not sum to 1)."""
    for cmap in (branching_map, scenario_map("overtaking")):
        buf = io.StringIO()
        write_prism(cmap, buf)
        got = _prism_distributions(buf.getvalue())
        m = export_model(cmap)
        want = {
            (m.states[k].ident, ch.action): {m.states[j].ident: p for j, p in ch.branches}
            for k, row in enumerate(m.choices)
            for ch in row
        }
        assert got == want


def test_storm_builds_the_printed_probabilities_of_the_prism_language(tmp_path, branching_map):
    cmap = branching_map
    write_prism(cmap, tmp_path / "b.nm")
    from clomp.formal.checking import load_storm_model

    sm = load_storm_model(tmp_path / "b.nm")
    model, idents = sm.model, sm.idents
    init = int(model.initial_states[0])
    rows = {
        frozenset((idents[t.column], Fraction(t.value).limit_denominator(1000)) for t in a.transitions)
        for a in model.states[init].actions
    }
    assert rows == {
        frozenset({(1, Fraction(1, 5)), (2, Fraction(3, 10)), (3, Fraction(1, 2))}),
        frozenset({(4, Fraction(1))}),
    }


# -- the svg writer takes the model kind like every writer --------------------------------------------
def test_svg_writer_takes_the_model_kind(scenario_map, tmp_path, monkeypatch):
    """Before: ``FORMATS["svg"](map, dest, "dtmc")`` passed "dtmc" as the Graphviz engine."""
    import shutil

    if shutil.which("dot") is None:
        pytest.skip("Graphviz is not installed (apt-get install graphviz)")
    cmap = scenario_map("overtaking")
    FORMATS["svg"](cmap, tmp_path / "s.svg", "dtmc")
    FORMATS["svg"](cmap, tmp_path / "u.svg", "mdp")
    supervised, unsupervised = (tmp_path / "s.svg").read_text(), (tmp_path / "u.svg").read_text()
    n_plan = len(cmap.metadata["plan"])

    def states(svg: str) -> int:  # the legend is a node too, not a state
        return svg.count('class="node"') - svg.count("<title>legend</title>")

    assert states(supervised) == n_plan
    assert states(unsupervised) == len(cmap)


# -- property files both tools read ----------------------------------------------------------------
@needs_prism
def test_prism_errors_are_reported_not_swallowed(scenario_map):
    with pytest.raises(PrismError, match="Syntax error"):
        check_with_prism(scenario_map("open"), ['Pmax>=1 [F "goal"]'], "mdp")


# -- property names and labels -------------------------------------------------------------------------
def _labels_for(pf) -> set[str]:
    """The labels of the models a shipped property file is for: a map's export of its
    kind, or (supervisor/) the supervisor composed with the plant."""
    from clomp.formal.control import PLANT, SUPERVISOR, machine_model
    from clomp.formal.export import LABELS

    if Path(pf.source).parent.name == "supervisor":
        return set(machine_model(SUPERVISOR, PLANT).labels)
    if Path(pf.source).parent.name == "closed_loop":  # clomp export --closed-loop: clomp.formal.retry.loop_model
        from clomp.formal.retry import GAVE_UP, INTERRUPTED, OFF_LABEL

        return {*LABELS, INTERRUPTED, GAVE_UP, OFF_LABEL}
    return set(LABELS)


def test_no_shipped_property_name_is_a_label_of_its_models():
    """Before: supervised.pctl named a property "goal"; PRISM 4.10.1 refuses the file on
    the DTMC: 'Name of property "goal" is already used for a label in the model'. Every
    label a file names is one its models have, too."""
    from clomp.formal.checking import property_labels, shipped_property_files

    files = [read_properties(p) for p in shipped_property_files()]
    assert {Path(pf.source).name for pf in files} >= {"supervised.pctl", "unsupervised.pctl", "machine.pctl"}
    for pf in files:
        labels = _labels_for(pf)
        assert not {p.name for p in pf.properties} & labels, pf.source
        assert property_labels(pf) <= labels, pf.source


@needs_prism
def test_check_with_both_tools_reports_prisms_refusal(tmp_path, capfd):
    """``clomp check --tool both`` hands PRISM the named properties, as a user's run of
    PRISM on the file does: a name that clashes with a label is PRISM's error, named."""
    import clomp.runtime.cli as cli

    spec = tmp_path / "clash.pctl"
    spec.write_text('// @model dtmc\n"goal": P=? [F "goal"]\n')
    code = cli.main(["check", "--scenario", "overtaking", "--tool", "both", "--specs", str(spec)])
    err = capfd.readouterr().err
    assert code == 2
    assert err.startswith("clomp: error: PRISM:") and 'already used for a label' in err


# -- every model clomp writes, against every property file shipped for it, in both tools ---------------
# The walk runs the commands a user runs (``clomp export`` in every format and model kind,
# ``--policy storm``, the demo's supervisor export; ``clomp demo`` itself under -m slow),
# picks the shipped property files for each written model as ``clomp check`` does (its
# kind, the labels it declares), and loads it every way the tools read it: the PRISM
# language in PRISM and in Storm, PRISM's explicit files in PRISM (Storm's explicit
# format wants a model-type line PRISM's files do not have), the DRN in plain Storm, the
# JSON map through ``clomp check --tool both``. Every load must give the same values
# (<= 1e-9) and pass every required property.
EXPORTS = (("mdp", ()), ("dtmc", ()), ("dtmc", ("--policy", "storm")),
           # the closed loop's model (docs/calibration.md) at harsh noise: stops, outcomes off
           # the map's prediction and replans in the model; checked against closed_loop/ only
           ("mdp", ("--samples", "5", "--noise", "harsh", "--seed", "1", "--closed-loop")),
           ("dtmc", ("--samples", "5", "--noise", "harsh", "--seed", "1", "--closed-loop", "--replans", "2")))


def _cli(*argv: str) -> int:
    import clomp.runtime.cli as cli

    return cli.main(list(argv))


def _properties_for(path: Path, kind: str) -> list:
    from clomp.formal.checking import file_labels, meant_for, shipped_property_files

    labels = file_labels(path)
    files = [read_properties(p) for p in shipped_property_files()]
    chosen = [pf for pf in files if meant_for(pf, kind, labels)]
    assert chosen, f"no shipped property file for {path}"
    return [p for pf in chosen for p in pf.properties]


def _storm_values(path: Path, specs: list) -> list:
    from clomp.formal.checking import check_properties, load_storm_model

    return [r.value for r in check_properties(load_storm_model(path), specs)]


def _prism_values(args: list[str], specs: list) -> list:
    from clomp.formal.prism import run_prism

    return run_prism(args, [f'"{p.name}": {p.formula}' for p in specs]).values


def _judge(name: str, specs: list, loads: dict[str, list]) -> list[str]:
    """What is wrong with one written model's loads: a disagreement or a failed requirement."""
    from clomp.formal.crosscheck import values_agree

    problems = []
    ref_load, ref = next(iter(loads.items()))
    for load, values in loads.items():
        assert len(values) == len(specs), (name, load)
        for spec, a, b in zip(specs, ref, values):
            if not values_agree(a, b):
                problems.append(f"{name} {spec.name}: {ref_load} {a!r} vs {load} {b!r}")
            if spec.required is not None and not spec.required.holds(b):
                problems.append(f"{name} {spec.name}: {load} gives {b!r}, required {spec.required}")
    return problems


# the closed loop's model with replans at harsh noise, as `check --closed-loop` builds it
CLOSED_LOOP = ("--samples", "5", "--noise", "harsh", "--seed", "1", "--closed-loop", "--replans", "2")

# a goal the scan sees, right of the box: the scenario's own stands in the box's shadow, no
# plan claims it, and Storm's scheduler for a goal it cannot reach may choose any task
SEEN = ("--goal", "0.8,-0.3")


def _walk(folder: Path, prism: bool) -> tuple[list[str], int]:
    """Write every model the commands write for the overtaking scenario into ``folder``,
    check them; returns the problems and how many (model, load) pairs were checked."""
    from clomp.formal.export import prism_import_args
    from clomp.runtime.cli.demo import supervisor_closed_loop_prism

    problems: list[str] = []
    checked = 0
    written: list[tuple[str, str, Path, Path | None, Path | None]] = []  # name, kind, .prism, .drn, explicit stem
    for kind, extra in EXPORTS:
        stem = folder / f"ov-{kind}{'-closed-loop' if '--closed-loop' in extra else '-' + extra[-1] if extra else ''}"
        for fmt, path in (("prism", stem.with_suffix(".prism")), ("drn", stem.with_suffix(".drn")),
                          ("prism-explicit", stem), ("dot", stem.with_suffix(".dot"))):
            assert _cli("export", "--scenario", "overtaking", *SEEN, "-f", fmt, "--model", kind, *extra, "-o", str(path)) == 0, (fmt, kind, extra)
        written.append((stem.name, kind, stem.with_suffix(".prism"), stem.with_suffix(".drn"), stem))
        # DOT is a picture, not a model checker's input: it must draw the model's states
        nodes = re.findall(r"^\s*\d+ \[label=", stem.with_suffix(".dot").read_text(), re.M)
        states = set(re.findall(r"^\s*\[\w+\] q=(\d+) ->", stem.with_suffix(".prism").read_text(), re.M))
        if len(nodes) != len(states):
            problems.append(f"{stem.name}.dot draws {len(nodes)} states, the model has {len(states)}")
    induced = folder / "induced"  # `clomp check --induced`: Storm's scheduler's DTMC, the format from the name
    for path in (induced.with_suffix(".prism"), induced.with_suffix(".drn"), induced):
        assert _cli("check", "--scenario", "overtaking", *SEEN, "--induced", str(path)) == 0, path
    written.append(("check --induced", "dtmc", induced.with_suffix(".prism"), induced.with_suffix(".drn"), induced))
    # `clomp check --closed-loop --induced`: Storm's scheduler of the closed loop's MDP (a task,
    # or retry at a stop, per map state and replans used), its DTMC checked against closed_loop/
    cl = folder / "ov-closed-loop-induced"
    for path in (cl.with_suffix(".prism"), cl.with_suffix(".drn"), cl):
        code = _cli("check", "--scenario", "overtaking", *SEEN, *CLOSED_LOOP, "--induced", str(path))
        if code != 0:  # the closed loop's own properties failed (a label made constant)
            problems.append(f"{cl.name}: clomp check --closed-loop exits {code}")
    written.append((cl.name, "dtmc", cl.with_suffix(".prism"), cl.with_suffix(".drn"), cl))
    sup = folder / "supervisor.prism"  # what `clomp demo` writes beside the map
    sup.write_text(supervisor_closed_loop_prism())
    written.append(("demo supervisor.prism", "mdp", sup, None, None))
    for name, kind, prism_file, drn, explicit in written:
        specs = _properties_for(prism_file, kind)
        loads = {"PRISM language in Storm": _storm_values(prism_file, specs)}
        if drn is not None:
            loads["DRN in Storm"] = _storm_values(drn, specs)
        if prism:
            loads["PRISM language in PRISM"] = _prism_values([str(prism_file)], specs)
            if explicit is not None:
                loads["explicit files in PRISM"] = _prism_values(prism_import_args(explicit, kind), specs)  # type: ignore[arg-type]
        checked += len(loads)
        problems += _judge(name, specs, loads)
    assert _cli("export", "--scenario", "overtaking", "-f", "json", "-o", str(folder / "ov.json")) == 0
    if _cli("check", str(folder / "ov.json"), "--tool", "both" if prism else "storm") != 0:
        problems.append("clomp check ov.json fails")
    return problems, checked + 1


def test_every_written_model_passes_its_property_files_in_both_tools(tmp_path, capsys):
    """Before: the demo's supervisor.prism FAILed machine.pctl (wheels_only_on_a_task),
    and PRISM refused supervised.pctl on the DTMC (a property named "goal", like a label);
    PRISM had only been handed the formulas, without their names. (This walk replaces a
    test that ran PRISM on each map property file with unnamed formulas.)"""
    problems, checked = _walk(tmp_path, prism=find_prism() is not None)
    assert not problems, problems
    assert checked >= (23 if find_prism() is not None else 12)
    if find_prism() is None:
        pytest.skip(f"PRISM not found (set CLOMP_PRISM): checked the {checked} Storm loads only")


@pytest.mark.parametrize("where", ["map", "supervisor", "closed-loop"])
def test_the_walk_fails_when_a_label_is_made_constant(tmp_path, capsys, monkeypatch, where):
    """The walk is not blind: ``goal`` constant false in a map's exports, ``driving``
    in the supervisor's (the demo's old export), or ``interrupted`` in the closed loop's
    models makes it report failures there (Storm only)."""
    from dataclasses import replace

    import clomp.formal.control as control
    import clomp.runtime.cli.export as export_cli

    if where == "map":
        real = export_cli.export_for
        monkeypatch.setattr(export_cli, "export_for", lambda *a: replace(m := real(*a), labels={**m.labels, "goal": frozenset()}))
    elif where == "closed-loop":
        real_loop = export_cli.loop_model
        monkeypatch.setattr(export_cli, "loop_model", lambda *a: replace(m := real_loop(*a), labels={**m.labels, "interrupted": frozenset()}))
    else:
        real_m = control.machine_model
        monkeypatch.setattr(control, "machine_model", lambda *a: replace(m := real_m(*a), labels={**m.labels, "driving": frozenset()}))
    problems, _ = _walk(tmp_path, prism=False)
    assert problems
    if where == "closed-loop":  # only the closed loop's models: both kinds of export and the scheduler's DTMC
        names = ("ov-mdp-closed-loop", "ov-dtmc-closed-loop", "ov-closed-loop-induced")
        assert all("closed-loop" in p for p in problems), problems
        assert {n for n in names if any(p.startswith((n + " ", n + ":")) for p in problems)} == set(names), problems
    else:
        assert any(("supervisor" in p) == (where == "supervisor") for p in problems), problems


@pytest.mark.slow
def test_clomp_demo_writes_a_supervisor_model_that_passes_in_both_tools(tmp_path, capsys):
    """The demo command itself (a closed-loop run, several seconds): its supervisor.prism
    passes machine.pctl in Storm and, when PRISM is found, in PRISM with the same values."""
    assert _cli("demo", "--out", str(tmp_path)) == 0
    path = tmp_path / "supervisor.prism"
    specs = _properties_for(path, "mdp")
    assert {s.name for s in specs} >= {"wheels_only_on_a_task", "fault_stops_the_wheels"}
    loads = {"PRISM language in Storm": _storm_values(path, specs)}
    if find_prism() is not None:
        loads["PRISM language in PRISM"] = _prism_values([str(path.resolve())], specs)
    assert not _judge("demo", specs, loads)


# -- schedulers and witnesses as files ------------------------------------------------------------------
def test_check_writes_storms_scheduler_with_tasks_and_valuations(tmp_path, capsys, risky_map):
    """``--scheduler``: per map state the chosen task, the state's pose and task; on the
    risky map Storm takes the detour (LEFT) that the best-first plan does not."""
    import json

    risky_map.write_json(tmp_path / "risky.json")
    # 1: the best-first plan's DTMC rightly fails the "sure" requirements (a collision 1 in 5)
    assert _cli("check", "--map", str(tmp_path / "risky.json"), "--scheduler", str(tmp_path / "s.json"), "--induced", str(tmp_path / "i.drn")) == 1
    record = json.loads((tmp_path / "s.json").read_text())
    assert record["probability"] == pytest.approx(1.0) and record["plan"][:2] == ["q0", "q3"]
    by = {s["state"]: s for s in record["states"]}
    assert by["q0"]["action"] == "LEFT" and by["q3"] == {"state": "q3", "ident": 3, "pose": [0.0, 0.0, 1.57], "task": "LEFT", "action": "STRAIGHT"}
    tasks = {(t.source, t.label.value) for t in risky_map.transitions()}
    assert all((s["ident"], s["action"]) in tasks for s in record["states"])
    assert _storm_values(tmp_path / "i.drn", [PropertySpec('P=? [!"collision" U "goal"]', "safe")]) == [1.0]
    assert _cli("check", str(tmp_path / "i.drn"), "--scheduler", str(tmp_path / "x.json")) == 2  # a model file has no poses


@pytest.mark.parametrize("replans", [0, 1])
def test_check_closed_loop_writes_storms_scheduler_and_its_dtmc(tmp_path, capsys, replans):
    """Before: ``--scheduler``/``--induced`` were refused with ``--closed-loop``. The
    scheduler of the closed loop's MDP chooses ``retry`` only at the interruptions (stops,
    outcomes off the map's prediction) with a replan left, a task elsewhere; its value is the induced DTMC's, in Storm (DRN and
    PRISM language) and PRISM (language and explicit files); here a replan lifts it
    from 0.8 to 1 (seed 1: the stops are false alarms the next plan gets through; 0.4
    before the closed-loop terms were refitted to today's harsh world)."""
    import json

    from clomp.formal.export import prism_import_args
    from clomp.formal.model import TaskKind

    argv = ["--scenario", "overtaking", *SEEN, "--samples", "5", "--noise", "harsh", "--seed", "1", "--closed-loop", "--replans", str(replans)]
    stem = tmp_path / "cl"
    for path in (stem.with_suffix(".drn"), stem.with_suffix(".prism"), stem):
        assert _cli("check", *argv, "--scheduler", str(tmp_path / "s.json"), "--induced", str(path)) == 0
    record = json.loads((tmp_path / "s.json").read_text())
    assert record["replans"] == replans and record["probability"] == pytest.approx(0.8 if replans == 0 else 1.0)
    assert record["plan"][0] == "q0" and record["property"] == 'Pmax=? [!"collision" U "goal"]'
    cmap_json = tmp_path / "m.json"
    assert _cli("export", "--scenario", "overtaking", *SEEN, *argv[4:-2], "-f", "json", "-o", str(cmap_json)) == 0
    meta = json.loads(cmap_json.read_text())["metadata"]
    stops = {int(k) for key in ("stops", "offs") for k in meta.get(key, {})}  # interrupted: a stop, or off the prediction
    for st in record["states"]:
        base = int(st["map_state"][1:])
        assert 0 <= st["replans_used"] <= replans
        if st["action"] == "retry":
            assert base in stops and st["replans_used"] < replans, st
        else:
            assert st["action"] in TaskKind.__members__, st
    assert any(st["action"] == "retry" for st in record["states"]) == (replans > 0)
    safe = [PropertySpec('P=? [!"collision" U "goal"]', "safe")]
    values = {"DRN in Storm": _storm_values(stem.with_suffix(".drn"), safe),
              "PRISM language in Storm": _storm_values(stem.with_suffix(".prism"), safe)}
    if find_prism() is not None:
        values["PRISM language in PRISM"] = _prism_values([str(stem.with_suffix(".prism"))], safe)
        values["explicit files in PRISM"] = _prism_values(prism_import_args(stem, "dtmc"), safe)
    for load, (v,) in values.items():
        assert v == pytest.approx(record["probability"], abs=1e-9), load


@pytest.mark.parametrize("source", ["map", "prism", "drn"])
def test_check_writes_the_witness_path_with_states_actions_labels(tmp_path, capsys, source):
    """Before: a violated property's path was only a printed line."""
    import json

    spec = tmp_path / "strict.pctl"
    spec.write_text('// @model mdp\n// @required = 0\n"never": Pmax=? [F "collision"]\n')
    argv = ["--scenario", "overtaking"]
    if source != "map":
        path = tmp_path / f"ov.{source}"
        assert _cli("export", "--scenario", "overtaking", "-f", source, "-o", str(path)) == 0
        argv = [str(path)]
    assert _cli("check", *argv, "--specs", str(spec), "--witness", str(tmp_path / "w.json")) == 1
    (violated,) = json.loads((tmp_path / "w.json").read_text())["violated"]
    path = violated["path"]
    assert violated["property"] == "never" and path[0]["state"] == "q0" and "init" in path[0]["labels"]
    assert "collision" in path[-1]["labels"] and path[-1]["action"] is None
    assert all(step["action"] in ("STRAIGHT", "LEFT", "RIGHT") for step in path[:-1]), path
