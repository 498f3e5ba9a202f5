"""``clomp plan``: plan on a built-in scenario, a scan file, every scan in a folder, or the
LaserScan topic of a ROS bag (every scan, or one with ``--index K`` / ``--time T``)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from clomp.formal.lts import CognitiveMap, MapError
from clomp.planner import GOAL_LIMIT_M as _PLANNER_GOAL_LIMIT_M
from clomp.planner import Configurator, PlanningError, PlanResult, RobotModel, ScanError
from clomp.planner.perception import ScanWarning
from clomp.planner.deepening import plan_deepening
from clomp.planner.probabilistic import MAX_SAMPLES, NoiseError, ProbabilisticMap, preset_names
from clomp.runtime.cli import EXIT_NOT_REACHED, EXIT_OK, CliError, plural
from clomp.runtime.cli._args import length_arg, seed_arg
from clomp.runtime.cli._bags import add_bag_options, bag_points, is_bag, labelled_scans, lidar_offset, open_topic, scan_label
from clomp.runtime.cli._common import (Notes, add_units_option, folder_scans, load_scene, many_summary, output_path, path_kind,
                                      read_points, scan_outcomes, summary_line)
from clomp.runtime.cli._progress import progress
from clomp.runtime.records.bags import BagError

if TYPE_CHECKING:
    from clomp.planner.robust import RobustConfigurator, RobustDecision

__all__ = [
    "register",
    "GOAL_LIMIT_M",
    "parse_goal",
    "configurator_from_args",
    "add_planner_options",
    "add_sampling_options",
    "probabilistic_from_args",
    "robust_summary",
    "scenario_goal",
    "scenario_scan",
]


GOAL_LIMIT_M = _PLANNER_GOAL_LIMIT_M
"""The largest goal coordinate ``--goal`` takes (m), the planner's own limit: the LiDAR sees
12 m, and a goal farther than this is a typing slip, not a destination."""


def parse_goal(text: str) -> tuple[float, float]:
    """``"1.0,0.0"`` → (1.0, 0.0); a clear error for anything else."""
    try:
        parts = [float(p) for p in text.replace(" ", "").split(",")]
    except ValueError:
        raise CliError(f"--goal: expected X,Y in metres, got {text!r}") from None
    if len(parts) != 2:
        raise CliError(f"--goal: expected X,Y in metres, got {text!r}")
    if not all(math.isfinite(p) for p in parts):
        raise CliError(f"--goal: coordinates must be finite, got {text!r}")
    if max(abs(parts[0]), abs(parts[1])) > GOAL_LIMIT_M:
        # beyond this a squared distance loses the centimetres the planner works in
        raise CliError(f"--goal: coordinates beyond {GOAL_LIMIT_M:g} m are not a place to plan to, got {text!r}")
    return parts[0], parts[1]


def scenario_goal(scene: Any, text: str | None) -> tuple[float, float]:
    """The goal for a scenario: ``--goal`` (robot frame) or the scenario's own, refused
    when it lies inside one of the scenario's true obstacles (the sensor sees only their
    near faces, so the planner alone could not tell)."""
    from clomp.formal.geometry import compose
    from clomp.formal.model import Pose

    goal = parse_goal(text) if text else tuple(scene.goal_in_robot_frame())
    world = compose(scene.start, Pose(goal[0], goal[1], 0.0))
    if scene.collides(world.x, world.y):
        raise CliError(
            f"--goal: ({goal[0]:g}, {goal[1]:g}) is inside an obstacle of scenario {scene.name!r} "
            "(its true shape, not only the face the sensor sees)"
        )
    return goal[0], goal[1]


def scenario_scan(args: argparse.Namespace, conf: Configurator) -> tuple[str, tuple[float, float], np.ndarray]:
    """What ``--scenario`` (and ``--goal``) give a command that plans: the scene's name, the
    goal (:func:`scenario_goal`) and the scan the robot takes at its start (within the
    sensor range of ``conf``'s robot).

    >>> args = argparse.Namespace(scenario="open", goal="1,0")
    >>> name, goal, scan = scenario_scan(args, Configurator())
    >>> name, goal, scan.shape[1]
    ('open', (1.0, 0.0), 2)
    """
    scene = load_scene(args.scenario)
    goal = scenario_goal(scene, args.goal)
    return scene.name, goal, scene.scan(max_range=conf.robot.sensor_range)


def add_planner_options(p: argparse.ArgumentParser) -> None:
    """Options shared by the commands that plan."""
    g = p.add_argument_group("planner")
    g.add_argument("--max-states", type=int, default=50, help="state budget of the cognitive map (default 50; a search that spends it short of the goal and the frontier runs again with 4 times as many)")
    g.add_argument("--horizon", type=length_arg(0.0, 100.0, "--horizon"), default=1.2, help="half-size of the box around the start beyond which states are not expanded (m, default 1.2)")
    g.add_argument("--step-length", type=length_arg(0.0, 10.0, "--step-length"), default=0.27, help="length of a STRAIGHT step when the way to the goal is not clear (m, default 0.27; 0 = no cut)")


def configurator_from_args(args: argparse.Namespace) -> Configurator:
    """A Configurator from the shared planner options (with WAIT and REVERSE when the command
    has ``--moving`` and it is given)."""
    try:
        step = None if args.step_length == 0 else args.step_length
        return Configurator(RobotModel(step_length=step), max_states=args.max_states, horizon=args.horizon,
                            recovery=bool(getattr(args, "moving", False)))
    except ValueError as exc:
        raise CliError(str(exc)) from None


def add_sampling_options(p: argparse.ArgumentParser) -> None:
    """--samples N, --noise P, --seed S, --learn: the probabilistic cognitive map."""
    g = p.add_argument_group("probabilistic map")
    g.add_argument("--samples", type=int, metavar="N", help="estimate every task's outcome from N noisy rollouts (probabilities k/N)")
    g.add_argument("--noise", metavar="PRESET", default="paper", help=f"noise preset of the rollouts (default paper; known: {', '.join(preset_names())})")
    g.add_argument("--seed", type=seed_arg, default=0, help="seed of the noisy rollouts (default 0)")
    g.add_argument("--learn", action="store_true", help="with --scan FOLDER or a run log: learn the probabilities from consecutive scans of one place")


def _check_samples(samples: int) -> None:
    """CliError naming ``--samples`` unless it is 1 to :data:`clomp.planner.probabilistic.MAX_SAMPLES`
    (the library refuses the same, with a NoiseError the callers here would word as ``--noise``)."""
    if not 1 <= samples <= MAX_SAMPLES:
        raise CliError(f"--samples: expected a whole number from 1 to {MAX_SAMPLES:,}, got {samples:,} "
                       "(time and memory grow with the rollouts: about 12 s and 0.5 GB at 300 on overtaking)")


def robust_from_args(args: argparse.Namespace, conf: Configurator) -> RobustConfigurator:
    """The runtime's robust configurator for the sampling options (``--samples``, default
    30; ``--noise``; ``--seed``) and the planner options of ``conf``: one construction for
    ``plan --robust`` and the maps ``export``/``check --samples`` write, so they agree."""
    from clomp.planner.robust import CLOSED_LOOP_HAZARD, SUPERVISOR_HAZARD, RobustConfigurator, closed_loop_pushes, rollout_noise

    if args.samples is None:
        args.samples = 30
    _check_samples(args.samples)
    try:
        noise = rollout_noise(args.noise)
    except NoiseError as exc:
        raise CliError(f"--noise: {exc}") from None
    closed = getattr(args, "closed_loop", False)  # export --closed-loop: contacts the check foresees are stops
    # ... and the world's pushes with the whole run's terms, as the calibration bench predicts
    return RobustConfigurator(conf.robot, samples=args.samples, noise=noise, seed=args.seed,
                              max_states=conf.max_states, horizon=conf.horizon,
                              hazard=CLOSED_LOOP_HAZARD if closed else SUPERVISOR_HAZARD,
                              pushes=closed_loop_pushes(args.noise) if closed else None)


def probabilistic_from_args(args: argparse.Namespace, conf: Configurator, scan: Any, goal: tuple[float, float]) -> ProbabilisticMap:
    """The probabilistic map of ``scan`` the sampling options ask for (``--samples`` set):
    the map ``plan --robust`` chooses its first plan on (the supervisor's end tolerance,
    hazard stops and carried poses; :meth:`clomp.planner.robust.RobustConfigurator.probabilistic_map`)."""
    robust = robust_from_args(args, conf)
    try:
        return robust.probabilistic_map(scan, goal)
    except NoiseError as exc:
        raise CliError(str(exc)) from None


def register(sub: Any) -> None:
    """Add ``plan`` to the command line."""
    p = sub.add_parser("plan", help="plan to a goal on a scenario or scan(s)", description=__doc__)
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--scenario", help="a built-in scenario name or a scenario JSON file")
    src.add_argument("--scan", help="a scan file (x y per line, or .npy), a folder of scans, or a ROS bag")
    p.add_argument("--goal", help="goal X,Y in the robot frame (metres); default: the scenario's, or 1.0,0.0")
    p.add_argument("--json", action="store_true", help="print JSON (one object; one line per scan for a folder)")
    p.add_argument("--map", metavar="FILE", help="also write the cognitive map as JSON to FILE")
    p.add_argument("--figure", metavar="FILE", help="also draw the explored task tree over the scan and the obstacle boxes "
                   "(the paper's Fig. 3C; .png, .svg or .pdf) to FILE: one plan (--scenario, a scan file, a bag's --index/--time)")
    add_units_option(p)
    add_bag_options(p)
    pick = p.add_mutually_exclusive_group()
    pick.add_argument("--index", type=int, metavar="K", help="plan on the K-th scan of the bag's topic (from 0; default: every scan)")
    pick.add_argument("--time", type=float, metavar="T", help="plan on the bag's scan nearest T seconds after its first scan")
    p.add_argument(
        "--robust",
        action="store_true",
        help="plan on the probabilistic map (--samples, default 30): Storm's scheduler for Pmax [!collision U goal]; "
        "the JSON gains probability and greedy_probability",
    )
    add_sampling_options(p)
    add_planner_options(p)
    p.set_defaults(func=run)


def _plan_one(conf: Configurator, scan: Any, goal: tuple[float, float], units: str | None = None) -> PlanResult:
    try:
        points = read_points(scan, units)  # in metres: one that looks like millimetres is refused
        with warnings.catch_warnings():
            if units is not None:
                warnings.simplefilter("ignore", ScanWarning)  # the units were given: no "millimetres?"
            return plan_deepening(conf, points, goal)  # as the supervisor plans: a spent budget searched again
    except (ScanError, PlanningError) as exc:
        raise CliError(str(exc)) from None


def _print_readable(r: PlanResult, title: str) -> None:
    out = sys.stdout
    verdict = "reaches the goal" if r.reached_goal else "does NOT reach the goal (best partial plan)"
    if r.goal_blocked:
        verdict += "; the goal is inside a perceived obstacle"
    elif r.stop_reason == "frontier":
        verdict += "; it ends at the edge of what the sensor saw"
    print(f"{title}: goal ({r.goal.x:g}, {r.goal.y:g}) — plan {verdict}", file=out)
    print(
        f"  {plural(r.n_states, 'state')}, {plural(r.transitions, 'transition')}, "
        f"{plural(len(r.obstacles), 'obstacle box', 'obstacle boxes')}, "
        f"planned in {r.planning_time_s * 1e3:.2f} ms (stopped: {r.stop_reason})",
        file=out,
    )
    if not r.steps:
        print("  (empty plan: no safe task leads closer to the goal)", file=out)
    for k, s in enumerate(r.steps, 1):
        print(
            f"  {k:2d}. {s.task.value:<8} ({s.start.x:+.3f}, {s.start.y:+.3f}, {math.degrees(s.start.theta):+6.1f}°)"
            f" → ({s.end.x:+.3f}, {s.end.y:+.3f}, {math.degrees(s.end.theta):+6.1f}°)  q{s.ident}",
            file=out,
        )
    end = r.map[r.plan.end].end
    print(f"  ends {end.distance_to(r.goal.x, r.goal.y):.3f} m from the goal; collision-free: {r.collision_free}", file=out)


def robust_summary(d: "RobustDecision") -> dict[str, Any]:
    """The ``clomp plan --robust`` JSON of a :class:`clomp.planner.robust.RobustDecision`: the
    plan a supervisor with :class:`clomp.planner.robust.RobustConfigurator` would execute
    (``plan``: Storm's policy where its deviation from the best-first plan is confirmed on
    fresh rollouts, else the best-first plan; ``decision`` says which) and ``policy``
    (the task it starts in every state it can reach). ``probability`` is Storm's
    P[!collision U target] of that plan on the probabilistic map, with the supervisor's
    retry of a stop (``target``: the goal within 0.1 m, or beyond the sensed disc a
    frontier as close as the best-first plan gets), ``greedy_probability`` the same for
    the best-first plan, ``scheduler_probability`` the value of Storm's policy itself,
    and ``path_probability`` the chance of the printed path (the product of its
    branches; at most ``probability``)."""
    from clomp.formal.scheduler import path_probability, policy_states

    c = d.choice
    pm = c.pm
    plan = d.plan
    policy = d.policy
    steps = plan.tasks(pm.map)
    end = pm.map[plan.end]
    out: dict[str, Any] = pm.nominal.to_dict()
    out.update(
        {
            "plan": [
                {"task": s.task.value, "start": [round(v, 6) for v in s.start.as_list()], "end": [round(v, 6) for v in s.end.as_list()], "state": s.ident}
                for s in steps
            ],
            "reached_goal": end.reached_goal and not end.interrupted,
            "collision_free": not any(pm.map[i].interrupted for i in plan.states),
            "decision": d.decision,
            "probability": d.probability,
            "path_probability": path_probability(pm.map, plan, c.target),
            "scheduler_probability": c.robust.probability,
            "confirmation": None if d.confirmation is None else list(d.confirmation),
            "policy": [{"state": q, "task": policy[q].value} for q in policy_states(pm.map, policy) if q in policy],
            "greedy_probability": c.p_greedy,
            "greedy_plan": [s.task.value for s in pm.nominal.steps],
            "target": sorted(c.target),
            "states": len(pm.map),
            "transitions": pm.map.n_transitions,
            "samples": pm.samples,
            "noise": pm.noise.to_dict(),
            "probabilistic_choices": pm.probabilistic_choices,
            "build_time_s": pm.build_time_s,
        }
    )
    return out


def _run_robust(args: argparse.Namespace, conf: Configurator) -> int:
    from clomp.formal.checking import StormMissing

    if args.learn:
        raise CliError("--learn goes with clomp export or check; plan --robust samples the map (--samples)")
    scan: Any
    if args.scenario:
        title, goal, scan = scenario_scan(args, conf)
    else:
        path = Path(args.scan)
        if path_kind(path, "--scan") != "file":
            raise CliError(f"--scan: {path}: --robust plans on one scan file")
        goal, title = (parse_goal(args.goal) if args.goal else (1.0, 0.0)), str(path)
        try:
            scan = read_points(path, args.units)
        except ScanError as exc:
            raise CliError(str(exc)) from None
    # the runtime's robust configurator itself: the same rollouts (hazard stops, the
    # supervisor's tolerance, poses carried), target, retry and second look
    robust = robust_from_args(args, conf)
    try:
        decision = robust.choose(scan, goal)
    except (ScanError, PlanningError, StormMissing) as exc:
        raise CliError(str(exc)) from None
    pm = decision.choice.pm
    summary = robust_summary(decision)
    _write_map(pm.map, args)
    status = EXIT_OK if summary["reached_goal"] else EXIT_NOT_REACHED
    if args.json:
        print(json.dumps(summary))
        return status
    print(f"{title}: robust plan on a map of {pm.samples} noisy rollouts per choice ({summary['states']} states)")
    print(f"  P(target without collision, a stop retried once): plan {summary['probability']:.4f} "
          f"({summary['decision']}: {_DECISIONS[summary['decision']]}), greedy {summary['greedy_probability']:.4f}, "
          f"Storm's scheduler {summary['scheduler_probability']:.4f} (a policy: the task it picks in whichever "
          f"outcome the robot lands)")
    print(f"  the path the plan starts on (each task's most likely outcome; this path itself: "
          f"P = {summary['path_probability']:.4f}):")
    for k, st in enumerate(summary["plan"], 1):
        print(f"  {k:2d}. {st['task']:<8} q{st['state']}")
    others = [f"q{d['state']} {d['task']}" for d in summary["policy"] if d["state"] not in {0, *(st["state"] for st in summary["plan"])}]
    if others:
        print(f"  off that path the policy continues: {', '.join(others)}")
    return status


_DECISIONS = {
    "kept": "Storm's scheduler keeps every best-first task",
    "confirmed": "Storm's detour, confirmed safer on fresh rollouts",
    "rejected": "Storm's detour was not safer on fresh rollouts: the best-first plan",
    "deviated": "Storm's detour",
}


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp plan``."""
    conf = configurator_from_args(args)
    if args.scenario and (args.topic or args.index is not None or args.time is not None or args.lidar_offset):
        raise CliError("--topic, --index, --time and --lidar-offset read a ROS bag given with --scan")
    if args.scenario and args.units:
        raise CliError("--units gives the units of the scans read with --scan; a scenario is in metres")
    _check_figure(args)
    if args.robust:
        return _run_robust(args, conf)
    if args.samples is not None or args.learn:
        raise CliError("--samples/--learn on plan go with --robust (or use clomp export --samples)")
    if args.scenario:
        title, goal, scan = scenario_scan(args, conf)
        r = _plan_one(conf, scan, goal)
        _emit(r, args, title, scan)
        return EXIT_OK if r.reached_goal else EXIT_NOT_REACHED
    path = Path(args.scan)
    goal = parse_goal(args.goal) if args.goal else (1.0, 0.0)
    kind = path_kind(path, "--scan")
    if kind == "missing":
        raise CliError(f"{path}: no such file or folder")
    if args.topic or is_bag(path):
        return _plan_bag(conf, path, goal, args)
    if args.index is not None or args.time is not None:
        raise CliError("--index and --time pick a scan of a ROS bag; --scan is not a bag")
    lidar_offset(args, bag=False)
    if kind == "folder":
        _one_plan_only(args, "a folder of scans")
        return _plan_folder(conf, path, goal, args)
    r = _plan_one(conf, path, goal, args.units)
    _emit(r, args, str(path))  # the figure draws the points the boxes cover (the file's, as perceived)
    return EXIT_OK if r.reached_goal else EXIT_NOT_REACHED


