"""The paper's experiment: planning vs the reactive loop, one run as a pure function, many on Dask.

:func:`run_once` drives one condition (``"planning"``: the :class:`~clomp.runtime.supervision.supervisor.
Supervisor` with a :class:`~clomp.planner.Configurator`; ``"reactive"``: the :class:`~clomp.runtime.
experiment.reactive.ReactiveController`) on a fresh robot of the execution world
(:func:`~clomp.runtime.experiment.groundtruth.make_robot`) and measures it on the world's ground
truth: contact episodes (:mod:`clomp.runtime.experiment.contacts`) and the true final distance
to the goal.

:func:`run_spec` is one run of an experiment as a pure function of its
:class:`RunSpec` — (family, seed, run index, condition, noise preset, noise scale):
the layout is :func:`~clomp.runtime.experiment.layouts.make_layout` (family, seed, run) and
the world's noise seed depends on (seed, run) only, so the two conditions of a run meet
the same world and the same noise (paired), and a result does not depend on which
process computed it or when. :func:`run_experiment` maps it over every run, in this
process (``workers=0``) or on Dask (a local cluster of ``workers`` processes, or an existing
scheduler), streaming each record to ``runs.jsonl`` as it finishes (``resume=True`` skips those there).

Success (``success``): for a family whose goal can be reached, the robot truly ends
within :data:`SUCCESS_RADIUS` of it (ground truth, whatever the controller believed);
for one whose goal cannot be reached (cul-de-sac), the controller stops by itself saying
so (``UNREACHABLE``) with no collision.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from clomp.formal.geometry import compose, relative
from clomp.formal.model import Pose
from clomp.planner.configurator import Configurator
from clomp.planner.scenarios import Scene, load_scenario
from clomp.runtime.experiment.contacts import Episode, contact_episodes
from clomp.runtime.experiment.layouts import FAMILIES, make_layout, shape_distance
from clomp.runtime.experiment.plots import RunTrace
from clomp.runtime.experiment.provenance import claim_folder
from clomp.runtime.experiment.reactive import ReactiveController
from clomp.runtime.experiment.groundtruth import NOISE_PRESETS, make_robot, world_name
from clomp.runtime.records.runlog import RunLog
from clomp.runtime.backends.sim import NoiseConfig
from clomp.runtime.backends.world import WorldNoise, make_world_robot
from clomp.runtime.supervision.supervisor import Supervisor, SupervisorConfig

__all__ = ["CONDITIONS", "PAPER", "SUCCESS_RADIUS", "ExperimentInterrupted", "RunsFailed", "RunResult", "RunSpec",
           "experiment_specs", "load_records", "run_experiment", "run_once", "run_spec",
           "scene_for"]

CONDITIONS = ("planning", "reactive")
SUCCESS_RADIUS = 0.1
"""Ground-truth distance (m) to the goal within which a run reached it: twice the planner's
goal tolerance (0.05 m), about half the body's width; the paper gives none."""
# the paper's figures (overtaking, real robot, 10 runs per condition)
PAPER: dict[str, dict[str, Any]] = {
    "planning": {"reached_goal": 10, "runs": 10, "collisions": 0, "brushes": 2, "planning_time_s": (0.064, 0.009),
                 "states": (32.9, 1.758)},
    "reactive": {"reached_goal": 0, "runs": 10, "collisions": 8},
    "ttest": {"t": -1.747, "p": 0.111},
}


