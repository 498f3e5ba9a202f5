"""Issue #42's measured situations rerun in the project's own worlds (planning condition).

    python bench/moving_situations.py [--seeds 3] [--noise paper harsh]

- a box (0.16 m) appearing 5 cm ahead of the robot's front at t = 2.5, 4 and 6 s;
- a person walking in and stopping 3 cm ahead (from either side);
- a person crossing ahead at 0.3 and 1.0 m/s.

Each in the ``appearing`` / ``stopper`` / ``crossing`` room (seed 0, run 0's walls and goal),
with the situation's mover in place of the drawn one. Prints per situation: reached (truly
within 0.1 m), false successes, collisions with moving bodies and the robot-caused ones, and
how many runs used WAIT and REVERSE.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.formal.model import TaskKind  # noqa: E402
from clomp.runtime.experiment.layouts import make_layout  # noqa: E402
from clomp.runtime.experiment.onerun import SUCCESS_RADIUS, run_once  # noqa: E402
from clomp.runtime.experiment.runspec import noise_seed  # noqa: E402


def situations() -> list[tuple[str, str, dict]]:
    out = [(f"box 5 cm ahead at t={t:g} s", "appearing", {"kind": "box", "appear": t, "ahead": 0.05})
           for t in (2.5, 4.0, 6.0)]
    out += [(f"person stops 3 cm ahead ({'left' if s > 0 else 'right'})", "stopper",
             {"kind": "person", "appear": 3.0, "ahead": 0.03, "lateral": 0.55 * s, "speed": 0.5}) for s in (1.0, -1.0)]
    out += [(f"person crosses 0.5 m ahead at {v:g} m/s", "crossing",
             {"kind": "person", "stays": False, "path": [[4.0 - 1.3 / v, 0.75, -1.3], [4.0 + 1.3 / v, 0.75, 1.3]]})
            for v in (0.3, 1.0)]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--noise", nargs="+", default=["paper", "harsh"])
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    print("| situation | noise | reached | false successes | moving collisions (robot-caused) | used WAIT | used REVERSE |")
    print("|---|---|---|---|---|---|---|")
    for name, family, mover in situations():
        lay = make_layout(family, 0, 0)
        for noise in args.noise:
            reached = false = coll = caused = waits = backs = 0
            for k in range(args.seeds):
                r = run_once(lay.scene, "planning", noise_seed(0, k), run=k, noise=noise, movers=(mover,),
                             keep_report=True, max_time=120.0)
                reached += r.final_distance <= SUCCESS_RADIUS
                false += r.end_state == "GOAL_REACHED" and r.final_distance > SUCCESS_RADIUS
                m = r.moving or {}
                coll, caused = coll + m.get("moving_collisions", 0), caused + m.get("robot_caused_collisions", 0)
                kinds = {t.state.task for t in r.report.tasks}
                waits += TaskKind.WAIT in kinds
                backs += TaskKind.REVERSE in kinds
            n = args.seeds
            print(f"| {name} | {noise} | {reached}/{n} | {false} | {coll} ({caused}) | {waits}/{n} | {backs}/{n} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
