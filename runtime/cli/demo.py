"""``clomp demo``: the main job — the paper's overtaking scenario planned, executed on the
simulated robot, summarised on one screen, with the trajectory, the first plan's explored
task tree (the paper's Fig. 3C) and the cognitive map written to an output folder."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from clomp.planner.scenarios import ScenarioError
from clomp.runtime.cli._args import seed_arg
from clomp.runtime.cli import CliError
from clomp.runtime.cli._common import load_scene, output_folder, scene_movers
from clomp.runtime.experiment.onerun import run_once
from clomp.runtime.experiment.plots import plot_run
from clomp.runtime.experiment.tasktree import plot_task_tree
from clomp.runtime.supervision.states import state_machine_dot

__all__ = ["register", "run", "write_map", "supervisor_closed_loop_prism"]


def register(sub: Any) -> None:
    """Add ``demo`` to the command line."""
    p = sub.add_parser("demo", help="plan and execute the overtaking scenario on the simulated robot", description=__doc__)
    p.add_argument("--scenario", default="overtaking", help="built-in scenario name or JSON file (default overtaking)")
    p.add_argument("--seed", type=seed_arg, default=None, help="noise seed (default: the scenario's 'seed', else 0)")
    p.add_argument("--out", default="clomp-demo-out", help="output folder (default ./clomp-demo-out)")
    from clomp.runtime.cli.simulate import add_world_options

    add_world_options(p)
    p.set_defaults(func=run)


def write_map(cmap: Any, folder: Path, stem: str = "cognitive_map") -> list[str]:
    """Write the map as JSON, and as DOT and SVG when the formal exporters (and Graphviz)
    are there; returns what was written or why not."""
    notes = []
    json_path = folder / f"{stem}.json"
    cmap.write_json(json_path)
    notes.append(str(json_path))
    try:
        from clomp.formal.export import render_svg, write_dot
    except ImportError:
        notes.append("(DOT/SVG skipped: clomp.formal.export is not available)")
        return notes
    dot_path = folder / f"{stem}.dot"
    write_dot(cmap, dot_path)
    notes.append(str(dot_path))
    try:
        svg_path = folder / f"{stem}.svg"
        render_svg(cmap, svg_path)
        notes.append(str(svg_path))
    except Exception as exc:  # Graphviz missing or failing: the DOT file is still there
        notes.append(f"(SVG skipped: {exc})")
    return notes


def supervisor_closed_loop_prism() -> str:
    """The supervisor composed with the plant (the robot), as a PRISM MDP: the model
    ``specs/properties/supervisor/machine.pctl`` is written for (the machine alone has no
    plant, so its ``driving`` and ``after_fault`` would be constant false and the
    property file would fail on it). ``supervisor.dot`` draws the machine alone.

    >>> supervisor_closed_loop_prism().splitlines()[0]
    '// check with specs/properties/supervisor/machine.pctl (clomp check picks it for this file)'
    """
    import io

    from clomp.formal.control import PLANT, SUPERVISOR, machine_model
    from clomp.formal.export import write_prism

    buf = io.StringIO()
    buf.write("// check with specs/properties/supervisor/machine.pctl (clomp check picks it for this file)\n")
    write_prism(machine_model(SUPERVISOR, PLANT), buf)
    return buf.getvalue()


def run(args: argparse.Namespace) -> int:
    """Plan, execute on the simulated robot, summarise, write the pictures and models."""
    from clomp.runtime.cli.simulate import check_world_options, exit_status, print_summary, world_noise

    out = Path(args.out)
    scene = load_scene(args.scenario)
    try:
        check_world_options(args)
        output_folder(out)
    except OSError as exc:
        raise CliError(f"--out: cannot create {out}: {exc}") from None
    seed = args.seed if args.seed is not None else scene.raw.get("seed", 0)
    movers = scene_movers(scene, args.mover)
    try:
        r = run_once(scene, "planning", seed, noise=world_noise(args, scene), keep_report=True, feedback=args.feedback,
                     gyro=not args.no_gyro, movers=movers, moving=args.moving or bool(movers))
    except ScenarioError as exc:
        raise CliError(str(exc)) from None
    print_summary(r)
    written = []
    png = out / "trajectory.png"
    plot_run(r.trace(), png, title=f"{scene.name}: planned and executed")
    written.append(str(png))
    rep = r.report
    if rep.plans:
        # the paper's Fig. 3C: the first plan's explored task tree over what the planner perceived
        tree = out / "task_tree.png"
        plot_task_tree(rep.plans[0].result, tree, title=f"{scene.name}: the first plan's explored task tree")
        written.append(str(tree))
        written += write_map(rep.plans[0].result.map, out)
    for name, text in (("supervisor.dot", state_machine_dot()), ("supervisor.prism", supervisor_closed_loop_prism())):
        (out / name).write_text(text, encoding="utf-8")
        written.append(str(out / name))
    print(f"wrote to {out}{os.sep}: " + ", ".join(Path(w).name if not w.startswith("(") else w for w in written))
    if r.end_state == "GOAL_UNCONFIRMED":  # the last line says why: the distance and its bound
        print(f"goal unconfirmed: {r.reason}")
    return exit_status(r)