@dataclass
class RunResult:
    """One run of one condition, measured on the world's ground truth (world frame).

    >>> from clomp.planner import load_scenario
    >>> r = run_once(load_scenario("open"), "planning", 0, noise="ideal")
    >>> r.condition, r.reached_goal, r.collisions, r.final_distance < SUCCESS_RADIUS
    ('planning', True, 0, True)
    """

    condition: str
    run: int
    seed: int
    scene: Scene
    end_state: str
    reason: str
    reached_goal: bool
    believed_goal: bool
    final_distance: float
    episodes: list[Episode]
    contacts: list[tuple[float, float]]
    time_s: float
    time_to_goal_s: float | None
    planning_time_s: float | None
    states: int | None
    plans: int
    path: list[tuple[float, float]]
    estimate: list[tuple[float, float]]
    planned: list[list[tuple[float, float]]]
    wall_s: float
    cpu_s: float
    final_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    counters: dict[str, int | None] = field(default_factory=dict)
    report: Any = field(default=None, repr=False)

    @property
    def collisions(self) -> int:
        """Contact episodes that are not brushes."""
        return sum(not e.brush for e in self.episodes)

    @property
    def brushes(self) -> int:
        """Short, shallow contact episodes."""
        return sum(e.brush for e in self.episodes)

    def trace(self) -> RunTrace:
        """The run as a picture."""
        verdict = "goal" if self.reached_goal else "failed"
        title = f"run {self.run}: {verdict}, {self.collisions} coll., {self.brushes} brush."
        st = self.scene.start
        poses = [(st.x, st.y, st.theta), self.final_pose]
        return RunTrace(self.scene, title, self.path, self.contacts, self.planned, self.estimate, poses,
                        self.reached_goal)


def _world(start: Pose, p: Pose) -> tuple[float, float]:
    w = compose(start, p)
    return (w.x, w.y)


def _count(report: Any, name: str) -> int | None:
    v = getattr(report, name, None)
    if v is None:
        return None
    if isinstance(v, (int, np.integer)):
        return int(v)
    try:
        return len(v)
    except TypeError:
        return None


def _ground_truth_path(robot: Any, pose: Pose) -> list[tuple[float, float, float, float]]:
    for name in ("ground_truth_trajectory", "trajectory"):
        v = getattr(robot, name, None)
        if callable(v):
            v = v()
        if v:
            return [(float(a), float(b), float(c), float(d)) for a, b, c, d in v]
    return [(0.0, pose.x, pose.y, pose.theta)]


def _contact_point(scene: Scene, path: list[tuple[float, float, float, float]], t: float) -> tuple[float, float]:
    """Where the body touched at time ``t``: the obstacle point nearest the true position then."""
    times = [p[0] for p in path]
    k = min(max(int(np.searchsorted(times, t)), 0), len(path) - 1)
    x, y = path[k][1], path[k][2]
    best, where = math.inf, (x, y)
    for s in scene.shapes:
        d = shape_distance(s, x, y)
        if d < best:
            best = d
            if s.kind == "circle":
                cx, cy = s.center
                r = math.hypot(x - cx, y - cy) or 1.0
                where = (cx + s.radius * (x - cx) / r, cy + s.radius * (y - cy) / r)
            else:
                v = s.vertices
                bq, bp = math.inf, (x, y)
                for i in range(len(v)):
                    ax, ay = v[i]
                    ex, ey = v[(i + 1) % len(v)][0] - ax, v[(i + 1) % len(v)][1] - ay
                    u = max(0.0, min(1.0, ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey)))
                    q = (ax + u * ex, ay + u * ey)
                    dq = math.hypot(x - q[0], y - q[1])
                    if dq < bq:
                        bq, bp = dq, q
                where = bp
    return (float(where[0]), float(where[1]))


class _TruthLog:
    """A simulated run's log: scan and task records also carry the ground truth pose
    (in the odometry frame, the robot's start), what a viewer shows beside the estimate."""

    def __init__(self, log: RunLog, robot: Any, start: Pose) -> None:
        self._log, self._robot, self._start = log, robot, start

    def write(self, event: str, **fields: Any) -> None:
        if event in ("scan", "task"):
            fields["truth"] = relative(self._start, self._robot.ground_truth_pose()).as_list()
        self._log.write(event, **fields)


def _open_log(dest: str | os.PathLike[str], robot: Any, scene: Scene, condition: str, seed: int,
              noise: str | NoiseConfig | WorldNoise | None, goal: tuple[float, ...]) -> RunLog:
    runlog = RunLog(dest, clock=robot)  # the robot keeps the simulated time
    runlog.write("run", simulated=True, scenario=scene.name, condition=condition, seed=seed,
                 noise=noise if isinstance(noise, str) else ("scene" if noise is None else "custom"),
                 goal=list(goal), wall=time.time())
    return runlog


