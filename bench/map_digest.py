"""Digest of every cognitive map the planner builds on the recorded scans and the scenarios.

A speed-up of the planner must not change any map (the closed-loop, experiment and robust
figures of the other issues all rest on the maps). This prints one SHA-256 per input over the
map's lossless JSON (floats written with ``repr``: bit-exact), the plan, its stop reason and
``goal_blocked``, and one over all of them; ``--save FILE`` writes them, ``--compare FILE``
says which inputs differ from a saved run (exit status 1 when any does).

Run it in the old tree and the new tree::

    python bench/map_digest.py --save /tmp/before.txt          # old tree
    python bench/map_digest.py --compare /tmp/before.txt       # new tree: "identical: 286 of 286"
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

from clomp.planner import Configurator, builtin_scenarios, load_scan, load_scenario

DEFAULT_SCANS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "scans" / "corridor-2023-10-25"


def digests(scans: Path) -> dict[str, str]:
    """``{input name: sha256 of its map, plan and stop reason}`` for every scan and scenario."""
    conf = Configurator()
    inputs: list[tuple[str, np.ndarray, tuple[float, float]]] = []
    for name in builtin_scenarios():
        scene = load_scenario(name)
        gx, gy = scene.goal_in_robot_frame()
        inputs.append((f"scenario:{name}", scene.scan(), (float(gx), float(gy))))
    for f in sorted(scans.glob("*.dat")):
        inputs.append((f"scan:{f.name}", load_scan(f), (1.0, 0.0)))
    out = {}
    for name, pts, goal in inputs:
        r = conf.plan(pts, goal)
        doc = {
            "map": r.map.to_dict(),
            "plan": list(r.plan.states),
            "stop": r.stop_reason,
            "blocked": r.goal_blocked,
            "psi": sorted((repr(k), v) for k, v in r.psi.items()),
        }
        out[name] = hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=Path, default=DEFAULT_SCANS)
    ap.add_argument("--save", type=Path, help="write the digests to this file")
    ap.add_argument("--compare", type=Path, help="compare with digests saved by --save")
    args = ap.parse_args(argv)
    d = digests(args.scans)
    total = hashlib.sha256("".join(f"{k} {v}\n" for k, v in d.items()).encode()).hexdigest()
    if args.save:
        args.save.write_text("".join(f"{k} {v}\n" for k, v in d.items()))
    print(f"{len(d)} maps, overall digest {total}")
    if args.compare:
        saved = dict(line.split() for line in args.compare.read_text().splitlines() if line.strip())
        differ = sorted(k for k in set(saved) | set(d) if saved.get(k) != d.get(k))
        print(f"identical: {len(d) - len(differ)} of {len(d)}" + (f"; differ: {', '.join(differ)}" if differ else ""))
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
