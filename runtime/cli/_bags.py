"""Options and helpers shared by the commands that read LaserScan topics of ROS bags
(``clomp plan --scan BAG``, ``clomp replay BAG``)."""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from clomp.planner import ScanError
from clomp.planner.inputs import special_kind
from clomp.runtime.cli import CliError
from clomp.runtime.records.bags import BagError, LaserScan, LaserScanTopic, is_bag, parse_offset

__all__ = ["add_bag_options", "bag_points", "is_bag", "open_topic", "lidar_offset", "labelled_scans", "scan_label"]


def add_bag_options(p: argparse.ArgumentParser) -> None:
    """``--topic`` and ``--lidar-offset``."""
    g = p.add_argument_group("ROS bags (ROS 2 folder, .mcap, .db3, or ROS 1 .bag)")
    g.add_argument("--topic", help="the sensor_msgs/LaserScan topic (default: the bag's only LaserScan topic)")
    g.add_argument("--lidar-offset", metavar="X,Y,THETA", default=None,
                   help="the LiDAR's pose on the robot, m, m, rad (default 0,0,0: at the rotation centre)")


def lidar_offset(args: argparse.Namespace, bag: bool = True) -> tuple[float, float, float]:
    """The parsed ``--lidar-offset`` (an error when given for a source that is no bag:
    scan files and run logs already hold robot-frame points)."""
    if not bag and getattr(args, "lidar_offset", None) is not None:
        raise CliError("--lidar-offset applies to LaserScan from ROS bags; scan files and run logs are in the robot frame")
    try:
        return parse_offset(getattr(args, "lidar_offset", None) or "0,0,0")
    except BagError as exc:
        raise CliError(str(exc)) from None


def open_topic(path: Path, args: argparse.Namespace) -> LaserScanTopic:
    """The LaserScan topic ``--topic`` names in the bag at ``path`` (one-line errors; a
    FIFO, device or socket is refused before a reader could block on it)."""
    try:
        what = special_kind(os.stat(path).st_mode, "ROS bag")
    except OSError as exc:
        raise CliError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if what and what != "is a folder, not a ROS bag":
        raise CliError(f"{path}: {what}")
    try:
        return LaserScanTopic(path, getattr(args, "topic", None))
    except BagError as exc:
        raise CliError(str(exc)) from None


def scan_label(topic: str, scan: LaserScan, t0_ns: int) -> str:
    """``/scan#7@1.400s``: topic, index on it, bag time since its first scan."""
    return f"{topic}#{scan.index}@{(scan.time_ns - t0_ns) / 1e9:.3f}s"


def bag_points(scan: LaserScan, offset: tuple[float, float, float]) -> np.ndarray:
    """The robot-frame points of one scan of a bag; a scan whose points cannot be read is
    that scan's :class:`~clomp.planner.ScanError` (a many-scan run records it and goes on)."""
    try:
        return scan.points(offset)
    except BagError as exc:
        raise ScanError(f"scan {scan.index}: {exc}") from None


def labelled_scans(topic: LaserScanTopic) -> Iterator[tuple[str, LaserScan]]:
    """(label, scan) of every scan on the topic; a bag that breaks off mid-way is a
    :class:`CliError`. (A scan's points may still be bad: ``scan.points()`` raises
    :class:`BagError` for that one scan.)"""
    t0: int | None = None
    try:
        for s in topic:
            t0 = s.time_ns if t0 is None else t0
            yield scan_label(topic.topic, s, t0), s
    except BagError as exc:
        raise CliError(str(exc)) from None
