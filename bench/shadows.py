"""How many plans drive through a LiDAR shadow: checked with geometry of its own.

For every scan in a folder (goal 1 m ahead, the default planner) the plan's body is
sampled along each task (every 1 cm of a straight, every 0.02 rad of a turn; the real
body inset by ``--inset``, default 1 cm, on a 1 cm grid) and each sample point is
tested against the scan's returns within the horizon (the robot's own returns left
out): a point lies in a shadow when the returns next to its bearing on both sides are
nearer than it and no more than ``--gap`` (default 2°) apart (adjacent beams of one
surface). Counted: plans whose body enters a shadow before their last task, and plans
that claim the goal (``reached_goal``) with a body that enters one anywhere.

It shares no geometry with :mod:`clomp.planner.visibility` (run it on a tree without
that module to count the plans before the rule). With ``--cpu`` it also prints the
median thread CPU per scan of the planner's known-free check (building the table and
every ``clear`` call), when the tree has it.

    PYTHONPATH=. python bench/shadows.py /path/to/scans/corridor-2023-10-25 --cpu
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from clomp.planner import Configurator, load_scan


def _returns(pts: np.ndarray, horizon: float, robot: Any) -> tuple[np.ndarray, np.ndarray]:
    r = np.hypot(pts[:, 0], pts[:, 1])
    own = (pts[:, 0] > -robot.rear_offset) & (pts[:, 0] < robot.front_offset) & (np.abs(pts[:, 1]) < robot.width / 2)
    keep = (r <= horizon) & (r > 1e-3) & ~own
    b = np.arctan2(pts[keep, 1], pts[keep, 0])
    o = np.argsort(b)
    return b[o], r[keep][o]


def _shadowed(px: np.ndarray, py: np.ndarray, b: np.ndarray, r: np.ndarray, gap: float) -> np.ndarray:
    """Per point: are the returns on both sides of its bearing, no more than ``gap``
    apart, both nearer than the point?"""
    if len(b) < 2:
        return np.zeros(len(px), dtype=bool)
    beta = np.arctan2(py, px)
    rho = np.hypot(px, py)
    n = len(b)
    hi = np.searchsorted(b, beta, side="left")  # first return at or after the bearing
    lo = hi - 1
    bl = np.where(lo < 0, b[lo % n] - 2 * np.pi, b[lo % n])
    bh = np.where(hi >= n, b[hi % n] + 2 * np.pi, b[hi % n])
    rl, rh = r[lo % n], r[hi % n]
    return (bh - bl <= gap) & (rl < rho) & (rh < rho)


def _body_grid(robot: Any, inset: float) -> np.ndarray:
    us = np.arange(-robot.rear_offset + inset, robot.front_offset - inset + 1e-9, 0.01)
    vs = np.arange(-robot.width / 2 + inset, robot.width / 2 - inset + 1e-9, 0.01)
    uu, vv = np.meshgrid(us, vs)
    return np.c_[uu.ravel(), vv.ravel()]


def _poses(step: Any) -> list[tuple[float, float, float]]:
    s, e = step.start, step.end
    if step.task.value == "STRAIGHT":
        d = math.hypot(e.x - s.x, e.y - s.y)
        n = max(1, int(math.ceil(d / 0.01)))
        return [(s.x + (e.x - s.x) * k / n, s.y + (e.y - s.y) * k / n, s.theta) for k in range(n + 1)]
    turned = math.atan2(math.sin(e.theta - s.theta), math.cos(e.theta - s.theta))
    if step.task.value == "LEFT" and turned < 0:
        turned += 2 * math.pi
    if step.task.value == "RIGHT" and turned > 0:
        turned -= 2 * math.pi
    n = max(1, int(math.ceil(abs(turned) / 0.02)))
    return [(s.x, s.y, s.theta + turned * k / n) for k in range(n + 1)]


def step_enters_shadow(step: Any, grid: np.ndarray, b: np.ndarray, r: np.ndarray, gap: float) -> bool:
    for x, y, th in _poses(step):
        c, s = math.cos(th), math.sin(th)
        px = x + grid[:, 0] * c - grid[:, 1] * s
        py = y + grid[:, 0] * s + grid[:, 1] * c
        if _shadowed(px, py, b, r, gap).any():
            return True
    return False


def _cpu_probe() -> Any:
    """Wrap the known-free check (when the tree has it) to add up its thread CPU."""
    try:
        from clomp.planner import visibility
    except ImportError:
        return None
    spent = [0]
    cls = visibility.KnownFree
    init, clear = cls.__init__, cls.clear

    def timed_init(self: Any, *a: Any, **k: Any) -> None:
        t = time.thread_time_ns()
        init(self, *a, **k)
        spent[0] += time.thread_time_ns() - t

    def timed_clear(self: Any, *a: Any, **k: Any) -> bool:
        t = time.thread_time_ns()
        out = clear(self, *a, **k)
        spent[0] += time.thread_time_ns() - t
        return out

    cls.__init__, cls.clear = timed_init, timed_clear  # type: ignore[method-assign]
    return spent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--inset", type=float, default=0.01, help="the body inset (m), default 0.01")
    ap.add_argument("--gap", type=float, default=2.0, help="adjacent returns at most this far apart (deg), default 2")
    ap.add_argument("--cpu", action="store_true", help="median thread CPU of the known-free check per scan")
    args = ap.parse_args(argv)
    files = sorted(args.folder.glob("*.dat"))
    if not files:
        print(f"shadows: no *.dat under {args.folder}", file=sys.stderr)
        return 2
    spent = _cpu_probe() if args.cpu else None
    conf = Configurator()
    robot = conf.robot
    grid = _body_grid(robot, args.inset)
    gap = math.radians(args.gap)
    before_last = claims = reached = 0
    cpu: list[float] = []
    plan_cpu: list[float] = []
    for f in files:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pts = load_scan(f)
            if spent is not None:
                spent[0] = 0
            t = time.thread_time_ns()
            res = conf.plan(pts, (1.0, 0.0))
            plan_cpu.append((time.thread_time_ns() - t) / 1e6)
        if spent is not None:
            cpu.append(spent[0] / 1e6)
        b, r = _returns(pts, robot.sensor_range, robot)
        steps = res.steps
        entered = [step_enters_shadow(s, grid, b, r, gap) for s in steps]
        before_last += any(entered[:-1])
        reached += res.reached_goal
        claims += res.reached_goal and any(entered)
    print(f"{args.folder.name}: {len(files)} plans, {reached} claim the goal; "
          f"{before_last} enter a shadow before their last task, {claims} claim the goal through one "
          f"(body inset {args.inset * 100:g} cm, adjacent returns <= {args.gap:g} deg)")
    print(f"plan thread CPU median {statistics.median(plan_cpu):.3f} ms")
    if cpu:
        print(f"known-free check thread CPU per scan: median {statistics.median(cpu):.3f} ms, "
              f"p90 {float(np.percentile(cpu, 90)):.3f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
