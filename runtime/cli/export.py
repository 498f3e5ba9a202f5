"""``clomp export``: write the cognitive map of a scenario, a scan or a map file in a model format."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from collections.abc import Iterator
from typing import Any

from clomp.formal.export import FORMATS, ExportError, write
from clomp.formal.lts import CognitiveMap, MapError
from clomp.planner import PlanningError, ScanError, load_scan, scan_files
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

__all__ = ["register", "add_source_options", "map_from_args"]


def add_source_options(p: argparse.ArgumentParser, required: bool = True) -> None:
    """--scenario | --scan | --map, and --goal: where the cognitive map comes from."""
    src = p.add_mutually_exclusive_group(required=required)
    src.add_argument("--scenario", help="a built-in scenario name or a scenario JSON file")
    src.add_argument("--scan", help="a scan file (x y per line, or .npy); with --learn, a folder of consecutive scans or a run log")
    src.add_argument("--map", metavar="JSON", help="a cognitive map written by 'clomp plan --map' or 'export --format json'")
    p.add_argument("--goal", help="goal X,Y in the robot frame (metres); default: the scenario's, or 1.0,0.0")
    add_sampling_options(p)


def map_from_args(args: argparse.Namespace) -> tuple[CognitiveMap, str]:
    """Plan (or read) the cognitive map the source options name; returns (map, title)."""
    if getattr(args, "map", None):
        try:
            return CognitiveMap.read_json(args.map), str(args.map)
        except OSError as exc:
            raise CliError(f"--map: cannot read {args.map}: {exc.strerror or exc}") from None
        except MapError as exc:
            raise CliError(f"--map: {args.map}: {exc}") from None
    conf = configurator_from_args(args)
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
            return conf.plan(scan, goal).map, title
        path = Path(args.scan)
        goal = parse_goal(args.goal) if args.goal else (1.0, 0.0)
        if learn and path.is_file():
            standing, log_goal = _standing_scans(path)
            g = parse_goal(args.goal) if args.goal else log_goal
            return learn_from_scans(standing, g, conf), f"{path} ({len(standing)} scans taken at one pose)"
        if learn:
            if not path.exists() or path.is_file():
                raise CliError(f"--scan: {path}: --learn needs a folder of scans or a run log (.jsonl)")
            files = scan_files(path)  # the shared folder reader: suffixes, hidden files, unreadable folders
            used: list[Path] = []
            cmap = learn_from_scans(_readable_scans(files, used), goal, conf)
            skipped = len(files) - len(used)
            return cmap, f"{path} ({plural(len(used), 'scan')}{f', {skipped} skipped' if skipped else ''})"
        if not path.is_file():
            raise CliError(f"--scan: {path}: no such file")
        if samples is not None:
            return probabilistic_from_args(args, conf, path, goal).map, str(path)
        return conf.plan(path, goal).map, str(path)
    except (ScanError, PlanningError, NoiseError) as exc:
        raise CliError(str(exc)) from None


def _readable_scans(files: list[Path], used: list[Path]) -> Iterator[Any]:
    """The scans of ``files`` read one by one as they are consumed (with a bar on a
    terminal); a file that is not a scan is skipped with one warning line naming it, as
    folder runs of ``clomp plan`` do, and the files read are appended to ``used``. No
    readable scan at all is one error."""
    from clomp.runtime.cli._progress import progress

    bar = progress(files, desc="learn", unit="scan")
    for f in bar:
        try:
            points = load_scan(f)
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
        default="mdp",
        help="mdp: the unsupervised map (actions are tasks); dtmc: the supervised system, Ψ applied (default mdp)",
    )
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="output file ('-' for standard output; a path stem for prism-explicit)")
    add_planner_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp export``."""
    cmap, _ = map_from_args(args)
    if args.output == "-":
        if args.format == "prism-explicit":
            raise CliError("prism-explicit writes several files: give a path stem with -o")
        dest: Any = sys.stdout
    else:
        dest = Path(args.output)
        if dest.parent and not dest.parent.exists():
            raise CliError(f"-o: folder {dest.parent} does not exist")
    started = time.time()
    try:
        write(cmap, dest, args.format, args.model)
    except ExportError as exc:
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
        print(f"wrote {', '.join(files)} ({args.format}, {args.model}, {plural(len(cmap), 'state')})")
    return EXIT_OK
