"""The reactive baseline's variants against the paper's figures (prints figures; not a test).

    python bench/experiment_reactive.py [--family overtaking] [--seed 0] [--runs 10] [--noise paper]
                                        [--workers 2] [--variants default,signed,blind,step-0.5,window-1.0]

Runs the reactive condition of ``clomp experiment`` (same layouts, noise seeds, ground
truth and counter: :func:`clomp.runtime.experiment.runner.run_once`) for each variant of
:class:`~clomp.runtime.experiment.reactive.ReactiveController`:

- ``default``: the authors' task structure and sides as their code ran (``Disturbance::
  getAngle`` is acos: always avoids right, pursues left), a one-step (0.27 m) look-ahead;
- ``signed``: ``sides="signed"``, the sides their code's comments meant (away from the
  obstacle, towards the goal);
- ``blind``: ``detect=False``, their code before 2024-10-09, whose reactive branch
  simulated the task in a world with no bodies;
- ``step-0.5``: straight steps (and so the look-ahead) of 0.5 m, ``reactive_target.cpp``'s
  command-line option;
- ``window-1.0``: the look-ahead over the whole 1 m world window (``BOX2DRANGE``), as
  this baseline read their code before b68adf9.

Every variant but ``signed`` takes the default's sides.

Prints per variant: reached (ground truth, 0.1 m), believed, collisions + brushes, the
median final error, and the paper's 0/10 with 8 collisions beside them (issue #9's band:
at most 2/10 reached, 4–20 collisions).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.planner.noise import preset_names  # noqa: E402
from clomp.planner.robot_model import RobotModel  # noqa: E402
from clomp.runtime.experiment.layouts import make_layout  # noqa: E402
from clomp.runtime.experiment.runner import noise_seed, run_once  # noqa: E402

VARIANTS: dict[str, dict[str, Any]] = {
    "default": {},
    "signed": {"sides": "signed"},
    "blind": {"detect": False},
    "step-0.5": {"model": dataclasses.replace(RobotModel(), step_length=0.5)},
    "window-1.0": {"look_ahead": 1.0},
}


def one(job: tuple[str, str, int, int, str]) -> tuple[str, int, bool, bool, int, int, float, float]:
    variant, family, seed, run, noise = job
    lay = make_layout(family, seed, run)
    c0 = time.thread_time()
    r = run_once(lay.scene, "reactive", noise_seed(seed, run), run=run, noise=noise, expect=lay.expect,
                 reactive=VARIANTS[variant])
    return variant, run, r.reached_goal, r.believed_goal, r.collisions, r.brushes, r.final_distance, time.thread_time() - c0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--family", default="overtaking")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--noise", default="paper", choices=preset_names())
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    a = ap.parse_args()
    names = a.variants.split(",")
    if a.runs < 1 or a.workers < 1 or any(n not in VARIANTS for n in names):
        ap.error(f"--runs and --workers must be >= 1; variants are {', '.join(VARIANTS)}")
    jobs = [(v, a.family, a.seed, k, a.noise) for v in names for k in range(a.runs)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(a.workers) as pool:
        rows = list(pool.map(one, jobs))
    wall = time.perf_counter() - t0
    print(f"{a.family} seed {a.seed} noise {a.noise}, {a.runs} runs per variant; the paper: 0/{a.runs} reached, "
          f"8 collisions; issue #9's band: reached <= 2, collisions 4-20")
    for v in names:
        rs = [r for r in rows if r[0] == v]
        reached, believed = sum(r[2] for r in rs), sum(r[3] for r in rs)
        coll, br = sum(r[4] for r in rs), sum(r[5] for r in rs)
        med = statistics.median(r[6] for r in rs)
        band = "in band" if reached <= 2 and 4 <= coll <= 20 else "out of band"
        print(f"  {v:9s} reached {reached}/{len(rs)} (believed {believed}), {coll} collisions + {br} brushes, "
              f"median final error {med:.3f} m: {band}")
    cpu = sum(r[7] for r in rows)
    print(f"{len(rows)} runs in {wall:.0f} s wall, {cpu:.0f} s thread CPU in the workers, load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