def _write_map(cmap: CognitiveMap, args: argparse.Namespace) -> None:
    """``--map FILE``: the cognitive map as JSON (a one-line error when it cannot be written)."""
    if args.map:
        output_path(args.map, "--map")
        try:
            cmap.write_json(args.map)
        except (OSError, MapError) as exc:
            raise CliError(f"--map: cannot write {args.map}: {exc}") from None


_FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


def _check_figure(args: argparse.Namespace) -> None:
    """``--figure FILE``: a format matplotlib writes, a place it can be written, one plan to draw."""
    if not args.figure:
        return
    output_path(args.figure, "--figure")  # a device, FIFO or socket is refused as such, whatever its name
    if Path(args.figure).suffix.lower() not in _FIGURE_SUFFIXES:
        raise CliError(f"--figure: {args.figure}: the name must end in {', '.join(_FIGURE_SUFFIXES)}")
    if args.robust:
        raise CliError("--figure draws the greedy plan's task tree; it does not go with --robust")


def _one_plan_only(args: argparse.Namespace, what: str) -> None:
    if args.figure:
        raise CliError(f"--figure draws one plan, not {what}")


def _write_figure(r: PlanResult, args: argparse.Namespace, title: str, scan: Any) -> None:
    """``--figure FILE``: the explored task tree in the scene (a one-line error when it cannot be written)."""
    if args.figure:
        from clomp.runtime.experiment.tasktree import plot_task_tree

        try:
            plot_task_tree(r, args.figure, scan if isinstance(scan, np.ndarray) else None, title=f"{title}: explored task tree")
        except OSError as exc:
            raise CliError(f"--figure: cannot write {args.figure}: {exc}") from None


