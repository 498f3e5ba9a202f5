"""``clomp emulate lidar|maestro|imu``: run a device emulator on a pseudo-terminal.

Prints the pty path on one line, then serves until Ctrl-C, so a driver (or
``clomp run`` on hardware settings) can be pointed at it without hardware.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from clomp.runtime.cli._args import seed_arg
from clomp.runtime.cli import CliError
from clomp.runtime.cli._common import add_units_option, load_scene, read_points
from clomp.runtime.cli._signals import interrupts_raise

__all__ = ["register"]


def register(subparsers: Any) -> None:
    """Add the ``emulate`` subcommand (with ``lidar``, ``maestro`` and ``imu``) to the CLI."""
    parser = subparsers.add_parser(
        "emulate",
        help="emulate the LiDAR, the motor controller, the IMU, or all three over a simulated world, on pseudo-terminals",
        description="Start a device emulator on a pseudo-terminal, print its path, run until Ctrl-C.",
    )
    devices = parser.add_subparsers(dest="device", metavar="DEVICE", required=True)

    lidar = devices.add_parser(
        "lidar",
        help="an RPLIDAR A1 streaming recorded or simulated scans",
        description="Emulate an RPLIDAR A1. Scans come from recorded mapNNNN.dat files (--scans) "
        "or a simulated scenario (--scenario).",
    )
    source = lidar.add_mutually_exclusive_group()
    source.add_argument("--scans", metavar="DIR", help="folder of recorded mapNNNN.dat scans, played in a loop")
    source.add_argument("--scenario", metavar="NAME", help="scenario name or file to simulate scans from")
    add_units_option(lidar)
    lidar.add_argument("--speed", type=float, default=1.0, metavar="FACTOR", help="pace factor (default 1: ~5.5 Hz)")
    lidar.add_argument("--garbage", type=float, default=0.0, metavar="RATE", help="probability per sample of a garbage burst")
    lidar.add_argument("--bad-check", type=float, default=0.0, metavar="RATE", help="probability per sample of a bad check bit")
    lidar.add_argument("--silent-after", type=int, metavar="N", help="go silent after N revolutions")
    lidar.add_argument("--vanish-after", type=float, metavar="N", help="close the pty after N (fractional) revolutions")
    lidar.add_argument("--health", choices=("good", "warning", "error"), default="good", help="GET_HEALTH status")
    lidar.add_argument("--error-code", type=int, default=0, metavar="CODE", help="GET_HEALTH error code")
    lidar.add_argument("--seed", type=seed_arg, help="seed for fault injection and simulated noise")
    lidar.set_defaults(func=_run_lidar)

    maestro = devices.add_parser(
        "maestro",
        help="a Pololu Maestro driving the two wheel servos",
        description="Emulate a Pololu Maestro (compact and Pololu protocol).",
    )
    maestro.add_argument("--device-number", type=int, default=12, help="Pololu protocol device number (default 12)")
    maestro.add_argument("--serial-timeout", type=float, metavar="S", help="send channels home after S s without a byte")
    maestro.add_argument("--show-speeds", action="store_true", help="print the decoded wheel speeds when they change")
    maestro.set_defaults(func=_run_maestro)

    imu = devices.add_parser(
        "imu",
        help="a BNO08x IMU in UART-RVC mode streaming a heading",
        description="Emulate a CEVA BNO080/085/086 strapped for UART-RVC mode: 100 reports/s at 115200 baud "
        "of a heading that stays put or turns at --turn-rate (the yaw is 0 at the start, as after a reset).",
    )
    imu.add_argument("--turn-rate", type=float, default=0.0, metavar="DEG_S", help="true turn rate, °/s counter-clockwise (default 0)")
    imu.add_argument("--drift", type=float, default=0.0, metavar="DEG_MIN", help="yaw drift, °/min (a still BNO08x: about 0.5)")
    imu.add_argument("--noise", type=float, default=0.0, metavar="DEG", help="yaw noise, standard deviation in °")
    imu.add_argument("--scale-error", type=float, default=0.0, metavar="FRACTION", help="yaw scale error (0.01: reads 1 %% more turn)")
    imu.add_argument("--drop", type=float, default=0.0, metavar="RATE", help="probability per report of losing it")
    imu.add_argument("--garbage", type=float, default=0.0, metavar="RATE", help="probability per report of a garbage burst before it")
    imu.add_argument("--bad-checksum", type=float, default=0.0, metavar="RATE", help="probability per report of a wrong checksum")
    imu.add_argument("--silent-after", type=int, metavar="N", help="go silent after N reports")
    imu.add_argument("--vanish-after", type=int, metavar="N", help="close the pty after N reports")
    imu.add_argument("--seed", type=int, help="seed for the noise and the fault injection")
    imu.set_defaults(func=_run_imu)

    # the three devices over one simulated world: the whole stack without hardware
    from clomp.runtime.cli.run import add_emulate_world

    add_emulate_world(devices)


def _scan_source(args: argparse.Namespace) -> Any:
    if args.scenario is not None:
        if getattr(args, "units", None):
            raise CliError("--units gives the units of the scans read with --scans; a scenario is in metres")
        try:
            from clomp.runtime.backends.sim import scenario_scan_source
        except ImportError as exc:
            raise CliError(f"scenario-driven emulation needs the simulation module (clomp.runtime.backends.sim): {exc}") from exc
        scene = load_scene(args.scenario)
        try:
            return scenario_scan_source(scene, seed=args.seed)
        except (OSError, KeyError, ValueError) as exc:
            raise CliError(f"cannot simulate scenario {args.scenario!r}: {exc}") from exc
    if args.scans is None:
        raise CliError("emulate lidar needs a scan source: --scans DIR (recorded mapNNNN.dat files) or --scenario NAME")
    from clomp.runtime.devices.rplidar_emulator import recorded_scan_source

    try:
        recorded = recorded_scan_source(args.scans)
    except (OSError, ValueError) as exc:
        raise CliError(str(exc)) from exc
    return _in_metres(recorded, getattr(args, "units", None), f"--scans: {args.scans}")


def _in_metres(source: Any, units: str | None, what: str) -> Any:
    """``source`` (a recorded scan source) in metres: its first scan is read here, so that a
    recording that looks like millimetres, given without ``--units``, is one CliError line
    before the emulator starts (the rest of the recording is in the same units), and is the
    first one served."""
    first = [read_points(source(), units, what)]
    units = units or "m"

    def metres() -> Any:
        return first.pop() if first else read_points(source(), units, what)

    return metres


def _serve(emulator: Any, what: str, label: str, next_step: str) -> int:
    """Start ``emulator``, print its labelled port and what to run next, serve until Ctrl-C.

    Ctrl-C and SIGTERM stop it even when the parent shell ignored SIGINT (a background
    job): the handler is installed here rather than inherited.
    """
    try:
        emulator.start()
    except OSError as exc:
        raise CliError(f"cannot open a pseudo-terminal for the {what} emulator: {exc}") from exc
    try:
        with interrupts_raise():
            print(f"{label}: {emulator.port}", flush=True)
            print(f"next: {next_step.format(port=emulator.port)}   (Ctrl-C stops the emulator)", flush=True)
            while emulator.running:
                time.sleep(0.1)
            reason = f": {emulator.error}" if emulator.error else " (fault injection)"
            print(f"{what} emulator closed its port{reason}", file=sys.stderr)
    except KeyboardInterrupt:
        pass
    finally:
        emulator.stop()
    return 0


def _run_lidar(args: argparse.Namespace) -> int:
    from clomp.runtime.devices.rplidar_emulator import LidarEmulator

    status = {"good": 0, "warning": 1, "error": 2}[args.health]
    if not 0 <= args.error_code <= 0xFFFF:
        raise CliError("--error-code must be in 0..65535")
    try:
        emulator = LidarEmulator(
            _scan_source(args),
            speed=args.speed,
            garbage_rate=args.garbage,
            bad_check_rate=args.bad_check,
            silent_after=args.silent_after,
            vanish_after=args.vanish_after,
            health_status=status,
            health_error_code=args.error_code,
            seed=args.seed,
        )
    except ValueError as exc:
        raise CliError(str(exc)) from exc
    return _serve(emulator, "LiDAR", "lidar", "clomp run --lidar {port} --dry-run --goal 1.0,0.0")


def _run_maestro(args: argparse.Namespace) -> int:
    from clomp.runtime.devices.maestro_emulator import MaestroEmulator

    if not 0 <= args.device_number <= 127:
        raise CliError("--device-number must be in 0..127")
    last: list[tuple[float, float]] = []

    def show(left: float, right: float) -> None:
        if not last or last[0] != (left, right):
            last[:] = [(left, right)]
            print(f"left={left:+.3f} right={right:+.3f}", flush=True)

    emulator = MaestroEmulator(
        device_number=args.device_number,
        serial_timeout=args.serial_timeout,
        on_speeds=show if args.show_speeds else None,
    )
    return _serve(emulator, "Maestro", "motors", "clomp run --lidar LIDAR_PORT --motors {port} --goal 1.0,0.0")


def _run_imu(args: argparse.Namespace) -> int:
    import math

    from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator

    rate = math.radians(args.turn_rate)
    try:
        emulator = Bno08xEmulator(
            lambda: rate * time.monotonic(),  # the true heading: still, or a steady turn (the emulator's clock)
            drift=math.radians(args.drift) / 60.0,
            noise=math.radians(args.noise),
            scale_error=args.scale_error,
            drop_rate=args.drop,
            garbage_rate=args.garbage,
            bad_checksum_rate=args.bad_checksum,
            silent_after=args.silent_after,
            vanish_after=args.vanish_after,
            seed=args.seed,
        )
    except ValueError as exc:
        raise CliError(str(exc)) from exc
    return _serve(emulator, "IMU", "imu", "clomp run --lidar LIDAR_PORT --motors MOTOR_PORT --imu {port} --goal 1.0,0.0")
