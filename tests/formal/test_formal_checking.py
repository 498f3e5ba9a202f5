"""Storm checking: property files, required properties on scenarios and scans, the
differential check against the plan, and the ``clomp check`` / ``clomp export`` commands."""

from __future__ import annotations

import math
from fractions import Fraction
import sys
from pathlib import Path

import pytest

from clomp.formal import CognitiveMap
from clomp.formal.checking import (
    PropertySpec,
    Requirement,
    SpecError,
    StormMissing,
    build_storm_model,
    check_map_properties,
    check_properties,
    compare_distance,
    default_property_files,
    parse_properties,
    plan_distance,
    read_properties,
    require_stormpy,
)
from clomp.planner.scenarios import builtin_scenarios

SCANS = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scans" / "corridor-2023-10-25"
needs_storm = pytest.mark.skipif(
    __import__("importlib").util.find_spec("stormpy") is None, reason="stormpy not installed: pip install -e '.[verify]'"
)






# -- the property-file format --------------------------------------------------------------
def test_shipped_property_files_parse_and_have_required_properties():
    files = [read_properties(p) for p in default_property_files()]
    assert {pf.model for pf in files} == {"mdp", "dtmc"}
    for pf in files:
        assert any(p.required is not None for p in pf.properties)
        assert all(p.description for p in pf.properties), "every property says what it means for the robot"


def test_property_file_fields():
    pf = parse_properties('// @model dtmc\n// never collides\n// @required = 0\n"c": P=? [F "collision"]\nP=? [F "goal"]\n', "x.pctl")
    a, b = pf.properties
    assert (a.name, a.formula, a.description, str(a.required), a.line) == ("c", 'P=? [F "collision"]', "never collides", "= 0", 4)
    assert b.required is None and b.name == 'P=? [F "goal"]'


@pytest.mark.parametrize(
    "text, where",
    [
        ('// @model dtmc\n// @requird true\nP=? [F "goal"]\n', "x.pctl:2"),
        ('// @model dtmc\nP=? [F "goal"\n', "x.pctl:2"),
        ('// @model dtmc\nthe robot is fine\n', "x.pctl:2"),
        ('P=? [F "goal"]\n', "x.pctl:1"),
        ('// @model ctmc\nP=? [F "goal"]\n', "x.pctl:1"),
        ('// @model dtmc\nP=? [F "goal"]\n// @required true\n', "x.pctl:3"),
        ('// @model dtmc\n// @required maybe\nP=? [F "goal"]\n', "x.pctl:2"),
        ('// @model dtmc\n"a": P=? [F "goal"]\n"a": P=? [F "goal"]\n', "x.pctl:3"),
        ("// only comments\n", "x.pctl"),
    ],
)
def test_property_file_syntax_errors_name_the_line(text, where):
    with pytest.raises(SpecError, match=f"^{where}"):
        parse_properties(text, "x.pctl")


def test_requirements_use_a_tolerance():
    assert Requirement.parse("0").holds(1e-9) and not Requirement.parse("0").holds(1e-3)
    assert Requirement.parse("<= 1.5").holds(1.5 + 1e-9) and not Requirement.parse("< 1.5").holds(1.5)
    assert Requirement.parse("true").holds(True) and not Requirement.parse("true").holds(1.0)


# -- Storm ---------------------------------------------------------------------------------------------
@needs_storm
@pytest.mark.parametrize("via", ["drn", "prism"])
@pytest.mark.parametrize("name", builtin_scenarios())
def test_required_properties_hold_on_scenarios(scenario_map, name, via):
    results = check_map_properties(scenario_map(name), via=via)
    assert {r.kind for r in results} == {"mdp", "dtmc"}
    failed = [(r.spec.name, r.value, r.witness) for r in results if r.passed is False]
    assert not failed


@needs_storm
def test_required_properties_hold_on_recorded_scans(scan_maps):
    for name, cmap in scan_maps():
        failed = [(r.spec.name, r.value) for r in check_map_properties(cmap) if r.passed is False]
        assert not failed, name


@needs_storm
def test_supervised_overtaking_reaches_the_goal_without_collision(scenario_map):
    # round the box to a goal the scan sees (the scenario's own stands in the box's shadow)
    results = {r.spec.name: r.value for r in check_map_properties(scenario_map("overtaking@0.8,-0.3"))}
    assert results["p_goal"] == pytest.approx(1.0) and results["no_collision"] == pytest.approx(0.0)
    assert results["distance"] == pytest.approx(plan_distance(scenario_map("overtaking@0.8,-0.3")))