def _emit(r: PlanResult, args: argparse.Namespace, title: str, scan: Any = None) -> None:
    _write_map(r.map, args)
    _write_figure(r, args, title, scan)
    if args.json:
        print(json.dumps(r.to_dict()))
    else:
        _print_readable(r, title)


def _plan_bag(conf: Configurator, path: Path, goal: tuple[float, float], args: argparse.Namespace) -> int:
    offset = lidar_offset(args)
    with open_topic(path, args) as topic:
        if args.index is None and args.time is None:
            _one_plan_only(args, "every scan of a bag (pick one with --index or --time)")
            items = ((label, (lambda s=s: bag_points(s, offset)), label) for label, s in labelled_scans(topic))
            return _plan_many(conf, topic.count, items, goal, args)
        try:
            scan = topic.at_index(args.index) if args.index is not None else topic.at_time(args.time)
            t0 = topic.start_ns()
            points = scan.points(offset)
        except BagError as exc:
            raise CliError(str(exc)) from None
        try:
            points = read_points(points, args.units)
        except ScanError as exc:
            raise CliError(str(exc)) from None
        r = _plan_one(conf, points, goal, args.units and "m")  # in metres now
        _emit(r, args, f"{path} {scan_label(topic.topic, scan, t0 or scan.time_ns)}", points)
    return EXIT_OK if r.reached_goal else EXIT_NOT_REACHED