def run_once(
    scene: Scene,
    condition: str = "planning",
    seed: int | None = 0,
    *,
    run: int = 0,
    noise: str | NoiseConfig | WorldNoise | None = None,
    noise_scale: float = 1.0,
    max_time: float = 120.0,
    expect: str = "reach",
    configurator: Configurator | None = None,
    keep_report: bool = False,
    log: str | os.PathLike[str] | None = None,
    feedback: str = "scan",
    reactive: dict[str, Any] | None = None,
) -> RunResult:
    """Run one condition in ``scene`` on a fresh robot; see the module docstring.

    ``noise``: a preset name (``ideal``, ``paper``, ``harsh``; the execution world of
    :func:`~clomp.runtime.experiment.groundtruth.make_robot`), a :class:`~clomp.runtime.backends.sim.NoiseConfig`
    for the simulated robot, a :class:`~clomp.runtime.backends.world.WorldNoise` for the execution
    world with those terms, or None for the simulated robot with the scene's own noise.
    ``log``: a file for the run log (the supervisor's records, as ``clomp run`` writes
    them, in simulated time, with the ground truth beside each scan and task record).
    ``feedback``: both conditions' pose estimate (the same robot, the same sensing) —
    ``"scan"`` (scan matching, the default) or ``"none"`` (dead reckoning alone).
    ``reactive``: keyword arguments for the ReactiveController (``bench/experiment_reactive.py``).

    >>> from clomp.planner import load_scenario
    >>> r = run_once(load_scenario("open"), "reactive", 0, noise="ideal")
    >>> r.reached_goal, r.collisions, r.brushes
    (True, 0, 0)
    """
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {', '.join(CONDITIONS)}, got {condition!r}")
    if not (math.isfinite(max_time) and max_time > 0):  # a simulated run needs an end
        raise ValueError(f"max_time must be a finite positive number of seconds, got {max_time!r}")
    conf = configurator or Configurator()
    seed_ = 0 if seed is None else int(seed)
    robot: Any
    if isinstance(noise, str):
        robot = make_robot(scene, noise=noise, noise_scale=noise_scale, seed=seed_, model=conf.robot)
    elif isinstance(noise, WorldNoise):
        robot = make_world_robot(scene, noise, seed=seed_, robot=conf.robot)
    else:
        from clomp.runtime.experiment.groundtruth import _TracedSimRobot

        robot = _TracedSimRobot(scene, conf.robot, noise=noise, seed=seed)
    start = scene.start
    goal = tuple(scene.goal_in_robot_frame())
    t0, c0 = time.perf_counter(), time.thread_time()
    planned: list[list[tuple[float, float]]] = []
    plan_time = states = None
    plans = 0
    report: Any
    if condition == "planning":
        runlog = _open_log(log, robot, scene, condition, seed_, noise, goal) if log is not None else None
        try:
            sup = Supervisor(robot, goal, conf, config=SupervisorConfig(feedback=feedback),  # type: ignore[arg-type]
                             log=None if runlog is None else _TruthLog(runlog, robot, start))
            report = sup.run(max_time=max_time)
        finally:
            if runlog is not None:
                runlog.close()
        for rec in report.plans:
            planned.append([_world(start, rec.to_frame(rec.result.map[i].end)) for i in rec.result.plan.states])
        if report.plans:
            plan_time = report.plans[0].result.planning_time_s
            states = report.plans[0].result.states
        plans = len(report.plans)
        end_state, reason = report.state.value, report.reason
    else:
        opts: dict[str, Any] = {"model": conf.robot, "feedback": feedback, **(reactive or {})}
        report = ReactiveController(robot, goal, **opts).run(max_time=max_time)  # type: ignore[arg-type]
        end_state, reason = report.state, report.reason
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    true = robot.ground_truth_pose()
    dist = math.hypot(true.x - scene.goal[0], true.y - scene.goal[1])
    believed = bool(report.reached_goal)
    episodes = contact_episodes(robot.contact_trace())
    truth = _ground_truth_path(robot, true)
    if expect == "unreachable":
        reached = end_state == "UNREACHABLE" and not any(not e.brush for e in episodes)
    else:
        reached = dist <= SUCCESS_RADIUS
    if believed and dist > SUCCESS_RADIUS:
        reason = f"{reason}, but truly {dist:.3f} m from the goal"
    path = [(x, y) for _, x, y, _ in truth[::10]] + [(true.x, true.y)]
    estimate = [_world(start, Pose(x, y, th)) for _, x, y, th in report.trajectory]
    contacts = [_contact_point(scene, truth, e.start_s) for e in episodes]
    counters = {name: _count(report, name) for name in ("checks", "recalls", "fresh_plans")}
    return RunResult(
        condition, run, seed_, scene, end_state, reason, reached, believed, dist, episodes, contacts,
        report.time_s, report.time_s if reached and expect == "reach" else None, plan_time, states, plans, path,
        estimate, planned, wall, cpu, (true.x, true.y, true.theta), counters, report if keep_report else None,
    )


