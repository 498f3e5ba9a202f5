"""Peak memory of ``clomp convert`` and ``clomp replay`` on a large generated run log (issue #43).

Both read the log one record at a time (:func:`clomp.planner.inputs.json_lines`), so their
peak RSS should not grow with the log's size: the target on a 300 MB log is under 300 MB.
A benchmark, not a test: it takes minutes at 300 MB.

    PYTHONPATH=$PWD .venv/bin/python bench/input_memory.py            # 300 MB
    PYTHONPATH=$PWD .venv/bin/python bench/input_memory.py --mb 30 --bins 360
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_MEASURE = (
    "import resource, subprocess, sys\n"
    "rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode\n"
    "print(rc, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
)


def write_log(path: Path, megabytes: float) -> int:
    """A run log of about ``megabytes`` MB: scan records of 360 points (a wall 0.8 m ahead)."""
    pts = [[round(0.8, 3), round(0.8 * math.tan(math.radians(a / 4)), 3)] for a in range(-180, 180)]
    n = 0
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(json.dumps({"t": 0.0, "event": "run", "wall": 1.7e9}) + "\n")
        while fh.tell() < megabytes * 1e6:
            n += 1
            fh.write(json.dumps({"t": n * 0.18, "event": "scan", "points": pts, "goal": [1.0, 0.0],
                                 "pose": [0.0, 0.0, 0.0]}) + "\n")
    return n


def peak_rss_mb(argv: list[str]) -> tuple[int, float, float]:
    """(exit status, peak RSS in MB, wall seconds) of ``argv`` run as a child process."""
    started = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", _MEASURE, *argv], capture_output=True, text=True, check=True)
    rc, kib = out.stdout.split()
    return int(rc), int(kib) / 1024, time.perf_counter() - started


def main() -> None:
    """Generate the log, run both commands on it, print one line each."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mb", type=float, default=300.0, help="size of the generated log (default 300 MB)")
    ap.add_argument("--bins", type=int, default=360, help="convert --bins (default 360: the output stays small)")
    ap.add_argument("--skip-replay", action="store_true", help="measure convert only (replay plans every scan)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "big.jsonl"
        n = write_log(log, args.mb)
        print(f"log: {os.path.getsize(log) / 1e6:.0f} MB, {n:,} scan records")
        clomp = [sys.executable, "-m", "clomp.runtime.cli"]
        runs = {"convert": [*clomp, "convert", str(log), "--bins", str(args.bins), "-o", str(Path(tmp) / "big.mcap")]}
        if not args.skip_replay:
            runs["replay"] = [*clomp, "replay", str(log), "--json"]
        for name, argv in runs.items():
            rc, mb, secs = peak_rss_mb(argv)
            verdict = "under" if mb < 300 else "OVER"
            print(f"{name}: exit {rc}, peak RSS {mb:.0f} MB ({verdict} the 300 MB target), {secs:.0f} s")


if __name__ == "__main__":
    main()
