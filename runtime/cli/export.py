"""``clomp export``: write the cognitive map of a scenario, a scan or a map file in a model format."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from collections.abc import Iterator
from typing import Any

from clomp.formal.export import FORMATS, LABEL_HOLDER, ExportError, ExportModel, ModelKind, drn_adds_holder, export_model, induced_model, write
from clomp.formal.lts import MAX_MAP_BYTES, CognitiveMap, MapError
from clomp.formal.retry import loop_model, map_lost, map_offs, map_stops
from clomp.planner import PlanningError, ScanError, scan_files
from clomp.planner.deepening import plan_deepening
from clomp.planner.inputs import InputError, load_json, read_text
from clomp.planner.probabilistic import NoiseError, learn_from_scans
from clomp.runtime.cli.plan import (
    add_planner_options,
    add_sampling_options,
    configurator_from_args,
    parse_goal,
    probabilistic_from_args,
    scenario_scan,
)
from clomp.runtime.cli import EXIT_OK, CliError, plural
from clomp.runtime.cli._common import add_units_option, output_path, path_kind, read_points

__all__ = ["register", "add_source_options", "map_from_args", "export_for", "storm_policy", "add_closed_loop_options",
           "check_closed_loop_options", "replans_of", "closed_loop_model"]


MAX_REPLANS = 20
"""The most replans ``--replans`` takes: the model grows by a copy of the map per replan."""


def add_source_options(p: argparse.ArgumentParser, required: bool = True) -> None:
    """--scenario | --scan | --map, and --goal: where the cognitive map comes from."""
    src = p.add_mutually_exclusive_group(required=required)
    src.add_argument("--scenario", help="a built-in scenario name or a scenario JSON file")
    src.add_argument("--scan", help="a scan file (x y per line, or .npy); with --learn, a folder of consecutive scans or a run log")
    src.add_argument("--map", metavar="JSON", help="a cognitive map written by 'clomp plan --map' or 'export --format json'")
    p.add_argument("--goal", help="goal X,Y in the robot frame (metres); default: the scenario's, or 1.0,0.0")
    add_units_option(p)
    add_sampling_options(p)


def map_from_args(args: argparse.Namespace) -> tuple[CognitiveMap, str]:
    """Plan (or read) the cognitive map the source options name; returns (map, title)."""
    if getattr(args, "map", None):
        try:  # the input layer: no FIFO, device or oversized file; JSON depth and numbers limited
            data = load_json(read_text(args.map, "map file", MAX_MAP_BYTES), str(args.map))
            return CognitiveMap.from_dict(data), str(args.map)
        except InputError as exc:
            raise CliError(f"--map: {exc}") from None
        except MapError as exc:
            raise CliError(f"--map: {args.map}: {exc}") from None
    conf = configurator_from_args(args)
    units = getattr(args, "units", None)
    if units and not getattr(args, "scan", None):
        raise CliError("--units gives the units of the scans read with --scan; a scenario or a map is in metres")
    samples = getattr(args, "samples", None)
    learn = getattr(args, "learn", False)
    if learn and samples:
        raise CliError("--learn learns from recorded scans; --samples samples rollouts: give one of them")
    try:
        if args.scenario:
            if learn:
                raise CliError("--learn needs --scan FOLDER (consecutive scans of a recorded run)")
            title, goal, scan = scenario_scan(args, conf)
            if samples is not None:
                return probabilistic_from_args(args, conf, scan, goal).map, title
            return plan_deepening(conf, scan, goal).map, title
        path = Path(args.scan)
        goal = parse_goal(args.goal) if args.goal else (1.0, 0.0)
        kind = path_kind(path, "--scan")
        if learn and kind == "file":
            standing, log_goal = _standing_scans(path)
            standing = [read_points(pts, units) for pts in standing]
            g = parse_goal(args.goal) if args.goal else log_goal
            return learn_from_scans(standing, g, conf), f"{path} ({len(standing)} scans taken at one pose)"
        if learn:
            if kind != "folder":
                raise CliError(f"--scan: {path}: --learn needs a folder of scans or a run log (.jsonl)")
            files = scan_files(path)  # the shared folder reader: suffixes, hidden files, unreadable folders
            used: list[Path] = []
            cmap = learn_from_scans(_readable_scans(files, used, units), goal, conf)
            skipped = len(files) - len(used)
            return cmap, f"{path} ({plural(len(used), 'scan')}{f', {skipped} skipped' if skipped else ''})"
        if kind == "missing":
            raise CliError(f"--scan: {path}: no such file")
        points = read_points(path, units)
        if samples is not None:
            return probabilistic_from_args(args, conf, points, goal).map, str(path)
        return plan_deepening(conf, points, goal).map, str(path)
    except (ScanError, PlanningError, NoiseError) as exc:
        raise CliError(str(exc)) from None


def _readable_scans(files: list[Path], used: list[Path], units: str | None = None) -> Iterator[Any]:
    """The scans of ``files`` read one by one as they are consumed (with a bar on a
    terminal), in metres (``units``; one that looks like millimetres without them is one
    error); a file that is not a scan is skipped with one warning line naming it, as
    folder runs of ``clomp plan`` do, and the files read are appended to ``used``. No
    readable scan at all is one error."""
    from clomp.runtime.cli._progress import progress

    bar = progress(files, desc="learn", unit="scan")
    for f in bar:
        try:
            points = read_points(f, units, f"--scan: {f.name}")
        except ScanError as exc:
            bar.write(f"warning: {f.name}: skipped: {exc}", file=sys.stderr)
            continue
        used.append(f)
        yield points
    if not used:
        raise CliError(f"--scan: {files[0].parent}: none of its {plural(len(files), 'scan file')} could be read")


def _standing_scans(path: Path) -> tuple[list[Any], tuple[float, float]]:
    """The longest run of consecutive scans of a run log taken at one pose (the robot
    standing: within 1 cm and 0.02 rad), and their goal in the robot frame: repeated
    observations of one situation, from which :func:`learn_from_scans` learns."""
    import math

    import numpy as np

    from clomp.runtime.records.runlog import LogError, read_log

    groups: list[list[tuple[Any, tuple[float, float]]]] = []
    last: list[float] | None = None
    try:
        for rec in read_log(path):
            if rec.get("event") != "scan":
                continue
            pose, goal = rec.get("pose"), rec.get("goal")
            if not (isinstance(pose, list) and len(pose) == 3 and isinstance(goal, list) and len(goal) == 2):
                continue
            pts = np.asarray(rec.get("points", []), dtype=float).reshape(-1, 2)
            same = last is not None and math.hypot(pose[0] - last[0], pose[1] - last[1]) <= 0.01 and abs(pose[2] - last[2]) <= 0.02
            if not same:
                groups.append([])
            groups[-1].append((pts, (float(goal[0]), float(goal[1]))))
            last = [float(v) for v in pose]
    except (LogError, OSError, ValueError) as exc:
        raise CliError(f"--scan: {path}: not a run log with scans: {exc}") from None
    if not groups:
        raise CliError(f"--scan: {path}: the run log has no scan records with a pose and a goal")
    best = max(groups, key=len)
    return [pts for pts, _ in best], best[0][1]


def register(sub: Any) -> None:
    """Add ``export`` to the command line."""
    p = sub.add_parser("export", help="export a cognitive map to PRISM, Storm DRN, DOT/SVG or JSON", description=__doc__)
    add_source_options(p)
    p.add_argument("--format", "-f", required=True, choices=sorted(FORMATS), help="output format")
    p.add_argument(
        "--model",
        choices=("mdp", "dtmc"),
        default=None,
        help="mdp: the unsupervised map (actions are tasks); dtmc: the supervised system, one task per state "
        "(default mdp; not for -f json, which is the map itself)",
    )
    p.add_argument(
        "--policy",
        choices=("plan", "storm"),
        default=None,
        help="with --model dtmc, whose task each state takes: plan (the map's own plan ρ with the guard Ψ; every "
        "state off ρ is absorbing; the default) or storm (Storm's optimal scheduler for "
        'Pmax=? [!"collision" U "goal"] on the map\'s MDP, a task in every state it reaches)',
    )
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="output file ('-' for standard output; a path stem for prism-explicit)")
    add_closed_loop_options(p)
    add_planner_options(p)
    p.set_defaults(func=run)


def add_closed_loop_options(p: argparse.ArgumentParser) -> None:
    """--closed-loop and --replans: the model of the closed loop (``export`` and ``check``)."""
    p.add_argument(
        "--closed-loop",
        action="store_true",
        help="with --samples: the model of the closed loop: a rollout the supervisor's check would interrupt before a "
        "contact is an 'interrupted' outcome replanned from (action retry), not a collision; labels interrupted and "
        "gave_up; properties in specs/properties/closed_loop/",
    )
    p.add_argument("--replans", type=int, metavar="N", default=None,
                   help="with --closed-loop: replans after an interruption before the run gives up (default 1, as the robust planner's objective)")


def check_closed_loop_options(args: argparse.Namespace, from_map: bool = False) -> None:
    """--closed-loop needs a probabilistic map (--samples, or with ``from_map`` a map
    file, whose stops and offs are its metadata's); --replans needs --closed-loop and
    lies in 0 … :data:`MAX_REPLANS`."""
    if args.closed_loop and args.samples is None and not from_map:
        raise CliError("--closed-loop models the rollouts of a probabilistic map: give --samples N")
    if args.replans is not None:
        if not args.closed_loop:
            raise CliError("--replans applies to --closed-loop (the replans after an interruption)")
        if not 0 <= args.replans <= MAX_REPLANS:
            raise CliError(f"--replans: expected a whole number from 0 to {MAX_REPLANS}, got {args.replans}")


def replans_of(args: argparse.Namespace) -> int:
    """The replans of the closed loop's model: ``--replans``, default 1."""
    return 1 if args.replans is None else int(args.replans)


def closed_loop_model(m: ExportModel, cmap: CognitiveMap, replans: int) -> ExportModel:
    """The closed loop's model of the export ``m`` of ``cmap``: its stops and offs (the
    map's metadata) replanned from ``replans`` times, its lost states (a push left the
    estimate off the truth) labelled (:func:`clomp.formal.retry.loop_model`)."""
    return loop_model(m, map_stops(cmap.metadata), replans, map_offs(cmap.metadata), map_lost(cmap.metadata))


def _check_model_options(args: argparse.Namespace) -> None:
    """An option that does not apply to the format or model is an error, not ignored."""
    if args.format == "json" and (args.model is not None or args.policy is not None):
        given = "--model" if args.model is not None else "--policy"
        raise CliError(f"{given} does not apply to -f json: JSON is the map itself (export a model with -f prism, drn, prism-explicit, dot or svg)")
    if args.policy is not None and args.model != "dtmc":
        raise CliError("--policy applies to --model dtmc (an MDP leaves every choice to the model checker)")
    check_closed_loop_options(args)
    if args.replans is not None and args.format == "json":
        raise CliError("--replans does not apply to -f json: JSON is the map itself (its stops named in its metadata)")
    if args.closed_loop and args.policy == "storm":
        raise CliError("--closed-loop with --policy storm is not supported: export the MDP (--model mdp) and let the "
                       "model checker choose, or the plan's DTMC (--model dtmc)")


def export_for(cmap: CognitiveMap, kind: ModelKind, policy: str | None) -> ExportModel:
    """The model ``clomp export`` writes: the MDP, the DTMC of the map's plan, or the DTMC
    Storm's optimal scheduler induces (``policy="storm"``; its ``plan`` label is the path
    the scheduler starts on)."""
    if policy != "storm":
        return export_model(cmap, kind)
    return storm_policy(cmap)[1]


def storm_policy(cmap: CognitiveMap) -> tuple[Any, ExportModel]:
    """Storm's optimal scheduler for ``Pmax=? [!"collision" U "goal"]`` on the map's MDP
    (a :class:`~clomp.formal.scheduler.RobustPlan`) and the DTMC it induces."""
    from clomp.formal.checking import StormMissing
    from clomp.formal.scheduler import robust_plan

    try:
        best = robust_plan(cmap)
    except StormMissing as exc:
        raise CliError(str(exc)) from None
    choose = {ident: task.value for ident, task in best.scheduler.items()}
    return best, induced_model(export_model(cmap, "mdp", best.plan), choose, "Storm's scheduler for Pmax [!collision U goal]")


def _states_written(m: ExportModel | None, cmap: CognitiveMap, fmt: str) -> str:
    """How many states the written file holds (the map's for JSON, the model's otherwise;
    a DRN's unreachable label holder is named)."""
    if m is None:
        return plural(len(cmap), "map state")
    if fmt == "drn" and drn_adds_holder(m):
        return f"{plural(m.n_states, 'state')} + 1 unreachable {LABEL_HOLDER} state"
    return plural(m.n_states, "state")


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp export``."""
    _check_model_options(args)
    if args.output == "-":
        if args.format == "prism-explicit":
            raise CliError("prism-explicit writes several files: give a path stem with -o")
        dest: Any = sys.stdout
    else:
        dest = Path(args.output)
        if args.format != "prism-explicit":
            output_path(dest, "-o")  # before any work: no device, FIFO or read-only file
        elif not dest.parent.is_dir():
            raise CliError(f"-o: folder {dest.parent} does not exist")
    cmap, _ = map_from_args(args)
    kind: ModelKind = args.model or "mdp"
    started = time.time()
    m = None
    try:
        if args.format == "json":
            write(cmap, dest, "json")
        else:
            m = export_for(cmap, kind, args.policy)
            if args.closed_loop:
                m = closed_loop_model(m, cmap, replans_of(args))
            FORMATS[args.format](m, dest, kind)
    except (ExportError, MapError) as exc:  # MapError: a map file whose metadata is inconsistent
        raise CliError(str(exc)) from None
    except OSError as exc:
        raise CliError(f"cannot write {args.output}: {exc.strerror or exc}") from None
    if args.output != "-":
        # say what was written (with -o - the model itself is on standard output: nothing else is)
        if args.format == "prism-explicit":
            files = sorted(str(f) for f in dest.parent.glob(f"{dest.name}.*")
                           if f.is_file() and f.stat().st_mtime >= started - 1.0)  # this run's, not older ones
        else:
            files = [str(dest)]
        what = "the map" if m is None else kind if m.policy == "plan" else f"{kind} under {m.policy}"
        if args.closed_loop:
            what += ", closed loop" if m is None else f", closed loop with {plural(replans_of(args), 'replan')}"
        print(f"wrote {', '.join(files)} ({args.format}, {what}, {_states_written(m, cmap, args.format)})")
    return EXIT_OK