# -- one run of an experiment, as a pure function ---------------------------------------------
@dataclass(frozen=True)
class RunSpec:
    """Everything one run depends on. ``family`` is a layout family or a scenario (name or file)."""

    family: str
    seed: int
    run: int
    condition: str
    noise: str = "paper"
    noise_scale: float = 1.0
    max_time: float = 120.0
    feedback: str = "scan"

    @property
    def key(self) -> str:
        """A stable name for the run (the Dask task key and the resume key)."""
        key = f"{self.family}/{self.seed}/{self.run}/{self.condition}/{self.noise}/{self.noise_scale:g}/{self.max_time:g}"
        return key if self.feedback == "scan" else f"{key}/feedback={self.feedback}"


def noise_seed(seed: int, run: int) -> int:
    """The world's noise seed of run ``run`` (the same for both conditions: paired)."""
    return int(np.random.default_rng([int(seed), int(run), 1]).integers(2**31))


def scene_for(spec: RunSpec) -> tuple[Scene, str]:
    """The world a run is in and what success means there: ``(scene, expect)``, where
    ``expect`` is ``"reach"`` or ``"unreachable"``. A layout family draws run ``spec.run``
    of seed ``spec.seed`` (:func:`~clomp.runtime.experiment.layouts.make_layout`); any other
    name is a built-in scenario or a scenario file, the same world every run. Benchmarks
    and ablations use it to put a variant in exactly the world :func:`run_spec` would.

    >>> scene, expect = scene_for(RunSpec("overtaking", 0, 3, "planning", "paper"))
    >>> scene == scene_for(RunSpec("overtaking", 0, 3, "reactive", "harsh"))[0], expect
    (True, 'reach')
    """
    if spec.family in FAMILIES:
        lay = make_layout(spec.family, spec.seed, spec.run)
        return lay.scene, lay.expect
    scene = load_scenario(spec.family)
    expect = "unreachable" if scene.raw.get("expect") == "unreachable" else "reach"
    return scene, expect


def _r(v: float | None, nd: int) -> float | None:
    return None if v is None else round(float(v), nd)


def run_spec(spec: RunSpec) -> dict[str, Any]:
    """One run as a JSON-ready record (the CSV columns plus what the plots need)."""
    scene, expect = scene_for(spec)
    r = run_once(scene, spec.condition, noise_seed(spec.seed, spec.run), run=spec.run, noise=spec.noise,
                 noise_scale=spec.noise_scale, max_time=spec.max_time, expect=expect, feedback=spec.feedback)
    return {
        "key": spec.key,
        "family": spec.family,
        "seed": spec.seed,
        "run": spec.run,
        "condition": spec.condition,
        "noise": spec.noise,
        "noise_scale": spec.noise_scale,
        "feedback": spec.feedback,
        "world": world_name(),
        "layout": scene.name,
        "expect": expect,
        "success": int(r.reached_goal),
        "reached_goal": int(r.final_distance <= SUCCESS_RADIUS),
        "believed_goal": int(r.believed_goal),
        "end_state": r.end_state,
        "final_error_m": _r(r.final_distance, 4),
        "collisions": r.collisions,
        "brushes": r.brushes,
        "max_penetration_m": _r(max((e.max_penetration_m for e in r.episodes), default=0.0), 4),
        "contact_s": _r(sum(e.duration_s for e in r.episodes), 3),
        "time_s": _r(r.time_s, 2),
        "time_to_goal_s": _r(r.time_to_goal_s, 2),
        "planning_time_s": _r(r.planning_time_s, 6),
        "states": r.states,
        "plans": r.plans,
        "checks": r.counters.get("checks"),
        "recalls": r.counters.get("recalls"),
        "fresh_plans": r.counters.get("fresh_plans"),
        "wall_s": _r(r.wall_s, 3),
        "cpu_s": _r(r.cpu_s, 3),
        "reason": r.reason,
        # for the plots (not in the CSV)
        "obstacles": scene.raw.get("obstacles", []),
        "goal": list(scene.goal),
        "start": [scene.start.x, scene.start.y, scene.start.theta],
        "path": [[round(x, 4), round(y, 4)] for x, y in r.path],
        "estimate": [[round(x, 4), round(y, 4)] for x, y in r.estimate[::3]],
        "planned": [[[round(x, 4), round(y, 4)] for x, y in poly] for poly in r.planned],
        "contacts": [[round(x, 4), round(y, 4)] for x, y in r.contacts],
        "episodes": [asdict(e) for e in r.episodes],
        "final_pose": [round(v, 4) for v in r.final_pose],
    }


