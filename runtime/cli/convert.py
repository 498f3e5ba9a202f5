"""``clomp convert``: a run log (``clomp run``, ``clomp simulate --log``) as MCAP with ROS 2
message types, to open in Foxglove or play with ``ros2 bag play``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from clomp.runtime.cli import EXIT_OK, CliError
from clomp.runtime.cli._common import log_records, output_path, path_kind
from clomp.runtime.cli._progress import progress
from clomp.runtime.records.mcap_writer import A1_BINS, MAX_BINS, ConvertError, write_mcap
from clomp.runtime.records.runlog import read_log

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add ``convert`` to the command line."""
    p = sub.add_parser("convert", help="write a run log as MCAP (ROS 2 types) for Foxglove and ros2 bag play",
                       description=__doc__)
    p.add_argument("log", help="a run log (JSON lines) from clomp run or clomp simulate --log")
    p.add_argument("-o", "--output", metavar="RUN.mcap", help="the MCAP file (default: the log's name with .mcap)")
    p.add_argument("--bins", type=int, default=A1_BINS,
                   help=f"LaserScan readings per revolution (default {A1_BINS}: the RPLIDAR A1's 1/64°)")
    p.add_argument("--json", action="store_true", help="print the message counts as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp convert``."""
    src = Path(args.log)
    if path_kind(src, "log") == "missing":
        raise CliError(f"{src}: no such file")
    if not 8 <= args.bins <= MAX_BINS:
        raise CliError(f"--bins: from 8 to {MAX_BINS:,} readings per revolution, got {args.bins:,}")
    dest = Path(args.output) if args.output else src.with_suffix(".mcap")
    if path_kind(dest, "-o") != "missing" and dest.resolve() == src.resolve():
        raise CliError(f"-o: {dest} is the log itself")
    output_path(dest, "-o")
    records = log_records(read_log, src, "records")  # streamed: one record in memory at a time
    try:
        summary = write_mcap(progress(records, desc="convert", unit="record"), dest, bins=args.bins)
    except ConvertError as exc:
        raise CliError(str(exc)) from None
    if args.json:
        print(json.dumps({"mcap": str(dest), "messages": summary.counts, "skipped": summary.skipped}))
    else:
        counts = ", ".join(f"{t} {n}" for t, n in summary.counts.items()) or "no messages"
        print(f"{dest}: {counts}")
        if summary.skipped:
            print(f"  passed over: {', '.join(f'{n} {k} record(s)' for k, n in summary.skipped.items())}")
    return EXIT_OK
