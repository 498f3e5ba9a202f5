"""Honest reach on recorded scans, scan by scan: why a plan does not reach the goal.

Run: ``python bench/honest_reach.py [--scans DIR] [--goal X,Y] [--oracle] [--only-missed]``.
Prints figures; asserts nothing.

For every scan with data it plans once (the default Configurator, goal 1 m ahead) and
sorts the outcome:

- ``honest``: the goal reached with the body inside the sensed disc and over no sensed
  point (the independent sweep of ``tests/planner/sweepcheck.py``);
- ``left-disc`` / ``over-point``: the plan reaches the goal but the sweep finds the body
  outside the disc or over a point (never seen since the first wave);
- otherwise the stop reason: ``frontier`` (the plan ends on the rim of the disc: the
  way needs unseen space), ``budget`` (``max_states`` spent), ``exhausted`` (no
  obstacle-free transition left), ``goal-blocked`` (the goal inside a perceived box).

Beside each it prints the authors' C++ outcome from ``cpp_anchor.csv``. With
``--oracle`` it also asks whether *any* motion of the body (forward straights and spins
in place, 1 cm clearance, inside the disc) reaches the goal: a search of the
configuration space on a 1 cm grid and 64 headings (scipy's FFT convolution for the
obstacle slices). A scan the oracle cannot solve is out of reach for every planner that
stays where the robot has seen, so ``honest / oracle`` bounds what is left to gain.
"""

from __future__ import annotations

import argparse
import collections
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "planner"))

from clomp.planner import Configurator, load_scan  # noqa: E402
from sweepcheck import check_states  # noqa: E402

DEFAULT_SCANS = ROOT.parent / "shared" / "data" / "scans" / "corridor-2023-10-25"
ANCHOR = ROOT.parent / "shared" / "reference" / "cpp_anchor.csv"


def classify(pts: np.ndarray, conf: Configurator, goal: tuple[float, float]) -> tuple[str, object]:
    """The outcome class of one plan (see the module docstring) and the plan result."""
    r = conf.plan(pts, goal)
    check = check_states(pts, r.steps, conf.robot)
    if r.reached_goal:
        if check.ok:
            return "honest", r
        return ("over-point" if check.over_points else "left-disc"), r
    if r.goal_blocked:
        return "goal-blocked", r
    return r.stop_reason, r