def experiment_specs(family: str, runs: int, seed: int = 0, *, noise: str = "paper",
                     noise_scales: Sequence[float] = (1.0,), conditions: Sequence[str] = CONDITIONS,
                     max_time: float = 120.0, feedback: str = "scan") -> list[RunSpec]:
    """Every run of an experiment, in a fixed order (scale, run, condition)."""
    if runs < 1:
        raise ValueError("runs must be at least 1")
    if noise not in NOISE_PRESETS:
        raise ValueError(f"unknown noise preset {noise!r} (known: {', '.join(NOISE_PRESETS)})")
    for c in conditions:
        if c not in CONDITIONS:
            raise ValueError(f"condition must be one of {', '.join(CONDITIONS)}, got {c!r}")
    for s in noise_scales:
        if not (math.isfinite(s) and s >= 0):
            raise ValueError(f"noise scale must be a finite number >= 0, got {s!r}")
    if family not in FAMILIES:
        load_scenario(family)  # a clear ScenarioError now rather than in every worker
    if feedback not in ("scan", "none"):
        raise ValueError(f"feedback must be 'scan' or 'none', got {feedback!r}")
    return [RunSpec(family, seed, k, c, noise, float(s), max_time, feedback) for s in noise_scales for k in range(runs)
            for c in conditions]


# -- many runs -----------------------------------------------------------------------------------
class ExperimentInterrupted(KeyboardInterrupt):
    """Ctrl-C during an experiment: ``records`` holds the runs that finished (all saved)."""

    def __init__(self, records: list[dict[str, Any]], total: int) -> None:
        super().__init__(f"interrupted: {len(records)} of {total} runs finished")
        self.records = records
        self.total = total


class RunsFailed(RuntimeError):
    """Some runs raised: ``records`` holds the ones that finished, ``failures`` key → error."""

    def __init__(self, records: list[dict[str, Any]], failures: dict[str, str]) -> None:
        first = next(iter(failures.items()))
        super().__init__(f"{len(failures)} run(s) failed, first {first[0]}: {first[1]}")
        self.records = records
        self.failures = failures


