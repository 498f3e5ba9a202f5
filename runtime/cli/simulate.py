"""``clomp simulate``: one scenario end to end on the simulated robot (planning or reactive)."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from clomp.planner.noise import preset_names
from clomp.planner.inputs import safe_name
from clomp.planner.scenarios import ScenarioError
from clomp.runtime.cli._args import seed_arg
from clomp.runtime.cli import EXIT_NOT_REACHED, EXIT_OK, CliError
from clomp.runtime.cli._common import add_mover_options, load_scene, output_folder, output_path, scene_movers
from clomp.runtime.experiment.onerun import SUCCESS_RADIUS, RunResult, run_once
from clomp.runtime.experiment.plots import plot_run
from clomp.runtime.backends.world import WorldNoise

__all__ = ["add_world_options", "check_world_options", "exit_status", "world_noise", "register", "run", "print_summary"]


def add_world_options(p: Any) -> None:
    """``--noise``, ``--noise-scale``, ``--feedback``, ``--no-gyro``, ``--moving`` and ``--mover``
    (shared by simulate and demo)."""
    p.add_argument("--noise", choices=preset_names(), default=None,
                   help="noise preset of the execution world (specs/noise_presets.json; default paper, with "
                        "the scenario file's own 'noise' object laid over it)")
    p.add_argument("--noise-scale", type=float, default=1.0, help="factor on every noise term (default 1)")
    p.add_argument("--feedback", choices=("scan", "none"), default="scan",
                   help="pose estimate: scan matching against a local map (default) or dead reckoning only")
    p.add_argument("--no-gyro", action="store_true",
                   help="the robot without its rate gyro, as the paper's robot and clomp run without an IMU")
    add_mover_options(p)


def check_world_options(args: argparse.Namespace) -> None:
    """CliError for a noise scale that is not a finite number >= 0, or a ``--max-time``
    that is not a finite positive number of seconds (NaN or inf would never end a run)."""
    if not (math.isfinite(args.noise_scale) and args.noise_scale >= 0):
        raise CliError(f"--noise-scale: must be a finite number >= 0, got {args.noise_scale:g}")
    max_time = getattr(args, "max_time", None)
    if max_time is not None and not (math.isfinite(max_time) and max_time > 0):
        raise CliError(f"--max-time: must be a finite positive number of seconds, got {max_time:g}")


def world_noise(args: argparse.Namespace, scene: Any) -> WorldNoise:
    """The execution world's noise: ``--noise`` (× ``--noise-scale``), else ``paper`` with
    the scenario's own ``noise`` object over it (ScenarioError naming a bad field)."""
    if args.noise is not None:
        return WorldNoise.preset(args.noise, args.noise_scale)
    return WorldNoise.for_scene(scene, "paper", args.noise_scale)


def register(sub: Any) -> None:
    """Add ``simulate`` to the command line."""
    p = sub.add_parser("simulate", help="run one scenario on the simulated robot and draw the trajectory", description=__doc__)
    p.add_argument("--scenario", default="overtaking", help="built-in scenario name or JSON file (default overtaking)")
    p.add_argument("--reactive", action="store_true", help="run the reactive baseline instead of the planner")
    p.add_argument("--seed", type=seed_arg, default=None, help="noise seed (default: the scenario's 'seed', else 0)")
    add_world_options(p)
    p.add_argument("--no-noise", action="store_true", help="same as --noise ideal")
    p.add_argument("--max-time", type=float, default=120.0, help="simulated seconds allowed (default 120)")
    p.add_argument("--out", default="clomp-simulate-out", help="folder for the PNG (default ./clomp-simulate-out)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--animate", metavar="FILE.gif", help="also write the run as an animated GIF (the robot's body moving "
                   "along its true path over the scene, the time and, at the end, the outcome)")
    p.add_argument("--log", metavar="FILE", help="write the run log (JSON lines, as clomp run writes; simulated time, "
                   "with the ground truth) to FILE; 'clomp convert FILE -o RUN.mcap' opens it in Foxglove")
    p.set_defaults(func=run)


def print_summary(r: RunResult) -> None:
    """A few readable lines about one run."""
    rep = r.report
    print(f"{r.scene.name} — {r.condition}: {'GOAL REACHED' if r.reached_goal else 'goal not reached'} "
          f"({r.end_state}: {r.reason})")
    print(f"  {r.time_s:.1f} s simulated in {r.wall_s:.2f} s ({r.time_s / max(r.wall_s, 1e-9):.0f}× real time); "
          f"collisions {r.collisions}" + (f" (+{r.pushed_contacts} pushed into)" if r.pushed_contacts else "")
          + f"; ends {r.final_distance:.3f} m from the goal (success within {SUCCESS_RADIUS} m)")
    if r.moving is not None:
        m = r.moving
        print(f"  moving bodies: {m['moving_collisions']} collision(s), {m['robot_caused_collisions']} caused by the robot, "
              f"{m['moving_brushes']} brush(es); {m['static_collisions']} collision(s) with static obstacles")
    if r.condition == "planning" and rep is not None:
        print(f"  {len(rep.plans)} plan(s), {len(rep.tasks)} task(s) run; first plan: {r.n_states} states in "
              f"{(r.planning_time_s or 0) * 1e3:.1f} ms")
        for k, p in enumerate(rep.plans, 1):
            tasks = " ".join(s.task.value[0] for s in p.result.steps) or "(empty)"
            o = p.origin
            print(f"   plan {k} at {p.time:5.1f} s from ({o.x:+.2f}, {o.y:+.2f}, {math.degrees(o.theta):+.0f}°): "
                  f"{tasks}  [{p.result.n_states} states, {'reaches' if p.result.reached_goal else 'short of'} the goal]")
        for t in rep.transitions:
            if t.event.value not in ("next_task", "start"):
                print(f"   {t.time:5.1f} s  {t.source.value} → {t.target.value}: {t.reason}")