@needs_storm
def test_a_failed_requirement_names_a_violating_path(scenario_map):
    cmap = scenario_map("overtaking")
    sm = build_storm_model(cmap, "mdp")
    (r,) = check_properties(sm, [PropertySpec('Pmax=? [F "collision"]', "hit", required=Requirement("=", 0.0))])
    assert r.passed is False and r.verdict == "FAIL"
    assert r.witness[0] == f"q{cmap.initial_id}" and r.witness[-1].endswith("[collision]")
    idents = [int(w.split("[")[0][1:]) for w in r.witness]
    assert all(cmap.has_transition(a, b) for a, b in zip(idents, idents[1:]))
    assert cmap[idents[-1]].interrupted


@needs_storm
def test_storm_rejects_an_unknown_label_as_a_spec_error(scenario_map):
    sm = build_storm_model(scenario_map("open"), "dtmc")
    with pytest.raises(SpecError, match="x.pctl:2"):
        check_properties(sm, parse_properties('// @model dtmc\nP=? [F "nowhere"]\n', "x.pctl"))


@needs_storm
def test_differential_storm_optimum_never_exceeds_the_plan(scenario_map, scan_maps):
    """Storm's R{"distance"}min=? [F "goal"] is the least expected distance over every
    scheduler of the explored MDP; the plan is one such scheduler, so when the plan reaches
    the goal, Storm's optimum is finite and ≤ the plan's distance. The Configurator is
    greedy best-first on φ (not on distance), so the inequality may be strict; when the
    plan does not reach the goal, the goal is not in the map and the optimum is infinite."""
    cases = [(n, scenario_map(n)) for n in builtin_scenarios()]
    if SCANS.is_dir():
        cases += scan_maps()
    for name, cmap in cases:
        cmp = compare_distance(cmap)
        assert cmp.consistent, name
        if cmp.plan_reaches_goal:
            assert cmp.storm_min <= cmp.plan + 1e-6, name
        else:
            assert math.isinf(cmp.storm_min), name


def test_without_stormpy_the_message_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "stormpy", None)
    with pytest.raises(StormMissing, match=r"pip install -e '\.\[verify\]'"):
        require_stormpy()


# -- the command line ---------------------------------------------------------------------------------
@pytest.fixture
def clomp(monkeypatch, capsys):
    import clomp.runtime.cli as cli

    mods = list(cli._COMMAND_MODULES)
    for m in ("clomp.runtime.cli.export", "clomp.runtime.cli.check"):
        if m not in mods:
            mods.append(m)
    monkeypatch.setattr(cli, "_COMMAND_MODULES", mods)

    def run(*argv: str) -> tuple[int, str, str]:
        try:
            code = cli.main(list(argv))
        except SystemExit as exc:  # argparse usage errors
            code = int(exc.code or 0)
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


@needs_storm
def test_cli_check_scenario_prints_a_table_and_passes(clomp):
    # a goal the scan sees (the scenario's own stands in the box's shadow: no plan reaches it)
    code, out, _ = clomp("check", "--scenario", "overtaking", "--goal", "0.8,-0.3")
    assert code == 0
    assert "no_collision" in out and "pass" in out and "FAIL" not in out
    # the figures are the map's own (the overtaking plan's length), not one planner version's
    import re

    from clomp.planner import Configurator, load_scenario

    scene = load_scenario("overtaking")
    r = Configurator().plan(scene.scan(max_range=1.1), (0.8, -0.3))
    length = sum(q.distance for q in r.steps)
    plan_m = re.search(r"distance: plan ([0-9.]+) m", out)
    opt_m = re.search(r"Rmin\[F goal\] = ([0-9.]+) m", out)
    assert plan_m and opt_m, out
    assert float(plan_m.group(1)) == pytest.approx(length, abs=0.006)
    assert float(opt_m.group(1)) <= float(plan_m.group(1))


@needs_storm
def test_cli_check_fails_with_a_path_when_a_requirement_fails(clomp, tmp_path):
    spec = tmp_path / "strict.pctl"
    spec.write_text('// @model mdp\n// no option collides\n// @required = 0\n"never": Pmax=? [F "collision"]\n')
    code, out, _ = clomp("check", "--scenario", "overtaking", "--specs", str(spec))
    assert code == 1
    assert "FAIL never" in out and "violating path: q0 ->" in out and "[collision]" in out


