"""Is the estimate's 95 % position bound honest? Coverage of the true error, binned by the bound.

    python bench/bound_coverage.py --families all --seeds 25-34 --gyro both --out /tmp/cov.jsonl
    python bench/bound_coverage.py --report /tmp/cov.jsonl [--compare /tmp/old.jsonl]

The supervisor claims the goal (GOAL_REACHED) only when the estimated distance plus the
estimate's 95 % position bound (``vouch_sigmas`` times
:meth:`~clomp.runtime.estimation.odometry.ScanOdometry.position_sd`) is within 0.1 m (issue #36).
That rule is only as true as the bound: this bench runs the execution world's planning
condition (the runs ``clomp sweep`` makes, same seeds and records) with a supervisor that
only *watches* — after each revolution's correction, and at the run's end, it writes the
true position error of the estimate (the world's ground truth, in the supervisor's frame)
beside the bound, the filter's ``honest`` position standard deviation, the doubt's floor and
the NEES (the error's squared Mahalanobis distance in ``honest``'s position block; 2 degrees
of freedom, 95 % of a consistent filter's below 5.99).

The report prints, per gyro setting and per bin of the bound (m), how many samples there are
and the share truly inside the bound (a consistent 95 % bound: ≥ 0.95), at every revolution,
at the end of runs, and at claims (runs ended GOAL_REACHED: the bound the claim used), and
the run outcomes (truly within 0.1 m, claimed and true, false successes, unconfirmed,
collisions, HALTED). ``--compare`` prints an older file's figures beside.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.formal.geometry import relative  # noqa: E402
from clomp.formal.model import Pose  # noqa: E402
from clomp.runtime.experiment.layouts import ALL_FAMILIES  # noqa: E402
from clomp.runtime.experiment.runner import RunSpec, run_spec  # noqa: E402
from clomp.runtime.supervision import Supervisor  # noqa: E402

BINS = (0.0, 0.02, 0.04, 0.07, 0.1, 0.2, math.inf)
"""Bin edges of the bound (m): a claim needs the bound under 0.1 m."""


def sample(sup: Any, origin: Pose, kind: str, bound: float | None = None) -> dict[str, Any] | None:
    """One sample: the estimate's true position error beside its bound (None without an estimator)."""
    est = sup.estimator
    if est is None:
        return None
    truth = relative(origin, sup.robot.ground_truth_pose())
    e = np.array([est.pose.x - truth.x, est.pose.y - truth.y])
    h = est.filter.honest[:2, :2]
    try:
        nees = float(e @ np.linalg.solve(h + np.eye(2) * 1e-12, e))
    except np.linalg.LinAlgError:  # pragma: no cover
        nees = math.inf
    b = sup.config.vouch_sigmas * est.position_sd() if bound is None else bound
    return {"k": kind, "t": round(float(sup.clock.now()), 2), "err": round(float(np.hypot(*e)), 5), "bound": round(b, 5),
            "hsd": round(est.filter.honest_sigma_xy, 5), "psd": round(est.filter.sigma_xy, 5),
            "vsd": round(est.vouched_sd(), 5), "ev": None if est.evidence is None else est.evidence.source,
            "doubt": round(est.doubt.sd, 5), "nees": round(min(nees, 1e9), 3)}


class Watched(Supervisor):
    """The supervisor as shipped, watched: :func:`sample` after each revolution and at the end."""

    samples: list[dict[str, Any]] = []

    def __init__(self, robot: Any, *args: Any, **kwargs: Any) -> None:
        super().__init__(robot, *args, **kwargs)
        self._origin = robot.ground_truth_pose()
        sensing, sup = self.sensing, self
        inner = sensing._feedback

        def feedback(frame: Any, now: float) -> Any:
            rec = inner(frame, now)
            s = sample(sup, sup._origin, "rev")
            if s is not None and getattr(rec, "source", "") == "map":
                Watched.samples.append(s)
            return rec

        sensing._feedback = feedback  # type: ignore[method-assign]

    def run(self, *args: Any, **kwargs: Any) -> Any:
        report = super().run(*args, **kwargs)
        bound = None if self._goal_end is None else self._goal_end[1]
        s = sample(self, self._origin, "end", bound)
        if s is not None:
            s["state"] = report.state.value
            Watched.samples.append(s)
        return report


def run_watched(spec: RunSpec) -> dict[str, Any]:
    """``clomp sweep``'s record of ``spec`` with the watched samples under ``samples``."""
    import clomp.runtime.experiment.onerun as onerun

    saved = onerun.Supervisor  # type: ignore[attr-defined]
    onerun.Supervisor = Watched  # type: ignore[attr-defined]  # where run_once looks it up
    Watched.samples = []
    try:
        rec = run_spec(spec)
    finally:
        onerun.Supervisor = saved  # type: ignore[attr-defined]
    keep = ("key", "family", "seed", "run", "gyro", "expect", "end_state", "final_error_m", "false_success",
            "goal_unconfirmed", "reached_goal", "collisions", "reason")
    out = {k: rec[k] for k in keep}
    out["samples"] = Watched.samples
    return out