def exit_status(r: RunResult) -> int:
    """0 when the robot truly reached the goal without a collision (its own or a pushed contact) and the supervisor could
    vouch for it; 1 otherwise (also GOAL_UNCONFIRMED: the estimate could not vouch for it)."""
    ok = r.reached_goal and r.collisions == 0 and r.pushed_contacts == 0 and r.end_state != "GOAL_UNCONFIRMED"
    return EXIT_OK if ok else EXIT_NOT_REACHED


def _summary_dict(r: RunResult, png: Path) -> dict[str, Any]:
    return {
        "scenario": r.scene.name,
        "condition": r.condition,
        "end_state": r.end_state,
        "reason": r.reason,
        "reached_goal": r.reached_goal,
        "goal_unconfirmed": r.end_state == "GOAL_UNCONFIRMED",
        "final_distance_m": r.final_distance,
        "collisions": r.collisions,
        "pushed_contacts": r.pushed_contacts,
        "time_s": r.time_s,
        "wall_s": r.wall_s,
        "plans": r.plans,
        "planning_time_s": r.planning_time_s,
        "states": r.n_states,
        "png": str(png),
        **({"moving": r.moving} if r.moving is not None else {}),
    }


def _check_animate(args: argparse.Namespace) -> None:
    """``--animate FILE.gif``: a GIF that can be written, checked before the run."""
    if not args.animate:
        return
    if Path(args.animate).suffix.lower() != ".gif":
        raise CliError(f"--animate: writes a GIF; name the file FILE.gif, got {args.animate}")
    try:
        Path(args.animate).parent.mkdir(parents=True, exist_ok=True)
        output_path(args.animate, "--animate")
    except OSError as exc:
        raise CliError(f"--animate: cannot write {args.animate}: {exc.strerror or exc}") from None


def _animate(args: argparse.Namespace, r: RunResult, title: str) -> None:
    """Write the run as the GIF ``--animate`` names (nothing without it)."""
    if not args.animate:
        return
    from clomp.runtime.experiment.animation import animate_run

    try:
        animate_run(r.trace(), args.animate, title=title)
    except OSError as exc:
        raise CliError(f"--animate: cannot write {args.animate}: {exc.strerror or exc}") from None


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp simulate``."""
    scene = load_scene(args.scenario)
    try:
        check_world_options(args)
        noise = WorldNoise.preset("ideal") if args.no_noise else world_noise(args, scene)
        seed = args.seed if args.seed is not None else scene.raw.get("seed", 0)
        out = output_folder(args.out)
        cond = "reactive" if args.reactive else "planning"
    except ScenarioError as exc:
        raise CliError(str(exc)) from None
    except OSError as exc:
        raise CliError(f"--out: {exc}") from None
    _check_animate(args)
    if args.log:
        if args.reactive:
            raise CliError("--log: the reactive baseline has no supervisor and keeps no run log")
        try:
            Path(args.log).parent.mkdir(parents=True, exist_ok=True)
            output_path(args.log, "--log")  # no FIFO (an open would block), device or read-only file
            open(args.log, "w", encoding="utf-8").close()  # a fresh log, not appended to an old one
        except OSError as exc:
            raise CliError(f"--log: cannot write {args.log}: {exc.strerror or exc}") from None
    try:
        movers = scene_movers(scene, args.mover)
        r = run_once(scene, cond, seed, noise=noise, noise_scale=args.noise_scale, max_time=args.max_time,
                     keep_report=True, log=args.log, feedback=args.feedback, gyro=not args.no_gyro,
                     movers=movers, moving=args.moving or bool(movers))
    except ScenarioError as exc:  # the scene's noise settings are checked when its robot is built
        raise CliError(str(exc)) from None
    except OSError as exc:
        raise CliError(f"--log: cannot write {args.log}: {exc.strerror or exc}") from None
    png = out / f"{safe_name(scene.name)}_{cond}.png"  # a name from a file: never a path
    plot_run(r.trace(), png, title=f"{scene.name} — {cond}")
    _animate(args, r, f"{scene.name} — {cond}")
    if args.json:
        summary = _summary_dict(r, png)
        if args.animate:
            summary["gif"] = str(args.animate)
        print(json.dumps(summary))
    else:
        print_summary(r)
        print(f"  trajectory: {png}")
        if args.animate:
            print(f"  animation: {args.animate}")
        if args.log:
            print(f"  run log: {args.log}")
        if r.end_state == "GOAL_UNCONFIRMED":  # the last line says why: the distance and its bound
            print(f"goal unconfirmed: {r.reason}")
    return exit_status(r)
