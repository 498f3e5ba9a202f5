"""The paper's experiment: planning vs a single reactive loop on randomised layouts.

:func:`run_once` drives one condition (``"planning"``: the :class:`~runtime.supervision.supervisor.
Supervisor` with a :class:`~planner.Configurator`; ``"reactive"``: the
:class:`~runtime.experiment.reactive.ReactiveController`) on a :class:`~runtime.robots.sim.SimRobot` in one
scene and measures it on the ground truth. :func:`run_experiment` jitters the scenario's
boxes (position and size) once per run, runs both conditions on the same layouts with the
same noise seed (paired), in several processes if asked, and summarises them as the
paper's table, with a paired t-test on collisions.

A run *reaches the goal* when its controller stops at the goal and the robot truly is
within ``SUCCESS_RADIUS`` of it (a robot that was knocked about can believe it is there
when it is not).
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from formal.geometry import compose
from formal.model import Pose
from planner.configurator import Configurator
from planner.scenarios import Scene, load_scenario, parse_scenario
from runtime.experiment.plots import RunTrace, plot_runs
from runtime.experiment.reactive import ReactiveController
from runtime.robots.sim import NoiseConfig, SimRobot
from runtime.supervision.supervisor import Supervisor

__all__ = [
    "CONDITIONS",
    "SUCCESS_RADIUS",
    "PAPER",
    "RunResult",
    "ExperimentResult",
    "jitter_scene",
    "run_once",
    "run_experiment",
    "paired_ttest",
]

CONDITIONS = ("planning", "reactive")
SUCCESS_RADIUS = 0.1
# the paper's figures (overtaking, real robot, 10 runs per condition)
PAPER: dict[str, dict[str, Any]] = {
    "planning": {"reached_goal": 10, "runs": 10, "collisions": 2, "planning_time_s": (0.064, 0.009), "states": (32.9, 1.758)},
    "reactive": {"reached_goal": 0, "runs": 10, "collisions": 8},
    "ttest": {"t": -1.747, "p": 0.111},
}


@dataclass
class RunResult:
    """One run of one condition, measured on the simulator's ground truth (world frame)."""

    condition: str
    run: int
    seed: int
    scene: Scene
    end_state: str
    reason: str
    reached_goal: bool
    final_distance: float
    collisions: int
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
    final_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    report: Any = field(default=None, repr=False)

    def trace(self) -> RunTrace:
        """The run as a picture."""
        verdict = "goal" if self.reached_goal else "failed"
        title = f"run {self.run}: {verdict}, {self.collisions} collision{'s' if self.collisions != 1 else ''}"
        st = self.scene.start
        poses = [(st.x, st.y, st.theta), self.final_pose]
        return RunTrace(self.scene, title, self.path, self.contacts, self.planned, self.estimate, poses, self.reached_goal)

    def row(self) -> dict[str, Any]:
        """The CSV row."""
        return {
            "condition": self.condition,
            "run": self.run,
            "seed": self.seed,
            "reached_goal": int(self.reached_goal),
            "end_state": self.end_state,
            "collisions": self.collisions,
            "planning_time_s": "" if self.planning_time_s is None else f"{self.planning_time_s:.6f}",
            "states": "" if self.states is None else self.states,
            "plans": self.plans,
            "time_s": f"{self.time_s:.2f}",
            "time_to_goal_s": "" if self.time_to_goal_s is None else f"{self.time_to_goal_s:.2f}",
            "final_distance_m": f"{self.final_distance:.4f}",
            "wall_s": f"{self.wall_s:.3f}",
            "obstacles": json.dumps(self.scene.raw.get("obstacles", []), separators=(",", ":")),
            "reason": self.reason,
        }