class Oracle:
    """Reachability of the goal by any forward/spin motion inside the sensed disc."""

    def __init__(self, robot: object, cell: float = 0.01, headings: int = 64) -> None:
        from scipy.signal import fftconvolve

        self._conv = fftconvolve
        self.cell, self.nt = cell, headings
        self.rng = float(robot.sensor_range)  # type: ignore[attr-defined]
        self.rear = float(robot.rear_offset)  # type: ignore[attr-defined]
        self.front = float(robot.front_offset)  # type: ignore[attr-defined]
        self.half = float(robot.width) / 2  # type: ignore[attr-defined]
        self.clear = float(robot.clearance)  # type: ignore[attr-defined]
        self.n = int(round(2 * self.rng / cell)) + 1
        self.c0 = self.n // 2
        g = (np.arange(self.n) - self.c0) * cell
        self.gx, self.gy = np.meshgrid(g, g, indexing="xy")
        self.kernels = [self._kernel(2 * math.pi * k / headings) for k in range(headings)]
        self.disc = [self._disc(2 * math.pi * k / headings) for k in range(headings)]
        step = 6  # cells per forward move (C-space obstacles are > 20 cells wide)
        self.moves = [
            (int(round(step * math.cos(2 * math.pi * k / headings))), int(round(step * math.sin(2 * math.pi * k / headings))))
            for k in range(headings)
        ]

    def _kernel(self, th: float) -> np.ndarray:
        m = int(math.ceil(0.25 / self.cell))
        o = np.arange(-m, m + 1) * self.cell
        kx, ky = np.meshgrid(o, o, indexing="xy")
        c, s = math.cos(th), math.sin(th)
        u, v = -kx * c - ky * s, kx * s - ky * c  # a point at offset -k, in the body frame
        cl = self.clear
        return ((u >= -self.rear - cl) & (u <= self.front + cl) & (np.abs(v) <= self.half + cl)).astype(float)

    def _disc(self, th: float) -> np.ndarray:
        c, s = math.cos(th), math.sin(th)
        ok = np.ones((self.n, self.n), dtype=bool)
        for a, b in ((-self.rear, -self.half), (self.front, -self.half), (self.front, self.half), (-self.rear, self.half)):
            ok &= np.hypot(self.gx + a * c - b * s, self.gy + a * s + b * c) <= self.rng
        return ok

    def _shift(self, a: np.ndarray, dx: int, dy: int) -> np.ndarray:
        n = self.n
        out = np.zeros_like(a)
        out[max(dy, 0) : n + min(dy, 0), max(dx, 0) : n + min(dx, 0)] = a[max(-dy, 0) : n + min(-dy, 0), max(-dx, 0) : n + min(-dx, 0)]
        return out

    def reachable(self, pts: np.ndarray, goal: tuple[float, float], tol: float = 0.05) -> bool:
        """True when some cell within ``tol`` of ``goal`` is reachable at some heading."""
        img = np.zeros((self.n, self.n))
        p = pts[np.hypot(pts[:, 0], pts[:, 1]) <= self.rng] if len(pts) else pts
        if len(p):
            own = (p[:, 0] > -self.rear) & (p[:, 0] < self.front) & (np.abs(p[:, 1]) < self.half)
            p = p[~own]
            ix = np.clip(np.round(p[:, 0] / self.cell).astype(int) + self.c0, 0, self.n - 1)
            iy = np.clip(np.round(p[:, 1] / self.cell).astype(int) + self.c0, 0, self.n - 1)
            img[iy, ix] = 1.0
        free = np.array([(self._conv(img, self.kernels[k], mode="same") < 0.5) & self.disc[k] for k in range(self.nt)])
        seen = np.zeros_like(free)
        seen[0, self.c0, self.c0] = free[0, self.c0, self.c0]
        target = np.hypot(self.gx - goal[0], self.gy - goal[1]) <= tol
        while seen.any():
            before = int(seen.sum())
            for k in range(self.nt):
                for _ in range(3):
                    seen[k] |= self._shift(seen[k], *self.moves[k]) & free[k]
            seen |= (np.roll(seen, 1, axis=0) | np.roll(seen, -1, axis=0)) & free
            if (seen.any(axis=0) & target).any():
                return True
            if int(seen.sum()) == before:
                return False
        return False


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=Path, default=DEFAULT_SCANS, help="folder of recorded scans")
    ap.add_argument("--goal", default="1,0", help="goal x,y in the robot frame (default 1,0)")
    ap.add_argument("--oracle", action="store_true", help="also search the configuration space for any way to the goal")
    ap.add_argument("--only-missed", action="store_true", help="list only the scans not reached honestly")
    args = ap.parse_args(argv)
    goal = tuple(float(v) for v in args.goal.split(","))
    assert len(goal) == 2
    anchor: dict[str, dict[str, str]] = {}
    if ANCHOR.is_file() and args.scans.resolve() == DEFAULT_SCANS.resolve():
        with ANCHOR.open() as f:
            anchor = {row["scan"]: row for row in csv.DictReader(f)}
    conf = Configurator()
    oracle = Oracle(conf.robot) if args.oracle else None
    counts: collections.Counter[str] = collections.Counter()
    t0 = time.perf_counter()
    print(f"{'scan':<12} {'clomp':<13} {'states':>6} {'plan':<14} {'to goal':>7}  {'C++':<10} {'C++ plan':<14}" + ("  oracle" if oracle else ""))
    for f in sorted(args.scans.glob("*.dat")):
        pts = load_scan(f)
        if not len(pts):
            continue
        what, r = classify(pts, conf, goal)  # type: ignore[assignment]
        counts[what] += 1
        row = anchor.get(f.name, {})
        cpp = "reached" if row.get("cpp_goal") == "1" else (row.get("cpp_status") or "-")
        if cpp == "ok":
            cpp = "not"
        counts[f"{what} / C++ {cpp}"] += 1
        reach = None
        if oracle is not None:
            reach = what == "honest" or oracle.reachable(pts, goal)  # type: ignore[arg-type]
            counts["oracle reachable"] += reach
        if args.only_missed and what == "honest":
            continue
        end = r.map[r.plan.end].end  # type: ignore[attr-defined]
        tasks = "".join(s.task.value[0] for s in r.steps)  # type: ignore[attr-defined]
        line = (
            f"{f.name:<12} {what:<13} {r.n_states:>6} {tasks or '-':<14} {end.distance_to(*goal):7.3f}  "  # type: ignore[attr-defined]
            f"{cpp:<10} {row.get('cpp_plan') or '-':<14}"
        )
        print(line + (f"  {'yes' if reach else 'no'}" if oracle else ""), flush=True)
    total = sum(v for k, v in counts.items() if "/" not in k and k != "oracle reachable")
    print(f"\n{total} scans with data ({time.perf_counter() - t0:.1f} s)")
    for k in sorted(counts):
        if k != "oracle reachable":
            print(f"  {k:<30} {counts[k]:4d}")
    print(f"honest reach {counts['honest']}/{total} = {100 * counts['honest'] / max(total, 1):.1f} %")
    if oracle is not None:
        n = counts["oracle reachable"]
        print(f"reachable by any motion inside the disc (oracle): {n}/{total} = {100 * n / max(total, 1):.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
