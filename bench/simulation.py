"""How much faster than real time the simulated robot runs (prints figures; not a test).

    python bench/simulation.py [--repeat N]

Three figures: the bare simulator (a robot driving and scanning, no controller), the
supervisor executing the overtaking plan (planning included), and the reactive loop.
Speed-up = simulated seconds / wall-clock seconds.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.planner import load_scenario  # noqa: E402
from clomp.runtime.experiment.runner import run_once  # noqa: E402
from clomp.runtime.backends.sim import SimRobot  # noqa: E402


def bare(seconds: float = 60.0) -> float:
    sim = SimRobot(load_scenario("overtaking"), seed=0)
    t = time.perf_counter()
    for k in range(int(seconds / 0.1)):
        sim.set_wheel_speeds(0.05, 0.06 if k % 50 < 25 else 0.04)
        sim.read_scan(timeout=0.0)
        sim.sleep(0.1)
    return seconds / (time.perf_counter() - t)


def condition(name: str, scenario: str, repeat: int) -> tuple[float, float, float]:
    scene = load_scenario(scenario)
    sim_s, wall_s = [], []
    for seed in range(repeat):
        r = run_once(scene, name, seed)
        sim_s.append(r.time_s)
        wall_s.append(r.wall_s)
    speed = [a / b for a, b in zip(sim_s, wall_s)]
    return statistics.mean(speed), min(speed), statistics.mean(sim_s)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    print(f"bare simulator (drive + 360-ray LiDAR at 5.5 Hz, 0.02 s substeps): {bare():.0f}× real time")
    for scenario in ("overtaking", "slalom"):
        for name in ("planning", "reactive"):
            mean, worst, sim_s = condition(name, scenario, args.repeat)
            print(f"{scenario:<11} {name:<9} {args.repeat} runs of {sim_s:5.1f} s simulated: "
                  f"{mean:5.0f}× real time (slowest run {worst:.0f}×)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