@needs_storm
@pytest.mark.parametrize("fmt", ["prism", "drn"])
def test_cli_export_then_check_the_exported_file(clomp, tmp_path, fmt):
    path = tmp_path / f"ov.{fmt}"
    assert clomp("export", "--scenario", "overtaking", "--format", fmt, "-o", str(path))[0] == 0
    code, out, _ = clomp("check", str(path))
    assert code == 0 and "mdp" in out and "dtmc" not in out.split("\n", 2)[2]
    path = tmp_path / f"ovs.{fmt}"
    assert clomp("export", "--scenario", "overtaking", "--format", fmt, "--model", "dtmc", "-o", str(path))[0] == 0
    code, out, _ = clomp("check", str(path))
    assert code == 0 and "no_collision" in out


def test_cli_export_writes_every_format(scenario_map, clomp, tmp_path):
    for fmt in ("prism", "prism-explicit", "drn", "dot", "json"):
        assert clomp("export", "--scenario", "overtaking", "--format", fmt, "-o", str(tmp_path / f"ov.{fmt}"))[0] == 0
    assert (tmp_path / "ov.prism-explicit.tra").is_file()
    assert CognitiveMap.read_json(tmp_path / "ov.json") == scenario_map("overtaking")
    scan = SCANS / "map0001.dat"
    if scan.is_file():
        assert clomp("export", "--scan", str(scan), "--goal", "1,0", "--format", "drn", "-o", str(tmp_path / "s.drn"))[0] == 0


@pytest.mark.parametrize(
    "make, argv, message",
    [
        ("empty", ("export", "--format", "prism"), "empty map"),
        ("no-initial", ("export", "--format", "drn"), "initial state"),
        ("empty", ("check",), "empty map"),
        ("garbage", ("export", "--format", "dot"), "not valid JSON"),
        (None, ("export", "--scenario", "overtaking", "--format", "graphml"), "invalid choice"),
        (None, ("check", "--scenario", "nowhere-land"), "nowhere-land"),
        ("badspec", ("check", "--scenario", "open"), "bad.pctl:2"),
    ],
)
def test_cli_bad_input_is_one_clear_error_and_status_2(scenario_map, clomp, tmp_path, make, argv, message):
    args = list(argv)
    m = tmp_path / "m.json"
    if make == "empty":
        m.write_text('{"format": "clomp-cognitive-map", "version": 1, "states": [], "transitions": []}')
    elif make == "no-initial":
        d = scenario_map("open").to_dict()
        d["initial"] = None
        CognitiveMap.from_dict(d).write_json(m)
    elif make == "garbage":
        m.write_text("{not json")
    if make in ("empty", "no-initial", "garbage"):
        args += ["--map", str(m)]
    if make == "badspec":
        bad = tmp_path / "bad.pctl"
        bad.write_text('// @model dtmc\nP=? [F "goal"\n')
        args += ["--specs", str(bad)]
    if args[0] == "export":
        args += ["-o", str(tmp_path / "out")]
    code, out, err = clomp(*args)
    assert code == 2
    assert message in err
    assert "Traceback" not in err


def test_cli_check_without_stormpy_says_how_to_install(clomp, monkeypatch):
    monkeypatch.setitem(sys.modules, "stormpy", None)
    code, _, err = clomp("check", "--scenario", "open")
    assert code == 2 and "pip install -e '.[verify]'" in err  # the README's own instruction


# -- clomp check --tool ------------------------------------------------------------------------------
needs_prism = pytest.mark.skipif(
    __import__("clomp.formal.prism", fromlist=["find_prism"]).find_prism() is None,
    reason="PRISM not found: set CLOMP_PRISM or keep shared/tools/prism-*/ beside the repo",
)


@needs_storm
@needs_prism
def test_cli_check_with_both_tools_prints_both_columns(clomp):
    code, out, _ = clomp("check", "--scenario", "overtaking", "--tool", "both")
    assert code == 0, out
    assert "checked by Storm and PRISM" in out and "DISAGREE" not in out
    row = next(line for line in out.splitlines() if " min_distance " in line)
    storm, prism = row.split()[2:4]
    assert storm == prism and float(storm) > 0  # both tools give the same shortest distance