def jitter_scene(scene: Scene, rng: np.random.Generator, position: float = 0.05,
                 size: tuple[float, float] = (0.8, 1.5)) -> Scene:
    """A copy of ``scene`` whose boxes are moved by up to ``position`` m in x and y and
    scaled by a factor in ``size`` along each side (walls, circles, polygons stay)."""
    raw = json.loads(json.dumps(scene.raw))
    for o in raw.get("obstacles", []):
        if o.get("type") != "box":
            continue
        cx, cy = o["center"]
        sx, sy = o["size"]
        o["center"] = [round(cx + rng.uniform(-position, position), 4), round(cy + rng.uniform(-position, position), 4)]
        o["size"] = [round(sx * rng.uniform(*size), 4), round(sy * rng.uniform(*size), 4)]
    return parse_scenario(raw, scene.name)


def _world(start: Pose, p: Pose) -> tuple[float, float]:
    w = compose(start, p)
    return (w.x, w.y)


def run_once(
    scene: Scene,
    condition: str = "planning",
    seed: int | None = 0,
    *,
    run: int = 0,
    noise: NoiseConfig | None = None,
    max_time: float = 120.0,
    configurator: Configurator | None = None,
    keep_report: bool = False,
) -> RunResult:
    """Run one condition in ``scene`` on a fresh simulated robot; see the module docstring."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {', '.join(CONDITIONS)}, got {condition!r}")
    conf = configurator or Configurator()
    sim = SimRobot(scene, conf.robot, noise=noise, seed=seed)
    goal = tuple(scene.goal_in_robot_frame())
    t0 = time.perf_counter()
    planned: list[list[tuple[float, float]]] = []
    plan_time = states = None
    plans = 0
    if condition == "planning":
        sup = Supervisor(sim, goal, conf)  # type: ignore[arg-type]
        report: Any = sup.run(max_time=max_time)
        for rec in report.plans:
            poly = [_world(sim.start_pose, rec.to_frame(rec.result.map[i].end)) for i in rec.result.plan.states]
            planned.append(poly)
        if report.plans:
            plan_time = report.plans[0].result.planning_time_s
            states = report.plans[0].result.states
        plans = len(report.plans)
        end_state, reason = report.state.value, report.reason
    else:
        report = ReactiveController(sim, goal, conf.robot).run(max_time=max_time)  # type: ignore[arg-type]
        end_state, reason = report.state, report.reason
    wall = time.perf_counter() - t0
    true = sim.pose
    dist = math.hypot(true.x - scene.goal[0], true.y - scene.goal[1])
    reached = bool(report.reached_goal and dist <= SUCCESS_RADIUS)
    if report.reached_goal and not reached:
        reason = f"{reason}, but truly {dist:.3f} m from the goal"
    path = [(x, y) for _, x, y, _ in sim.trajectory[::5]] + [(true.x, true.y)]
    estimate = [_world(sim.start_pose, Pose(x, y, th)) for _, x, y, th in report.trajectory]
    return RunResult(
        condition, run, -1 if seed is None else seed, scene, end_state, reason, reached, dist, sim.collisions,
        [(c.x, c.y) for c in sim.contacts], report.time_s, report.time_s if reached else None, plan_time, states,
        plans, path, estimate, planned, wall, (true.x, true.y, true.theta), report if keep_report else None,
    )


def paired_ttest(a: list[float], b: list[float]) -> dict[str, Any]:
    """Paired t-test (``scipy.stats.ttest_rel``) of ``a`` against ``b``.

    When every paired difference is the same the statistic is undefined; the result then
    has ``t`` and ``p`` None and a ``note`` saying so (no difference at all when the
    common difference is 0).
    """
    from scipy.stats import ttest_rel

    if len(a) != len(b):
        raise ValueError("paired samples must have the same length")
    d = np.asarray(a, float) - np.asarray(b, float)
    if len(d) < 2:
        return {"t": None, "p": None, "n": len(d), "note": "fewer than two pairs"}
    if np.all(d == d[0]):
        note = "no difference in any pair" if d[0] == 0 else f"every pair differs by {d[0]:g}"
        return {"t": None, "p": None, "n": len(d), "note": f"undefined: {note} (zero variance)"}
    res = ttest_rel(a, b)
    return {"t": float(res.statistic), "p": float(res.pvalue), "n": len(d), "note": ""}


def _mean_sd(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"mean": None, "sd": None}
    arr = np.asarray(values, float)
    return {"mean": float(arr.mean()), "sd": float(arr.std(ddof=1)) if len(arr) > 1 else 0.0}


@dataclass
class ExperimentResult:
    """All runs of an experiment and their summary."""

    scenario: str
    seed: int
    runs: list[RunResult]
    wall_s: float

    def condition(self, name: str) -> list[RunResult]:
        """The runs of one condition, by run number."""
        return sorted((r for r in self.runs if r.condition == name), key=lambda r: r.run)

    def summary(self) -> dict[str, Any]:
        """The JSON form: ``{"conditions": {name: {...}}, "ttest_collisions": {...}, ...}``."""
        conds: dict[str, Any] = {}
        for name in CONDITIONS:
            rs = self.condition(name)
            if not rs:
                continue
            sim_time = sum(r.time_s for r in rs)
            wall = sum(r.wall_s for r in rs)
            conds[name] = {
                "runs": len(rs),
                "reached_goal": sum(r.reached_goal for r in rs),
                "collisions": sum(r.collisions for r in rs),
                "runs_with_collision": sum(r.collisions > 0 for r in rs),
                "planning_time_s": _mean_sd([r.planning_time_s for r in rs if r.planning_time_s is not None]),
                "states": _mean_sd([float(r.states) for r in rs if r.states is not None]),
                "plans": _mean_sd([float(r.plans) for r in rs]) if name == "planning" else {"mean": None, "sd": None},
                "time_to_goal_s": _mean_sd([r.time_to_goal_s for r in rs if r.time_to_goal_s is not None]),
                "speedup_vs_real_time": sim_time / wall if wall > 0 else None,
            }
        out: dict[str, Any] = {"scenario": self.scenario, "seed": self.seed, "conditions": conds}
        p, r = self.condition("planning"), self.condition("reactive")
        if p and r and len(p) == len(r):
            out["ttest_collisions"] = paired_ttest([x.collisions for x in p], [x.collisions for x in r])
        out["success_radius_m"] = SUCCESS_RADIUS
        out["wall_s"] = self.wall_s
        return out

    def table(self) -> str:
        """The paper's table, this experiment next to the paper's figures."""
        s = self.summary()
        c = s["conditions"]

        def ms(d: dict[str, Any], fmt: str) -> str:
            return "—" if d["mean"] is None else f"{d['mean']:{fmt}} ± {d['sd']:{fmt}}"

        def col(name: str, key: str) -> str:
            if name not in c:
                return "—"
            d = c[name]
            if key == "reached":
                return f"{d['reached_goal']}/{d['runs']}"
            if key == "collisions":
                return f"{d['collisions']} (in {d['runs_with_collision']} runs)"
            if key == "plan_t":
                return ms(d["planning_time_s"], ".3f")
            if key == "states":
                return ms(d["states"], ".1f")
            return ms(d["time_to_goal_s"], ".1f")

        pp, pr = PAPER["planning"], PAPER["reactive"]
        paper = {
            "reached": f"{pp['reached_goal']}/{pp['runs']} | {pr['reached_goal']}/{pr['runs']}",
            "collisions": f"{pp['collisions']} brushes | {pr['collisions']}",
            "plan_t": f"{pp['planning_time_s'][0]:.3f} ± {pp['planning_time_s'][1]:.3f} | —",
            "states": f"{pp['states'][0]:.1f} ± {pp['states'][1]:.1f} | —",
            "ttg": "— | —",
        }
        rows = [
            ("runs reaching the goal", "reached"),
            ("collisions (total)", "collisions"),
            ("planning time (s, first plan)", "plan_t"),
            ("states (first plan)", "states"),
            ("time to goal (s, simulated)", "ttg"),
        ]
        w0, w1, w2 = 30, 20, 22
        lines = [
            f"{self.scenario}: {len(self.condition('planning')) or len(self.condition('reactive'))} randomised layouts, seed {self.seed}",
            f"{'':<{w0}} {'planning':<{w1}} {'reactive':<{w2}} paper (planning | reactive)",
        ]
        for label, key in rows:
            lines.append(f"{label:<{w0}} {col('planning', key):<{w1}} {col('reactive', key):<{w2}} {paper[key]}")
        if "planning" in c:
            lines.append(f"{'replans (plans per run − 1)':<{w0}} {ms({k: (v - 1 if k == 'mean' and v is not None else v) for k, v in c['planning']['plans'].items()}, '.1f'):<{w1}}")
        t = s.get("ttest_collisions")
        if t is not None:
            mine = f"T = {t['t']:.3f}, p = {t['p']:.4f}" if t["t"] is not None else t["note"]
            lines.append(f"paired t-test on collisions (planning − reactive, n={t['n']}): {mine}"
                         f"   [paper: T = {PAPER['ttest']['t']}, p = {PAPER['ttest']['p']}]")
        speed = [f"{n} {c[n]['speedup_vs_real_time']:.0f}×" for n in c if c[n]["speedup_vs_real_time"]]
        lines.append(f"goal reached = controller stopped at the goal and truly within {SUCCESS_RADIUS} m of it; "
                     f"simulated vs real time: {', '.join(speed)}")
        return "\n".join(lines)

    def write_csv(self, path: str | os.PathLike[str]) -> None:
        """One row per run and condition."""
        rows = [r.row() for name in CONDITIONS for r in self.condition(name)]
        with open(path, "w", newline="", encoding="utf-8") as fh:
            if not rows:
                return
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)

    def write_plots(self, folder: str | os.PathLike[str]) -> list[Path]:
        """One PNG per condition (a panel per run); returns the files written."""
        out = []
        for name in CONDITIONS:
            rs = self.condition(name)
            if not rs:
                continue
            p = Path(folder) / f"{self.scenario}_{name}.png"
            reached = sum(r.reached_goal for r in rs)
            hits = sum(r.collisions for r in rs)
            plot_runs([r.trace() for r in rs], p,
                      f"{self.scenario} — {name}: goal reached in {reached}/{len(rs)} runs, {hits} collisions "
                      f"(solid: executed, dashed: planned, ♥ target, ★ collision)")
            out.append(p)
        return out


def _job(args: tuple[Scene, str, int, int, float]) -> RunResult:
    scene, condition, run, seed, max_time = args
    return run_once(scene, condition, seed, run=run, max_time=max_time)


def run_experiment(
    scenario: str | os.PathLike[str] = "overtaking",
    runs: int = 10,
    seed: int = 0,
    *,
    jobs: int | None = None,
    max_time: float = 120.0,
    conditions: tuple[str, ...] = CONDITIONS,
    jitter: bool = True,
) -> ExperimentResult:
    """Run every condition on ``runs`` jittered layouts of ``scenario`` (paired by run)."""
    if runs < 1:
        raise ValueError("runs must be at least 1")
    base = load_scenario(scenario)
    tasks = []
    for k in range(runs):
        rng = np.random.default_rng([seed, k])
        scene = jitter_scene(base, rng) if jitter else base
        noise_seed = int(np.random.default_rng([seed, k, 1]).integers(2**31))
        for cond in conditions:
            tasks.append((scene, cond, k, noise_seed, max_time))
    t0 = time.perf_counter()
    jobs = jobs if jobs is not None else min(len(tasks), os.cpu_count() or 1)
    if jobs <= 1:
        results = [_job(t) for t in tasks]
    else:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            results = list(pool.map(_job, tasks))
    return ExperimentResult(base.name, seed, results, time.perf_counter() - t0)
