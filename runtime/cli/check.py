"""``clomp check``: model-check a cognitive map (scenario, scan, map or exported file) with Storm.

Checks every property of the property files (default: specs/properties/*.pctl), prints a
table of property, result and verdict, and exits with status 1 when a required property
fails, naming a path of map states that violates it.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from formal.checking import (
    CheckResult,
    PropertyFile,
    SpecError,
    StormMissing,
    build_storm_model,
    compare_distance,
    default_property_files,
    load_storm_model,
    read_properties,
)
from formal.export import ExportError
from formal.lts import CognitiveMap, MapError
from runtime.cli.export import add_source_options, map_from_args
from runtime.cli.plan import add_planner_options
from runtime.cli import CliError

__all__ = ["register"]


def register(sub: Any) -> None:
    """Add ``check`` to the command line."""
    p = sub.add_parser("check", help="model-check a cognitive map with Storm", description=__doc__)
    add_source_options(p, required=False)
    p.add_argument("file", nargs="?", help="an exported model (.prism or .drn) or a map (.json)")
    p.add_argument("--specs", action="append", metavar="FILE", help="a property file (repeatable; default: specs/properties/*.pctl)")
    p.add_argument("--via", choices=("drn", "prism"), default="drn", help="format handed to Storm for a map (default drn)")
    add_planner_options(p)
    p.set_defaults(func=run)


def _spec_files(args: argparse.Namespace) -> list[PropertyFile]:
    paths = [Path(p) for p in args.specs] if args.specs else default_property_files()
    try:
        return [read_properties(p) for p in paths]
    except SpecError as exc:
        raise CliError(str(exc)) from None


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp check``."""
    sources = [x for x in (args.scenario, args.scan, args.map, args.file) if x]
    if len(sources) != 1:
        raise CliError("give exactly one of --scenario, --scan, --map or a model FILE")
    files = _spec_files(args)
    try:
        if args.file and Path(args.file).suffix != ".json":
            results, title, cmap = _check_file(Path(args.file), files), args.file, None
        else:
            if args.file:
                args.map = args.file
            cmap, title = map_from_args(args)
            results = []
            built = {}
            for pf in files:
                if pf.model not in built:
                    built[pf.model] = build_storm_model(cmap, pf.model, args.via)
                results += _check(built[pf.model], pf)
    except StormMissing as exc:
        raise CliError(str(exc)) from None
    except (SpecError, ExportError, MapError) as exc:
        raise CliError(str(exc)) from None
    _print_table(title, results)
    if cmap is not None:
        _print_distance(cmap, args.via)
    failed = [r for r in results if r.passed is False]
    for r in failed:
        print(f"FAIL {r.spec.name} ({r.kind}): {r.value_text()}, required {r.spec.required}; violating path: {' -> '.join(r.witness)}")
    return 1 if failed else 0


def _check(sm: Any, pf: PropertyFile) -> list[CheckResult]:
    from formal.checking import check_properties

    return check_properties(sm, pf)


def _check_file(path: Path, files: list[PropertyFile]) -> list[CheckResult]:
    sm = load_storm_model(path)
    matching = [pf for pf in files if pf.model == sm.kind]
    if not matching:
        raise CliError(f"{path} is a {sm.kind.upper()}, and no property file is about a {sm.kind}")
    out: list[CheckResult] = []
    for pf in matching:
        out += _check(sm, pf)
    return out


def _print_table(title: str, results: list[CheckResult]) -> None:
    print(f"{title}: {len(results)} properties checked by Storm")
    width = max([8, *(len(r.spec.name) for r in results)])
    print(f"  {'model':<5}  {'property':<{width}}  {'result':>10}  {'required':<9} verdict")
    for r in results:
        req = "" if r.spec.required is None else str(r.spec.required)
        print(f"  {r.kind:<5}  {r.spec.name:<{width}}  {r.value_text():>10}  {req:<9} {r.verdict}")


def _print_distance(cmap: CognitiveMap, via: str) -> None:
    cmp = compare_distance(cmap, via)
    storm = f"{cmp.storm_min:.4g} m" if math.isfinite(cmp.storm_min) else "unreachable"
    goal = "reaches the goal" if cmp.plan_reaches_goal else "does not reach the goal"
    print(
        f"distance: plan {cmp.plan:.4g} m ({goal}); Storm's optimum over the map Rmin[F goal] = {storm}"
        f"{'' if cmp.consistent else '  — INCONSISTENT: the optimum exceeds the plan'}"
    )