def load_records(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The records of a ``runs.jsonl`` (a line cut short by a crash is skipped)."""
    p = Path(path)
    if not p.exists():
        return []
    out = []
    for line in p.read_text(encoding="utf-8").splitlines():
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(rec, dict) and "key" in rec:
            out.append(rec)
    return out


def _dask_client(workers: int, scheduler: str | None) -> tuple[Any, Any]:
    import logging

    try:
        distributed: Any = importlib.import_module("distributed")
    except ImportError:
        raise RuntimeError("running on Dask needs dask.distributed: pip install 'clomp[dask]' "
                           "(or --workers 0 to run in this process)") from None
    if scheduler:
        return distributed.Client(scheduler), None
    # the worker processes ignore Ctrl-C (they inherit SIG_IGN): the terminal's SIGINT reaches the
    # whole process group, and only this process should answer it (cancel, keep what finished)
    import signal

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if _main_thread() else None
    try:
        with warnings.catch_warnings():  # "port 8787 in use, using another": the scheduler's HTTP server, harmless
            warnings.simplefilter("ignore", UserWarning)
            cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                               host="127.0.0.1", dashboard_address=None, silence_logs=logging.CRITICAL)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    return distributed.Client(cluster), cluster


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def run_experiment(
    family: str = "overtaking",
    runs: int = 10,
    seed: int = 0,
    *,
    noise: str = "paper",
    noise_scales: Sequence[float] = (1.0,),
    conditions: Sequence[str] = CONDITIONS,
    max_time: float = 120.0,
    workers: int = 0,
    scheduler: str | None = None,
    out: str | os.PathLike[str] | None = None,
    resume: bool = False,
    progress: Callable[[int, int], Any] | None = None,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    feedback: str = "scan",
) -> list[dict[str, Any]]:
    """Run an experiment; the records of every run (finished before or now), in spec order.

    ``workers=0`` runs in this process; ``workers=K`` starts a local Dask cluster of K
    processes; ``scheduler`` uses an existing one. With ``out``, each record is appended
    to ``out/runs.jsonl`` as it finishes; ``resume`` keeps the ones already there (same
    specs) and runs only the rest. Ctrl-C raises :class:`ExperimentInterrupted` holding
    what finished. A worker lost mid-run has its runs retried on another. A run that raises
    does not stop the others: at the end :class:`RunsFailed` names the failures (also in
    ``out/errors.jsonl``) and holds the records that finished. ``progress``
    makes a bar from (total, already done); it gets ``update(1)`` per run and ``close()``.

    >>> recs = run_experiment("overtaking", runs=1, noise="ideal", conditions=("reactive",))
    >>> [(r["condition"], r["run"]) for r in recs]
    [('reactive', 0)]
    """
    specs = experiment_specs(family, runs, seed, noise=noise, noise_scales=noise_scales, conditions=conditions,
                             max_time=max_time, feedback=feedback)
    wanted = {s.key: s for s in specs}
    done: dict[str, dict[str, Any]] = {}
    sink = None
    if out is not None:
        folder = Path(out)
        claim_folder(folder, resume)  # refuses to resume another code version's runs
        path = folder / "runs.jsonl"
        if resume:
            for rec in load_records(path):
                if rec["key"] in wanted:
                    done[rec["key"]] = rec
            # rewrite clean (drops a line cut short by a crash)
            path.write_text("".join(json.dumps(r, allow_nan=False) + "\n" for r in done.values()), encoding="utf-8")
        else:
            path.write_text("", encoding="utf-8")
        sink = open(path, "a", encoding="utf-8")
    todo = [s for s in specs if s.key not in done]
    bar = progress(len(specs), len(done)) if progress else None

    def keep(rec: dict[str, Any]) -> None:
        done[rec["key"]] = rec
        if sink is not None:
            sink.write(json.dumps(rec, allow_nan=False) + "\n")
            sink.flush()
        if bar is not None:
            bar.update(1)
        if on_record is not None:
            on_record(rec)

    failures: dict[str, str] = {}

    def fail(key: str, exc: BaseException) -> None:
        failures[key] = f"{type(exc).__name__}: {exc}"
        if out is not None:
            with open(Path(out) / "errors.jsonl", "a", encoding="utf-8") as fh:
                fh.write(json.dumps({"key": key, "error": failures[key]}) + "\n")
        if bar is not None:
            bar.update(1)

    if out is not None and (Path(out) / "errors.jsonl").exists():
        (Path(out) / "errors.jsonl").unlink()
    client = cluster = None
    try:
        if todo and (workers > 0 or scheduler):
            client, cluster = _dask_client(workers, scheduler)
            as_completed: Any = importlib.import_module("distributed").as_completed
            futures = client.map(run_spec, todo, key=["clomp-" + s.key for s in todo], pure=False, retries=2)
            for fut in as_completed(futures):
                if fut.status == "error":
                    fail(fut.key.removeprefix("clomp-"), fut.exception())
                else:
                    keep(fut.result())
        else:
            for s in todo:
                try:
                    rec = run_spec(s)
                except Exception as exc:  # one broken run must not cost the others
                    fail(s.key, exc)
                else:
                    keep(rec)
    except KeyboardInterrupt:
        raise ExperimentInterrupted([done[s.key] for s in specs if s.key in done], len(specs)) from None
    finally:
        if bar is not None:
            bar.close()
        if sink is not None:
            sink.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    if failures:
        raise RunsFailed([done[s.key] for s in specs if s.key in done], failures)
    return [done[s.key] for s in specs]