@needs_prism
def test_cli_check_with_prism_fails_a_requirement_and_reads_exported_files(clomp, tmp_path):
    spec = tmp_path / "strict.pctl"
    spec.write_text('// @model mdp\n// no option collides\n// @required = 0\n"never": Pmax=? [F "collision"]\n')
    code, out, _ = clomp("check", "--scenario", "overtaking", "--specs", str(spec), "--tool", "prism")
    assert code == 1 and "checked by PRISM" in out and "FAIL never (mdp): 1" in out
    path = tmp_path / "ov.prism"
    assert clomp("export", "--scenario", "overtaking", "--format", "prism", "--model", "dtmc", "-o", str(path))[0] == 0
    code, out, _ = clomp("check", str(path), "--tool", "prism")
    assert code == 0 and "no_collision" in out and " mdp " not in out


@needs_prism
def test_cli_check_prism_refuses_a_drn_file_with_one_clear_error(clomp, tmp_path):
    path = tmp_path / "ov.drn"
    assert clomp("export", "--scenario", "open", "--format", "drn", "-o", str(path))[0] == 0
    code, _, err = clomp("check", str(path), "--tool", "prism")
    assert code == 2 and "PRISM reads the PRISM language" in err and "Traceback" not in err


def test_cli_check_without_prism_says_how_to_get_it(clomp, monkeypatch, tmp_path):
    monkeypatch.setenv("CLOMP_PRISM", str(tmp_path / "no-such-prism"))
    code, _, err = clomp("check", "--scenario", "open", "--tool", "prism")
    assert code == 2 and "CLOMP_PRISM" in err


@needs_storm
def test_cli_check_both_fails_when_the_tools_disagree(clomp, monkeypatch):
    """The comparison itself: PRISM's answer is replaced by one that differs by 1e-6."""
    import clomp.runtime.cli.check as check
    from clomp.formal.prism import PrismResult

    def off_by_a_little(cmap, formulas, kind):
        values = [0.0 + 1e-6 if "collision" in f and "=?" in f else (True if "=?" not in f else 1.0) for f in formulas]
        return PrismResult(1, 1, None, values)

    monkeypatch.setattr(check, "check_with_prism", off_by_a_little)
    code, out, _ = clomp("check", "--scenario", "overtaking", "--tool", "both")
    assert code == 1
    assert "DISAGREE no_collision (dtmc): Storm 0.0, PRISM 1e-06" in out


# -- the probabilistic map on the command line -----------------------------------------------------
def test_cli_export_samples_writes_branches_strictly_between_0_and_1(clomp, tmp_path):
    from fractions import Fraction

    path = tmp_path / "d.drn"
    assert clomp("export", "--scenario", "doorway", "--samples", "30", "-f", "drn", "-o", str(path))[0] == 0
    probs = [Fraction(line.split(":")[1]) for line in path.read_text().splitlines() if line.startswith("\t\t")]
    assert any(0 < p < 1 for p in probs) and all((p * 30).denominator == 1 for p in probs)


@needs_storm
def test_cli_plan_robust_json_has_both_probabilities(clomp):
    import json

    # round the box to a goal the scan sees (the doorway's goal stands in the wall's shadow:
    # no plan claims it, and the command exits 1)
    seen = ("--scenario", "overtaking", "--goal", "0.8,-0.3")
    code, out, _ = clomp("plan", *seen, "--robust", "--json")
    assert code == 0
    d = json.loads(out)
    assert 0 <= d["greedy_probability"] <= d["probability"] <= 1
    assert d["samples"] == 30 and d["plan"] and d["plan"][0]["state"] > 0
    # what is printed and the figure agree: the path's own chance beside the policy's value,
    # and the policy names a task on every state of the printed path
    assert 0 <= d["path_probability"] <= d["probability"] + 1e-12
    policy = {p["state"]: p["task"] for p in d["policy"]}
    assert [policy[q] for q in [0] + [st["state"] for st in d["plan"][:-1]]] == [st["task"] for st in d["plan"]]
    code, out, _ = clomp("plan", *seen, "--robust")
    assert code == 0 and "a policy" in out and f"P = {d['path_probability']:.4f}" in out
    assert d["decision"] in ("kept", "confirmed", "rejected")


