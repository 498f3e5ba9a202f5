"""``clomp demo``: the main job on a built-in scenario (the paper's overtaking)."""

from __future__ import annotations

import argparse
from typing import Any

from planner import Configurator, load_scenario
from runtime._cli_plan import _print_readable

__all__ = ["register"]


def register(sub: Any) -> None:
    """Add ``demo`` to the command line."""
    p = sub.add_parser("demo", help="plan the built-in overtaking scenario and show the plan")
    p.add_argument("--scenario", default="overtaking", help="built-in scenario (default overtaking)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Plan the scenario and print the plan."""
    scene = load_scenario(args.scenario)
    r = Configurator().plan(scene.scan(), tuple(scene.goal_in_robot_frame()))  # type: ignore[arg-type]
    _print_readable(r, f"demo — {scene.name}")
    return 0
