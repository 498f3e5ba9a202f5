"""``clomp emulate world``'s IMU fault options: ``--imu-fault KIND --imu-fault-at SECONDS``.

The fault itself is :class:`clomp.runtime.backends.imu_fault.ImuFault`; here are its
options, their checks, and the lines the world prints: when the fault comes, and at the end
what became of it (how long until the wheels were commanded to stop, how far the robot went).
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from clomp.runtime.cli import CliError

__all__ = ["add_imu_fault_options", "imu_fault_from", "say_fault_came"]


def add_imu_fault_options(parser: Any) -> None:
    """Add ``--imu-fault``, ``--imu-fault-at``, ``--imu-yaw-jump`` and ``--imu-spin`` to ``parser``."""
    from clomp.runtime.backends.imu_fault import IMU_FAULTS

    parser.add_argument("--imu-fault", choices=IMU_FAULTS, metavar="KIND",
                        help="fail the IMU at --imu-fault-at: silent (no more reports), unplug (its pty closes), "
                             "garbage (random bytes instead of reports), wrong-yaw (the yaw jumps by --imu-yaw-jump "
                             "and stays off), spin (the yaw turns at --imu-spin while the body does not)")
    parser.add_argument("--imu-fault-at", type=float, default=5.0, metavar="SECONDS",
                        help="world time of the IMU fault (default 5; the world's time runs from clomp run's start)")
    parser.add_argument("--imu-yaw-jump", type=float, default=90.0, metavar="DEG",
                        help="wrong-yaw: the yaw's jump, degrees (default 90)")
    parser.add_argument("--imu-spin", type=float, default=30.0, metavar="DEG_S",
                        help="spin: the false turn rate, °/s of world time (default 30)")


def imu_fault_from(args: argparse.Namespace) -> Any:
    """The :class:`~clomp.runtime.backends.imu_fault.ImuFault` the options ask for (None without
    ``--imu-fault``); a CliError for a bad time or size."""
    from clomp.runtime.backends.imu_fault import ImuFault

    if args.imu_fault is None:
        return None
    try:
        return ImuFault(args.imu_fault, at=args.imu_fault_at, jump=math.radians(args.imu_yaw_jump),
                        spin=math.radians(args.imu_spin))
    except ValueError as exc:
        raise CliError(f"--imu-fault: {exc}") from None


def say_fault_came(world: Any, said: list[bool]) -> None:
    """Print, once, that the world's IMU fault came (``said`` remembers it)."""
    fault = getattr(world, "imu_fault", None)
    if fault is not None and fault.applied and not said:
        said.append(True)
        p = fault.pose
        where = "" if p is None else f", the robot at ({p.x:.3f}, {p.y:.3f}, {math.degrees(p.theta):.0f}°)"
        print(f"imu fault: {fault.describe()} came at {fault.world_time:.2f} s{where}", flush=True)