@needs_storm
def test_cli_plan_robust_is_the_runtimes_robust_configurator(clomp, tmp_path):
    """One code path: ``clomp plan --robust`` gives the decision and figures of
    :class:`clomp.planner.robust.RobustConfigurator` (the supervisor's robust planner) on the
    same scan: its rollouts stopped by the hazard rule (stops in the map, retried in the
    objective), poses carried, the closed loop's noise terms, the plan's target."""
    import json

    from clomp.planner import load_scenario
    from clomp.planner.robust import RobustConfigurator, closed_loop_noise

    path = tmp_path / "m.json"
    code, out, _ = clomp("plan", "--scenario", "doorway", "--robust", "--noise", "harsh", "--samples", "8", "--seed", "3",
                         "--json", "--map", str(path))
    assert code in (0, 1)
    d = json.loads(out)
    scene = load_scenario("doorway")
    c = RobustConfigurator(samples=8, noise="harsh", seed=3).choose(scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame()))
    assert (d["decision"], d["probability"], d["greedy_probability"]) == (c.decision, c.probability, c.choice.p_greedy)
    assert d["target"] == sorted(c.choice.target) and d["noise"] == closed_loop_noise("harsh").to_dict()
    written = json.loads(path.read_text())
    m = c.choice.pm.map
    assert written["metadata"]["carry"] is True and written["metadata"]["stops"] == m.metadata["stops"]
    assert (len(written["states"]), len(written["transitions"])) == (len(m), m.n_transitions) == (d["states"], d["transitions"])
    assert d["greedy_probability"] <= d["probability"] + 1e-12


@needs_storm
def test_cli_export_samples_writes_the_map_plan_robust_chooses_on(clomp, tmp_path):
    """The model a user exports and checks is the one the robust planner and the runtime
    plan on: the same rollouts (supervisor's tolerance, hazard stops, carried poses), the
    same seed, so the same states, transitions and k/N, the plan's metadata aside."""
    import json

    chosen, exported = tmp_path / "chosen.json", tmp_path / "exported.json"
    opts = ("--scenario", "doorway", "--noise", "harsh", "--samples", "8", "--seed", "3")
    assert clomp("plan", *opts, "--robust", "--json", "--map", str(chosen))[0] in (0, 1)
    assert clomp("export", *opts, "-f", "json", "-o", str(exported))[0] == 0
    a, b = json.loads(chosen.read_text()), json.loads(exported.read_text())
    assert b["metadata"]["carry"] is True and b["metadata"]["stops"] == a["metadata"]["stops"]
    assert a["states"] == b["states"] and a["transitions"] == b["transitions"]
    assert any(0 < Fraction(t["probability"]) < 1 for t in b["transitions"])  # a probabilistic map indeed


@needs_storm
def test_cli_check_require_safe_fails_with_a_path_into_a_collision(clomp):
    code, out, _ = clomp(
        # harsh noise: at paper noise the overtaking map (left turn 3π/8 round the box) has
        # no sampled path into a collision any more (safe_goal 1.0)
        "check", "--scenario", "overtaking", "--samples", "20", "--noise", "harsh", "--seed", "0",
        "--specs", str(default_property_files()[0]), "--require-safe", "0.999",
    )
    assert code == 1
    line = next(x for x in out.splitlines() if x.startswith("FAIL safe_goal"))
    assert "required >= 0.999; violating path: q0 ->" in line
    code, out, _ = clomp("check", "--scenario", "open", "--samples", "5", "--require-safe", "0.5")
    assert "safe_goal" in out and "FAIL safe_goal" not in out


@needs_storm
def test_cli_export_learn_from_a_folder_of_recorded_scans(clomp, tmp_path):
    if not SCANS.is_dir():
        pytest.skip("recorded scans not found")
    folder = tmp_path / "scans"
    folder.mkdir()
    for f in sorted(SCANS.glob("*.dat"))[:6]:
        (folder / f.name).write_bytes(f.read_bytes())
    out = tmp_path / "learned.json"
    assert clomp("export", "--scan", str(folder), "--learn", "-f", "json", "-o", str(out))[0] == 0
    m = CognitiveMap.read_json(out)
    assert m.metadata["observations"] == 6
    assert all((t.probability * 6).denominator == 1 or t.probability.denominator <= 6 for t in m.transitions())