def _bin(b: float) -> int:
    for i in range(len(BINS) - 1):
        if BINS[i] <= b < BINS[i + 1]:
            return i
    return len(BINS) - 2


def coverage(runs: list[dict[str, Any]], kind: str) -> dict[int, tuple[int, int]]:
    """Per bin of the bound: (samples, samples truly inside the bound). ``kind``: 'rev', 'end' or 'claim'."""
    c: dict[int, list[int]] = defaultdict(lambda: [0, 0])
    for r in runs:
        for s in r["samples"]:
            if kind == "claim":
                if s["k"] != "end" or s.get("state") != "GOAL_REACHED":
                    continue
            elif s["k"] != kind:
                continue
            i = _bin(s["bound"])
            c[i][0] += 1
            c[i][1] += s["err"] <= s["bound"]
    return {i: (v[0], v[1]) for i, v in c.items()}


def outcomes(runs: list[dict[str, Any]]) -> dict[str, int]:
    """Run outcomes as the sweeps count them."""
    o: dict[str, int] = defaultdict(int)
    for r in runs:
        o["runs"] += 1
        reach = r["expect"] == "reach"
        o["truly"] += int(reach and r["final_error_m"] <= 0.1)
        o["claimed_true"] += int(r["end_state"] == "GOAL_REACHED" and r["final_error_m"] <= 0.1)
        o["FS"] += int(r["false_success"])
        o["unconf"] += int(r["goal_unconfirmed"])
        o["coll"] += int(r["collisions"])
        o["halted"] += int(r["end_state"] == "HALTED")
    return dict(o)


def report(runs: list[dict[str, Any]], old: list[dict[str, Any]] | None = None) -> None:
    """Print coverage per bin and outcomes per gyro setting (beside ``old``'s when given)."""
    names = [f"[{BINS[i]:.2f},{BINS[i + 1]:.2f})" for i in range(len(BINS) - 1)]
    for g in (1, 0):
        mine = [r for r in runs if r["gyro"] == g]
        theirs = None if old is None else [r for r in old if r["gyro"] == g]
        if not mine:
            continue
        print(f"gyro {'on' if g else 'off'}: {len(mine)} runs")
        for kind in ("rev", "end", "claim"):
            cov = coverage(mine, kind)
            prev = None if theirs is None else coverage(theirs, kind)
            cells = []
            for i, name in enumerate(names):
                n, k = cov.get(i, (0, 0))
                text = f"{name} {k}/{n}" + (f" {k / n:.0%}" if n else "")
                if prev is not None:
                    pn, pk = prev.get(i, (0, 0))
                    text = f"{name} {pk}/{pn}" + (f" {pk / pn:.0%}" if pn else "") + f" -> {k}/{n}" + (f" {k / n:.0%}" if n else "")
                cells.append(text)
            print(f"  coverage at {kind:5s}: " + "; ".join(cells))
        nees = [s["nees"] for r in mine for s in r["samples"] if s["k"] == "rev" and s["hsd"] > 0]
        if nees:
            print(f"  NEES per revolution (2 dof): median {np.median(nees):.2f}, share > 5.99: {np.mean(np.array(nees) > 5.99):.1%}")
        print(f"  outcomes: {outcomes(mine)}" + ("" if theirs is None else f"  (was {outcomes(theirs)})"))


def _seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def load(path: str) -> list[dict[str, Any]]:
    """The runs a ``--out`` file holds."""
    return [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--families", default="all")
    ap.add_argument("--seeds", default="25-34")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--gyro", choices=["on", "off", "both"], default="both")
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--out", default=None, help="JSON lines, one per run (resumed: runs already there are kept)")
    ap.add_argument("--report", default=None, help="only report this file")
    ap.add_argument("--compare", default=None, help="an older file to report beside")
    a = ap.parse_args()
    old = None if a.compare is None else load(a.compare)
    if a.report is not None:
        report(load(a.report), old)
        return
    fams = list(ALL_FAMILIES) if a.families == "all" else a.families.split(",")
    gyros = {"on": [True], "off": [False], "both": [True, False]}[a.gyro]
    done = {r["key"] for r in load(a.out)} if a.out and Path(a.out).exists() else set()
    runs: list[dict[str, Any]] = load(a.out) if done and a.out else []
    t0 = time.perf_counter()
    for seed in _seeds(a.seeds):
        for fam in fams:
            for run in range(a.runs):
                for g in gyros:
                    spec = RunSpec(fam, seed, run, "planning", a.noise, gyro=g)
                    if spec.key in done:
                        continue
                    r = run_watched(spec)
                    runs.append(r)
                    if a.out:
                        with open(a.out, "a") as fh:
                            fh.write(json.dumps(r) + "\n")
    print(f"{len(runs)} runs, {time.perf_counter() - t0:.0f} s")
    report(runs, old)


if __name__ == "__main__":
    main()
