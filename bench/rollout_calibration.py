"""How far a task truly ends from where it was meant to: the execution world beside the
sampled rollouts of the same noise preset.

Run: ``python bench/rollout_calibration.py [--runs 20] [--families doorway clutter]
[--noise harsh] [--samples 300] [--seed 0]``. World: planning runs of the experiment's layouts driven by the
supervisor (scan feedback on), each run's log read back; for every task that ended by
its own criterion, the truth's motion against the estimate's (what the supervisor
believed it did): a turn's relative angle error, a straight's relative length error and
its sideways error per metre. Rollouts: :func:`clomp.planner.probabilistic.sample_map`'s
noisy rollouts (:class:`clomp.planner.probabilistic.RolloutNoise` of the same preset) of a
90° turn and a straight to the rim in an empty scene, against the noise-free task, with
the preset's terms and with the closed-loop terms fitted to the world
(:data:`clomp.planner.robust.CLOSED_LOOP_TERMS`).
Prints mean and standard deviation of each; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
import time
from typing import Any

import numpy as np

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Disturbance, Pose, TaskKind
from clomp.planner import Configurator
from clomp.planner.perception import perceive
from clomp.planner.rollout import simulate
from clomp.planner.probabilistic import RolloutNoise, _rollout, _World
from clomp.planner.robust import closed_loop_noise
from clomp.planner.robot_model import RobotModel
from clomp.runtime.experiment.layouts import make_layout
from clomp.runtime.experiment.runner import run_once


def world_errors(families: list[str], runs: int, noise: str) -> dict[str, list[float]]:
    """Per-task errors of the truth against the estimate, over the runs' logs."""
    out: dict[str, list[float]] = {"turn": [], "length": [], "sideways": []}
    for family in families:
        for k in range(runs):
            layout = make_layout(family, 0, k)
            fd, path = tempfile.mkstemp(suffix=".jsonl")
            os.close(fd)
            try:
                run_once(layout.scene, "planning", seed=k, run=k, noise=noise, configurator=Configurator(),
                         expect=layout.expect, log=path)
                with open(path, encoding="utf-8") as fh:
                    records = [json.loads(line) for line in fh]
            finally:
                os.unlink(path)
            for key, values in task_errors(records).items():
                out[key].extend(values)
    return out


def task_errors(records: list[dict[str, Any]]) -> dict[str, list[float]]:
    """The errors of every task of one run log (``clomp run``'s records) that ended by its
    own criterion: a turn's relative angle error (truth / believed - 1, turns of more
    than 0.2 rad), a straight's relative length error and its sideways error per metre
    (straights of more than 5 cm), the truth against the supervisor's estimate.

    >>> start = {"event": "task", "phase": "start", "task": "STRAIGHT", "pose": [0, 0, 0], "truth": [0, 0, 0]}
    >>> end = {"event": "task", "phase": "end", "task": "STRAIGHT", "pose": [1, 0, 0], "truth": [1.1, 0.05, 0]}
    >>> {k: [round(x, 3) for x in v] for k, v in task_errors([start, end]).items()}
    {'turn': [], 'length': [0.1], 'sideways': [0.05]}
    """
    out: dict[str, list[float]] = {"turn": [], "length": [], "sideways": []}
    start: dict[str, Any] | None = None
    for rec in records:
        if rec.get("event") != "task":
            continue
        if rec.get("phase") == "start":
            start = rec
            continue
        if rec.get("phase") != "end" or start is None:
            start = None
            continue
        p0, p1, t0, t1 = start["pose"], rec["pose"], start["truth"], rec["truth"]
        if rec["task"] == "STRAIGHT":
            d = math.hypot(p1[0] - p0[0], p1[1] - p0[1])
            if d > 0.05:
                dx, dy = t1[0] - t0[0], t1[1] - t0[1]
                c, s = math.cos(t0[2]), math.sin(t0[2])
                out["length"].append((dx * c + dy * s) / d - 1)
                out["sideways"].append((-dx * s + dy * c) / d)
        else:
            believed = wrap_angle(p1[2] - p0[2])
            if abs(believed) > 0.2:
                out["turn"].append(wrap_angle(t1[2] - t0[2]) / believed - 1)
        start = None
    return out


def rollout_errors(noise: str | RolloutNoise, samples: int, seed: int = 0) -> dict[str, list[float]]:
    """The same errors of sampled rollouts against the noise-free task (empty scene)."""
    robot = RobotModel()
    nz = RolloutNoise.preset(noise) if isinstance(noise, str) else noise
    goal = Disturbance.goal(3.0, 0.0)
    empty = perceive(np.zeros((0, 2)), robot.sensor_range, robot.cluster_distance)
    start = Pose(0.0, 0.0, 0.0)
    turn = simulate(TaskKind.LEFT, start, goal, empty, robot)
    straight = simulate(TaskKind.STRAIGHT, start, goal, empty, robot)
    rng = np.random.default_rng(seed)
    out: dict[str, list[float]] = {"turn": [], "length": [], "sideways": []}
    for _ in range(samples):
        r = np.random.default_rng(rng.integers(2**63))
        bl, br = r.normal(0.0, nz.wheel_bias, 2)  # as sample_map draws a world
        w = _World(empty, float(bl), float(br), float(r.normal(0.0, nz.drift)), r)
        o = _rollout(TaskKind.LEFT, start, goal, w, robot, nz)
        out["turn"].append(o.end.theta / turn.end.theta - 1)
        o = _rollout(TaskKind.STRAIGHT, start, goal, w, robot, nz)
        out["length"].append(o.end.x / straight.end.x - 1)
        out["sideways"].append(o.end.y / straight.end.x)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=20, help="runs per family (default 20)")
    ap.add_argument("--families", nargs="+", default=["doorway", "clutter"])
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--samples", type=int, default=300, help="rollouts (default 300)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the rollouts (default 0)")
    args = ap.parse_args(argv)
    w0, c0 = time.perf_counter(), time.thread_time()
    world = world_errors(args.families, args.runs, args.noise)
    roll = rollout_errors(args.noise, args.samples, args.seed)
    fitted = rollout_errors(closed_loop_noise(args.noise), args.samples, args.seed)
    print(f"task end errors at noise {args.noise}: execution world ({', '.join(args.families)}, {args.runs} runs each; "
          f"truth against the supervisor's estimate) beside {args.samples} sampled rollouts (against the noise-free task) "
          f"of the preset and of clomp.planner.robust.closed_loop_noise({args.noise!r})")
    print(f"  {'error':<32} {'world n':>8} {'mean':>8} {'sd':>8}   {'preset mean':>11} {'sd':>8}   {'closed-loop mean':>16} {'sd':>8}")
    names = {"turn": "turn angle, relative", "length": "straight length, relative", "sideways": "straight sideways, per metre"}
    for key, label in names.items():
        w, r, f = np.array(world[key]), np.array(roll[key]), np.array(fitted[key])
        wm, ws = (float(w.mean()), float(w.std())) if len(w) else (math.nan, math.nan)
        print(f"  {label:<32} {len(w):>8d} {wm:>8.4f} {ws:>8.4f}   {float(r.mean()):>11.4f} {float(r.std()):>8.4f}   "
              f"{float(f.mean()):>16.4f} {float(f.std()):>8.4f}")
    print(f"wall {time.perf_counter() - w0:.0f} s, thread CPU {time.thread_time() - c0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