def test_cli_export_learn_reads_the_folder_as_plan_does(clomp, tmp_path):
    """--learn goes through the shared folder reader: hidden files (e.g. macOS ``._``
    twins) and other suffixes are not scans, a bad scan is skipped with a warning naming
    it, and a folder with no readable scan is one error."""
    if not SCANS.is_dir():
        pytest.skip("recorded scans not found")
    folder = tmp_path / "scans"
    folder.mkdir()
    for f in sorted(SCANS.glob("*.dat"))[:3]:
        (folder / f.name).write_bytes(f.read_bytes())
    (folder / "._map0001.dat").write_bytes(b"\x00\x05\x16\x07junk")  # AppleDouble twin
    (folder / "notes.md").write_text("not a scan")
    (folder / "zz_broken.dat").write_text("0.5 0.1\nhello world\n")
    out = tmp_path / "learned.json"
    code, stdout, err = clomp("export", "--scan", str(folder), "--learn", "-f", "json", "-o", str(out))
    assert code == 0, err
    assert "zz_broken.dat: skipped" in err and "._map0001" not in err and "Traceback" not in err
    assert CognitiveMap.read_json(out).metadata["observations"] == 3
    for f in folder.glob("*.dat"):
        if not f.name.startswith("._"):
            f.write_text("nan nan\n")
    code, _, err = clomp("export", "--scan", str(folder), "--learn", "-f", "json", "-o", str(out))
    assert code == 2 and "none of its 4 scan files could be read" in err and "Traceback" not in err
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / ".hidden.dat").write_text("0.5 0.0")
    code, _, err = clomp("export", "--scan", str(empty), "--learn", "-f", "json", "-o", str(out))
    assert code == 2 and "no scan files" in err


@pytest.mark.parametrize(
    "argv, message",
    [
        (("export", "--scenario", "doorway", "--samples", "0", "-f", "drn"), "--samples: expected a whole number from 1 to 2,000, got 0"),
        (("export", "--scenario", "doorway", "--samples", "3", "--noise", "bogus", "-f", "drn"), "unknown noise preset 'bogus'"),
        (("export", "--scenario", "doorway", "--learn", "-f", "drn"), "--learn needs --scan FOLDER"),
        (("plan", "--scenario", "doorway", "--samples", "3"), "go with --robust"),
        (("check", "--scenario", "open", "--require-safe", "1.5"), "--require-safe: expected a probability"),
    ],
)
def test_cli_probabilistic_bad_input_is_one_clear_error(clomp, tmp_path, argv, message):
    args = list(argv)
    if args[0] == "export":
        args += ["-o", str(tmp_path / "out")]
    code, _, err = clomp(*args)
    assert code == 2 and message in err and "Traceback" not in err


def test_cli_export_learn_from_a_run_log_uses_the_scans_taken_at_one_pose(clomp, tmp_path):
    import json

    import numpy as np

    from clomp.planner import load_scenario

    scene = load_scenario("overtaking")
    pts = scene.scan(max_range=1.1)
    rng = np.random.default_rng(0)
    log = tmp_path / "run.jsonl"
    with log.open("w") as fh:
        fh.write(json.dumps({"t": 0.0, "event": "run", "argv": []}) + "\n")
        for k in range(7):
            pose = [0.0, 0.0, 0.0] if k < 5 else [0.3, 0.0, 0.0]  # five scans standing, then two elsewhere
            noisy = (pts + rng.normal(0, 0.004, pts.shape)).tolist()
            fh.write(json.dumps({"t": 0.1 * k, "event": "scan", "points": noisy, "goal": list(scene.goal_in_robot_frame()), "pose": pose}) + "\n")
    out = tmp_path / "learned.json"
    code, _, err = clomp("export", "--scan", str(log), "--learn", "-f", "json", "-o", str(out))
    assert code == 0, err
    m = CognitiveMap.read_json(out)
    assert m.metadata["observations"] == 5
    assert all((t.probability * 5).denominator == 1 for t in m.out_transitions(0))
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"t": 0, "event": "run"}\n')
    code, _, err = clomp("export", "--scan", str(bad), "--learn", "-f", "json", "-o", str(out))
    assert code == 2 and "no scan records" in err