def _plan_folder(conf: Configurator, folder: Path, goal: tuple[float, float], args: argparse.Namespace) -> int:
    files, notes = folder_scans(folder)
    return _plan_many(conf, len(files), ((f.name, f, str(f)) for f in files), goal, args, notes)


def _plan_many(conf: Configurator, total: int, items: Iterable[tuple[str, Any, str]], goal: tuple[float, float],
               args: argparse.Namespace, listing: list[str] | None = None) -> int:
    """Plan on every (name, scan, JSON name) of ``items``: one line each, then a summary
    (in text, what is worth a word — how many returns lay beyond the planning horizon,
    placeholders, copies — is said once, before the summary: :class:`~clomp.runtime.cli._common.Notes`).

    A scan that cannot be planned gets its own line with an error and the run goes on;
    the exit status is 0 once every scan was processed.
    """
    times: list[float] = []
    outcomes: list[str] = []
    notes = Notes(listing, conf.robot.sensor_range)
    bar = progress(items, total=total, desc="plan", unit="scan")
    for name, scan, json_name in bar:
        r, rec = scan_outcomes(conf, scan, goal, args.units, f"--scan: {json_name}")
        outcomes.append(rec["outcome"])
        if r is not None:
            times.append(r.planning_time_s)
        if args.json:
            bar.write(json.dumps({"scan": json_name, **(r.to_dict() if r is not None else {}), **rec}))
        elif r is None:
            what = f"error: {rec['error']}" if rec["outcome"] == "error" else "already at the goal"
            bar.write(f"{name}: {what}")
        else:
            bar.write(
                f"{name}: {rec['outcome'].replace('_', ' ')}  {plural(len(r.steps), 'task')}  {plural(r.n_states, 'state')}  "
                f"{r.planning_time_s * 1e3:.2f} ms  [{' '.join(s.task.value[0] for s in r.steps)}]"
            )
        notes.add(name, rec)
    summary = {**many_summary(outcomes, times), **notes.summary()}
    for note in [] if args.json else notes.lines():
        print(note)
    print(json.dumps({"summary": summary}) if args.json else summary_line(summary))
    return EXIT_OK
