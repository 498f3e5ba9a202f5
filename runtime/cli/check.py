"""``clomp check``: model-check a cognitive map (scenario, scan, map or exported file)
with Storm, PRISM or both.

Checks every property of the property files (default: specs/properties/*.pctl), prints a
table of property, result and verdict, and exits with status 1 when a required property
fails, naming a path of map states that violates it (Storm finds the path), or, with
``--tool both``, when the two tools disagree (by more than 1e-9). With ``--samples N
--closed-loop [--replans N]`` the properties are checked on the closed loop's model of
the probabilistic map, as ``clomp export --closed-loop`` writes it (default files:
specs/properties/closed_loop/); ``--scheduler``/``--induced`` then write Storm's scheduler
of that model (a task, or ``retry`` at a stop, per map state and replans used) and the
DTMC it induces.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from clomp.formal.checking import (
    CheckResult,
    PropertyFile,
    PropertySpec,
    Requirement,
    SpecError,
    StormMissing,
    build_storm_model,
    closed_loop_property_files,
    compare_distance,
    default_property_files,
    file_labels,
    load_storm_model,
    meant_for,
    parse_properties,
    shipped_property_files,
)
from clomp.formal.crosscheck import values_agree
from clomp.formal.export import ExportError, ExportModel, ModelKind, export_model
from clomp.formal.scheduler import SAFE_GOAL
from clomp.formal.prism import PrismError, PrismMissing, check_with_prism, run_prism
from clomp.formal.lts import CognitiveMap, MapError
from clomp.runtime.cli.export import (
    add_closed_loop_options,
    add_source_options,
    check_closed_loop_options,
    closed_loop_model,
    map_from_args,
    replans_of,
)
from clomp.runtime.cli.plan import add_planner_options
from clomp.runtime.cli import CliError
from clomp.runtime.cli._common import path_kind
from clomp.planner.inputs import read_text

__all__ = ["register"]


def register(sub: Any) -> None:
    """Add ``check`` to the command line."""
    p = sub.add_parser("check", help="model-check a cognitive map with Storm and/or PRISM", description=__doc__)
    add_source_options(p, required=False)
    p.add_argument("file", nargs="?", help="an exported model (.prism or .drn) or a map (.json)")
    p.add_argument("--specs", action="append", metavar="FILE", help="a property file (repeatable; default: specs/properties/*.pctl)")
    p.add_argument("--via", choices=("drn", "prism"), default="drn", help="format handed to Storm for a map (default drn)")
    p.add_argument(
        "--require-safe",
        type=float,
        metavar="P",
        help='also require Pmax=? [!"collision" U "goal"] >= P on the MDP (reaching the goal without a collision; '
        "with --samples on a probabilistic map); a failure names a path into a state that misses it",
    )
    p.add_argument(
        "--tool",
        choices=("storm", "prism", "both"),
        default="storm",
        help="model checker: Storm (stormpy), PRISM (the PRISM language; $CLOMP_PRISM or shared/tools) or both side by side (default storm)",
    )
    p.add_argument("--scheduler", metavar="FILE", help='write Storm\'s optimal scheduler for Pmax=? [!"collision" U "goal"] as JSON '
                   "(per map state: pose, task, the chosen task; with --closed-loop per state of the closed loop's model: "
                   "its map state, replans used, pose, task, the chosen task or retry); needs a map, not a model file")
    p.add_argument("--induced", metavar="FILE", help="write the DTMC that scheduler induces: FILE.drn, FILE.prism (or .pm), "
                   "or PRISM's explicit files for a name without suffix")
    p.add_argument("--witness", metavar="FILE", help="write the violating path of each failed property as JSON (states, actions, labels)")
    add_closed_loop_options(p)
    add_planner_options(p)
    p.set_defaults(func=run)


def _write_json(path: str, data: Any, option: str) -> None:
    try:
        Path(path).write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    except OSError as exc:
        raise CliError(f"{option}: cannot write {path}: {exc.strerror or exc}") from None


def _write_policy(args: argparse.Namespace, cmap: CognitiveMap | None) -> None:
    """``--scheduler`` and ``--induced``: Storm's scheduler of the map (with
    ``--closed-loop``: of the closed loop's model, a task or ``retry`` per map state ×
    replans used) and the DTMC it induces."""
    if not (args.scheduler or args.induced):
        return
    if cmap is None:
        raise CliError("--scheduler/--induced need a map (--scenario, --scan, --map or a .json FILE): a model file has no poses or tasks")
    from clomp.formal.export import write_drn, write_prism, write_prism_explicit

    record, induced = _closed_loop_policy(args, cmap) if args.closed_loop else _map_policy(cmap)
    if args.scheduler:
        _write_json(args.scheduler, record, "--scheduler")
    if args.induced:
        path = Path(args.induced)
        writer = {".drn": write_drn, ".prism": write_prism, ".pm": write_prism, "": write_prism_explicit}.get(path.suffix)
        if writer is None:
            raise CliError(f"--induced: {path}: give a .drn or .prism file, or a name without suffix for PRISM's explicit files")
        try:
            writer(induced, path)
        except OSError as exc:
            raise CliError(f"--induced: cannot write {path}: {exc.strerror or exc}") from None


def _map_policy(cmap: CognitiveMap) -> tuple[dict[str, Any], ExportModel]:
    from clomp.formal.scheduler import scheduler_record
    from clomp.runtime.cli.export import storm_policy

    best, induced = storm_policy(cmap)
    return scheduler_record(cmap, best), induced


def _closed_loop_policy(args: argparse.Namespace, cmap: CognitiveMap) -> tuple[dict[str, Any], ExportModel]:
    """Storm's scheduler for ``Pmax=? [!"collision" U "goal"]`` on the closed loop's MDP
    (the one the closed loop's properties are checked on) and its induced DTMC."""
    from clomp.formal.export import induced_model
    from clomp.formal.scheduler import model_policy, model_scheduler_record

    base = export_model(cmap, "mdp")
    replans = replans_of(args)
    m = closed_loop_model(base, cmap, replans)
    best = model_policy(m)
    record = {"model": f"closed loop, {replans} replan{'' if replans == 1 else 's'}", "replans": replans,
              **model_scheduler_record(m, best, span=max(s.ident for s in base.states) + 1)}
    return record, induced_model(m, best.choose, f"Storm's scheduler for {best.formula} on the closed loop")


def _witness_record(title: str, failed: list[CheckResult], cmap: CognitiveMap | None) -> dict[str, Any]:
    """The violated properties with their paths (Storm's), actions named from the map's
    transitions where the model's choices carry no name."""
    tasks = None if cmap is None else {(t.source, t.target): t.label.value for t in cmap.transitions()}
    out = []
    for r in failed:
        trace = [dict(x) for x in r.trace]
        for a, b in zip(trace, trace[1:]):
            if a["action"] is None and tasks is not None:
                a["action"] = tasks.get((a["ident"], b["ident"]))
        value: Any = r.value if isinstance(r.value, bool) or math.isfinite(r.value) else str(r.value)
        out.append({"property": r.spec.name, "formula": r.spec.formula, "model": r.kind, "value": value,
                    "required": str(r.spec.required), "path": trace})
    return {"model": title, "tool": "Storm", "violated": out}


def _spec_files(args: argparse.Namespace) -> list[PropertyFile]:
    """The property files to check: ``--specs``; else, for a model FILE, every shipped file
    (the supervisor's too: :func:`_matching` keeps those whose labels the file has); else
    the cognitive maps' files."""
    model_file = bool(args.file) and Path(args.file).suffix != ".json"
    if args.specs:
        paths = [Path(p) for p in args.specs]
    elif args.closed_loop:
        paths = closed_loop_property_files()
    else:
        paths = shipped_property_files() if model_file else default_property_files()
    try:
        # the input layer: a FIFO, device or oversized file is refused before it is read
        files = [parse_properties(read_text(p, "property file", MAX_SPEC_BYTES, SpecError), str(p)) for p in paths]
    except SpecError as exc:
        raise CliError(str(exc)) from None
    p = args.require_safe
    if p is not None:
        if not (math.isfinite(p) and 0 <= p <= 1):
            raise CliError(f"--require-safe: expected a probability in [0, 1], got {p}")
        spec = PropertySpec(
            f"Pmax=? [{SAFE_GOAL}]",
            "safe_goal",
            "the best probability of reaching the goal without a collision",
            Requirement(">=", p),
        )
        files.append(PropertyFile("mdp", (spec,), "--require-safe"))
    return files


def _check_sources(args: argparse.Namespace) -> None:
    """Exactly one source, and a model FILE that is a file (a FIFO would block its reader)."""
    sources = [x for x in (args.scenario, args.scan, args.map, args.file) if x]
    if len(sources) != 1:
        raise CliError("give exactly one of --scenario, --scan, --map or a model FILE")
    model_file = bool(args.file) and Path(args.file).suffix != ".json"
    if model_file and path_kind(Path(args.file), "FILE") == "other":
        raise CliError(f"{args.file}: not a regular file (a FIFO, device or socket)")
    if args.closed_loop and model_file:
        raise CliError(f"--closed-loop builds the closed loop's model of a map; {args.file} is a model already "
                       "(write one with 'clomp export --samples N --closed-loop')")
    check_closed_loop_options(args, from_map=bool(args.map or args.file))


#: a property file holds at most this many bytes
MAX_SPEC_BYTES = 1024 * 1024


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp check``."""
    _check_sources(args)
    files = _spec_files(args)
    chosen = bool(args.specs)
    if args.witness and args.tool == "prism":
        raise CliError("--witness: Storm finds the violating paths: use --tool storm or both")
    use_storm, use_prism = args.tool in ("storm", "both"), args.tool in ("prism", "both")
    try:
        if args.file and Path(args.file).suffix != ".json":
            path, cmap, title = Path(args.file), None, args.file
            storm = _check_file(path, files, chosen) if use_storm else []
            prism = _prism_file(path, files, chosen) if use_prism else []
        else:
            if args.file:
                args.map = args.file
            cmap, title = map_from_args(args)
            if args.closed_loop:
                title += f" (closed loop, {replans_of(args)} replan{'' if replans_of(args) == 1 else 's'})"
            storm, prism = _check_map(_models(cmap, args), files, args.via, use_storm, use_prism)
        _write_policy(args, cmap)
    except (StormMissing, PrismMissing) as exc:
        raise CliError(str(exc)) from None
    except (SpecError, ExportError, MapError, PrismError) as exc:
        raise CliError(str(exc)) from None
    results = storm or prism
    _print_table(title, results, prism if storm and prism else None, args.tool)
    if cmap is not None and use_storm and args.samples is None:  # a sampled map's Rmin[F goal] is infinite unless sure
        _print_distance(cmap, args.via)
    failed = [r for r in results if r.passed is False]
    if storm and prism:
        failed += [q for r, q in zip(storm, prism) if q.passed is False and r.passed is not False]
    if args.witness:
        _write_json(args.witness, _witness_record(title, [r for r in storm if r.passed is False], cmap), "--witness")
    return 1 if _report(failed, storm, prism) else 0


def _models(cmap: CognitiveMap, args: argparse.Namespace) -> Any:
    """The model of each kind that the map's properties are checked on: the map's export,
    or with ``--closed-loop`` the closed loop's model of it (``--replans``)."""
    made: dict[str, ExportModel] = {}

    def model(kind: ModelKind) -> ExportModel:
        if kind not in made:
            m = export_model(cmap, kind)
            made[kind] = closed_loop_model(m, cmap, replans_of(args)) if args.closed_loop else m
        return made[kind]

    return model


def _check_map(model: Any, files: list[PropertyFile], via: str, use_storm: bool, use_prism: bool) -> tuple[list[CheckResult], list[CheckResult]]:
    """Storm's and PRISM's results for every property file on ``model(kind)``, the model
    of its kind (:func:`_models`)."""
    storm: list[CheckResult] = []
    prism: list[CheckResult] = []
    built: dict[str, Any] = {}
    for pf in files:
        if use_storm:
            if pf.model not in built:
                built[pf.model] = build_storm_model(model(pf.model), pf.model, via)
            storm += _check(built[pf.model], pf)
        if use_prism:
            prism += _prism_results(check_with_prism(model(pf.model), _named(pf), pf.model), pf, pf.model)
    return storm, prism


def _report(failed: list[CheckResult], storm: list[CheckResult], prism: list[CheckResult]) -> bool:
    """Print a FAIL line per failed property and a DISAGREE line per property the tools
    disagree on; whether there was any."""
    for r in failed:
        path_text = f"violating path: {' -> '.join(r.witness)}" if r.witness else "run with --tool storm for a violating path"
        print(f"FAIL {r.spec.name} ({r.kind}): {r.value_text()}, required {r.spec.required}; {path_text}")
    disagree = []
    if storm and prism:
        disagree = [(r, q) for r, q in zip(storm, prism) if not values_agree(r.value, q.value)]
        for r, q in disagree:
            print(f"DISAGREE {r.spec.name} ({r.kind}): Storm {r.value!r}, PRISM {q.value!r}")
    return bool(failed or disagree)


def _named(pf: PropertyFile) -> list[str]:
    """The properties as the file names them (``"name": formula``): PRISM then sees what a
    user's run of PRISM on the property file sees, e.g. a name that clashes with a label."""
    return [f'"{p.name}": {p.formula}' if p.name != p.formula else p.formula for p in pf.properties]


def _matching(path: Path, kind: str, files: list[PropertyFile], chosen: bool) -> list[PropertyFile]:
    """The property files about a ``kind`` model; unless the user chose them (``--specs``),
    only those meant for the labels the model file declares (:func:`~clomp.formal.checking.meant_for`:
    a map's files for a map, the closed loop's for the closed loop's model, the
    supervisor's for the supervisor)."""
    labels = file_labels(path)
    matching = [pf for pf in files if pf.model == kind and (chosen or pf.source == "--require-safe" or meant_for(pf, kind, labels))]
    if not any(pf.source != "--require-safe" for pf in matching):
        raise CliError(f"{path} is a {kind.upper()}, and no property file is about a {kind} with its labels ({', '.join(sorted(labels))}): give one with --specs")
    return matching


def _prism_results(res: Any, pf: PropertyFile, kind: Any) -> list[CheckResult]:
    out = []
    for spec, value in zip(pf.properties, res.values):
        passed = None if spec.required is None else spec.required.holds(value)
        out.append(CheckResult(spec, kind, value, passed))
    return out


def _prism_file(path: Path, files: list[PropertyFile], chosen: bool) -> list[CheckResult]:
    if path.suffix not in (".prism", ".pm", ".nm"):
        raise CliError(f"{path}: PRISM reads the PRISM language (.prism .pm .nm); export one with --format prism, or use --tool storm")
    if not path.is_file():
        raise CliError(f"{path}: no such file")
    first = next((w for line in path.read_text(encoding="utf-8", errors="replace").splitlines() if (w := line.split("//")[0].strip())), "")
    kind = first if first in ("mdp", "dtmc") else None
    if kind is None:
        raise CliError(f"{path}: not a PRISM model of kind mdp or dtmc (first statement {first!r})")
    out: list[CheckResult] = []
    for pf in _matching(path, kind, files, chosen):
        out += _prism_results(run_prism([str(path.resolve())], _named(pf)), pf, kind)  # PRISM runs in a temporary folder
    return out


def _check(sm: Any, pf: PropertyFile) -> list[CheckResult]:
    from clomp.formal.checking import check_properties

    return check_properties(sm, pf)


def _check_file(path: Path, files: list[PropertyFile], chosen: bool) -> list[CheckResult]:
    sm = load_storm_model(path)
    out: list[CheckResult] = []
    for pf in _matching(path, sm.kind, files, chosen):
        out += _check(sm, pf)
    return out


def _print_table(title: str, results: list[CheckResult], prism: list[CheckResult] | None, tool: str) -> None:
    by = {"storm": "Storm", "prism": "PRISM", "both": "Storm and PRISM"}[tool]
    print(f"{title}: {len(results)} properties checked by {by}")
    width = max([8, *(len(r.spec.name) for r in results)])
    head = f"{'Storm':>10}  {'PRISM':>10}" if prism else f"{'result':>10}"
    print(f"  {'model':<5}  {'property':<{width}}  {head}  {'required':<9} verdict")
    for k, r in enumerate(results):
        req = "" if r.spec.required is None else str(r.spec.required)
        verdict = r.verdict
        values = f"{r.value_text():>10}"
        if prism:
            q = prism[k]
            values += f"  {q.value_text():>10}"
            if q.passed is False:
                verdict = "FAIL"
            if not values_agree(r.value, q.value):
                verdict += " DISAGREE"
        print(f"  {r.kind:<5}  {r.spec.name:<{width}}  {values}  {req:<9} {verdict}")


def _print_distance(cmap: CognitiveMap, via: str) -> None:
    cmp = compare_distance(cmap, via)
    storm = f"{cmp.storm_min:.4g} m" if math.isfinite(cmp.storm_min) else "unreachable"
    goal = "reaches the goal" if cmp.plan_reaches_goal else "does not reach the goal"
    print(
        f"distance: plan {cmp.plan:.4g} m ({goal}); Storm's optimum over the map Rmin[F goal] = {storm}"
        f"{'' if cmp.consistent else '  — INCONSISTENT: the optimum exceeds the plan'}"
    )