# -- the demo's supervisor export and the supervisor's property file ----------------------------------
@needs_storm
def test_cli_check_passes_the_demos_supervisor_export_with_its_property_file(clomp, tmp_path):
    """Before: ``supervisor.prism`` was the machine alone (``driving`` and ``after_fault``
    constant false): ``--specs machine.pctl`` FAILed wheels_only_on_a_task, and without
    ``--specs`` the map's files were tried on it (exit 2)."""
    from clomp.formal.checking import shipped_property_files
    from clomp.runtime.cli.demo import supervisor_closed_loop_prism

    path = tmp_path / "supervisor.prism"
    path.write_text(supervisor_closed_loop_prism())
    machine = next(p for p in shipped_property_files() if p.parent.name == "supervisor")
    for argv in (("--specs", str(machine)), ()):
        code, out, _ = clomp("check", str(path), *argv)
        assert code == 0, out
        assert "wheels_only_on_a_task" in out and "FAIL" not in out and "no_collision" not in out


@needs_storm
def test_cli_check_keeps_storms_cpp_log_off_stdout(tmp_path, capfd):
    """Before: Storm's ``ERROR (SparsePropositionalModelChecker.cpp:46)`` line reached
    stdout (fd 1, under Python's sys.stdout) when a property named an unknown label."""
    import clomp.runtime.cli as cli
    from clomp.runtime.cli.demo import supervisor_closed_loop_prism

    path = tmp_path / "supervisor.prism"
    path.write_text(supervisor_closed_loop_prism())
    unsupervised = next(p for p in default_property_files() if p.name == "unsupervised.pctl")
    capfd.readouterr()
    code = cli.main(["check", str(path), "--specs", str(unsupervised)])
    fd = capfd.readouterr()
    assert code == 2
    assert "unknown label" in fd.err and "Storm" in fd.err
    assert ".cpp" not in fd.out and ".cpp" not in fd.err


# -- exports say what they hold ---------------------------------------------------------------------
def _file_states(path: Path) -> int:
    """The states a written PRISM-language or DRN file holds, read from the file."""
    import re

    text = path.read_text()
    if path.suffix == ".drn":
        return len(re.findall(r"^state \d+", text, re.M))
    return len(set(re.findall(r"^\s*\[\w+\] q=(\d+) ->", text, re.M)))


@pytest.mark.parametrize("kind", ["mdp", "dtmc"])
@pytest.mark.parametrize("fmt", ["prism", "drn"])
def test_cli_export_prints_the_files_state_count(clomp, tmp_path, kind, fmt):
    """Before: ``--model dtmc`` printed the map's 15 states for a file of 6."""
    import re

    path = tmp_path / f"ov.{fmt}"
    code, out, _ = clomp("export", "--scenario", "overtaking", "-f", fmt, "--model", kind, "-o", str(path))
    assert code == 0
    m = re.search(r"(\d+) states?( \+ 1 unreachable label_holder state)?\)$", out.strip())
    assert m, out
    assert int(m.group(1)) + (1 if m.group(2) else 0) == _file_states(path)


@pytest.mark.parametrize("extra", [("--model", "dtmc"), ("--model", "mdp"), ("--policy", "storm")])
def test_cli_export_json_refuses_model_options(clomp, tmp_path, extra):
    """Before: ``-f json --model dtmc`` wrote the same bytes as ``--model mdp``, silently."""
    code, out, err = clomp("export", "--scenario", "open", "-f", "json", *extra, "-o", str(tmp_path / "m.json"))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"clomp: error: {extra[0]} does not apply to -f json")
    assert not (tmp_path / "m.json").exists()


@needs_storm
def test_cli_export_dtmc_fixes_the_plans_or_storms_policy(clomp, tmp_path, risky_map):
    """``--policy plan`` (default) is the best-first plan's DTMC (the short STRAIGHT,
    collision 1 in 5); ``--policy storm`` the DTMC of Storm's scheduler (the detour)."""
    from clomp.formal.checking import load_storm_model

    risky_map.write_json(tmp_path / "risky.json")
    got = {}
    for policy in ("plan", "storm"):
        path = tmp_path / f"{policy}.drn"
        code, out, _ = clomp("export", "--map", str(tmp_path / "risky.json"), "-f", "drn", "--model", "dtmc", "--policy", policy, "-o", str(path))
        assert code == 0, out
        (r,) = check_properties(load_storm_model(path), [PropertySpec('P=? [!"collision" U "goal"]', "safe")])
        got[policy] = r.value
    assert got == pytest.approx({"plan": 0.8, "storm": 1.0}, abs=1e-12)
    assert clomp("export", "--map", str(tmp_path / "risky.json"), "-f", "drn", "--policy", "storm", "-o", str(tmp_path / "x.drn"))[0] == 2
