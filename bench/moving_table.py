"""The moving families' table (issue #42) from the folders ``clomp experiment`` filled.

    python bench/moving_table.py OUT/crossing-paper OUT/stopper-paper ...

Each folder holds one family at one noise preset (``clomp experiment crossing --noise paper
--out OUT/crossing-paper``). Per family, noise and condition: runs, success (truly within
0.1 m of the goal) with its Wilson 95 % interval, false successes (GOAL_REACHED while truly
farther), GOAL_UNCONFIRMED, collisions with the static obstacles, collisions with the moving
bodies and how many of those the robot caused, and brushes with moving bodies.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.runtime.experiment.runrecords import load_records  # noqa: E402
from clomp.runtime.experiment.stats import wilson  # noqa: E402

HEADER = ("| family | noise | condition | runs | success [95 %] | false successes | unconfirmed | "
          "static collisions | moving collisions (robot-caused) | moving brushes |\n"
          "|---|---|---|---|---|---|---|---|---|---|")


def rows(folder: Path) -> list[str]:
    recs = load_records(folder / "runs.jsonl")
    out = []
    for cond in ("planning", "reactive"):
        rs = [r for r in recs if r["condition"] == cond]
        if not rs:
            continue
        n, ok = len(rs), sum(int(r["success"]) for r in rs)
        lo, hi = wilson(ok, n)

        def total(k: str, rs: list[dict] = rs) -> int:
            return sum(int(r.get(k) or 0) for r in rs)

        out.append(f"| {rs[0]['family']} | {rs[0]['noise']} | {cond} | {n} | {ok}/{n} [{lo:.2f}, {hi:.2f}] | "
                   f"{total('false_success')} | {total('goal_unconfirmed')} | {total('static_collisions')} | "
                   f"{total('moving_collisions')} ({total('robot_caused_collisions')}) | {total('moving_brushes')} |")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folders", nargs="+", type=Path)
    args = ap.parse_args(argv)
    print(HEADER)
    for f in args.folders:
        for line in rows(f):
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
