"""Device emulators on pseudo-terminals, end to end with the real drivers, and the CLI."""

from __future__ import annotations

import math
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import serial

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.emulators import (
    LidarEmulator,
    MaestroEmulator,
    load_scan_file,
    recorded_scan_source,
    scan_to_samples,
)
from clomp.runtime.devices.bno08x import Bno08xRvc
from clomp.runtime.devices.maestro import encode_set_target
from clomp.runtime.devices.rplidar import (
    Command,
    LidarHealthError,
    LidarPortError,
    LidarTimeout,
    RPLidar,
    encode_request,
)

REPO = Path(__file__).resolve().parents[2]

# ----------------------------------------------------------------------- scan sources


def test_scan_files_load_and_empty_files_are_empty_scans(tmp_path: Path) -> None:
    (tmp_path / "map0001.dat").write_text("0.50\t0.10\n-0.20\t0.30\n")
    (tmp_path / "map0002.dat").write_text("")
    (tmp_path / "notes.txt").write_text("not a scan")
    np.testing.assert_array_equal(load_scan_file(tmp_path / "map0001.dat"), [[0.5, 0.1], [-0.2, 0.3]])
    assert load_scan_file(tmp_path / "map0002.dat").shape == (0, 2)
    source = recorded_scan_source(tmp_path)
    shapes = [source().shape for _ in range(3)]
    assert shapes == [(2, 2), (0, 2), (2, 2)]  # cycles in file order


def test_malformed_scan_file_names_file_and_line(tmp_path: Path) -> None:
    (tmp_path / "map0001.dat").write_text("0.5\t0.1\n0.5 oops\n")
    with pytest.raises(ValueError, match=r"map0001\.dat:2"):
        recorded_scan_source(tmp_path)


def test_scan_folder_errors_are_clear(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="not found"):
        recorded_scan_source(tmp_path / "missing")
    (tmp_path / "corridor").mkdir()
    with pytest.raises(FileNotFoundError, match="subfolders: corridor"):
        recorded_scan_source(tmp_path)


def test_scan_to_samples_keeps_the_nearest_return_per_clockwise_bin() -> None:
    pts = np.array([[1.0, 0.0], [0.0, -0.5], [0.0, -0.4], [-0.3, 0.0], [0.0, 2.0], [np.nan, 1.0]])
    angle, dist = scan_to_samples(pts)
    assert len(angle) == len(dist) == 360
    assert dist[0] == pytest.approx(1000.0)
    assert dist[90] == pytest.approx(400.0)  # right of the robot, nearest of two
    assert dist[180] == pytest.approx(300.0)
    assert dist[270] == pytest.approx(2000.0)  # left of the robot
    assert np.count_nonzero(dist) == 4
    assert np.all(np.diff(angle) > 0)  # angles rise through the revolution


# ---------------------------------------------------------------------------- LiDAR


def test_lidar_info_health_and_scan_round_trip() -> None:
    truth = np.array([[0.5, 0.0], [0.0, 0.5], [-0.3, -0.3], [0.4, -0.7], [2.0, 0.0]])
    with LidarEmulator(lambda: truth, speed=4.0) as emu, RPLidar(emu.port) as lidar:
        assert lidar.info().firmware == "1.29"
        assert lidar.health().name == "good"
        scan = lidar.read_scan(timeout=10.0)
        got = scan.points[np.lexsort(scan.points.T)]
        want = truth[:4][np.lexsort(truth[:4].T)]  # 2 m is beyond the 1.1 m crop
        np.testing.assert_allclose(got, want, atol=0.001)
        assert scan.quality is not None and (scan.quality == 15).all()
        lidar.stop()
        # the emulator's thread reads the request when it gets the CPU: wait for it
        assert emu.wait_for(lambda e: Command.STOP in e.requests, 10.0)


def test_lidar_health_error_code_end_to_end() -> None:
    with LidarEmulator(health_status=2, health_error_code=0x8001) as emu, RPLidar(emu.port) as lidar:
        with pytest.raises(LidarHealthError, match="0x8001") as err:
            lidar.health()
        assert err.value.error_code == 0x8001


def test_lidar_paces_like_the_device() -> None:
    # the emulator's own clock is the test's: exactly 2000 samples per second of device time
    clock = ManualClock(0.0)
    with LidarEmulator(lambda: np.array([[0.5, 0.0]]), clock=clock.now) as emu, RPLidar(emu.port) as lidar:
        lidar.start_scan()
        assert emu.wait_for(lambda e: e.scanning, 10.0)
        for k in range(1, 5):
            clock.advance(0.125)  # 250 samples due (exact in binary: no rounding at the edge)
            seen = emu.passes
            assert emu.wait_for(lambda e, seen=seen: e.passes >= seen + 2, 10.0)
            assert emu.samples_sent == 250 * k  # never ahead of the device's time, never behind
            assert emu.revolutions_sent == 250 * k // 360  # 360 samples a revolution: ~5.5 Hz
        # what was sent decodes to whole revolutions (the third is still open)
        assert len(lidar.read_scan(timeout=5.0, newest=False).points) == 1
        assert len(lidar.read_scan(timeout=5.0, newest=False).points) == 1


def test_empty_scans_stream_zero_distance_samples() -> None:
    with LidarEmulator(speed=4.0) as emu, RPLidar(emu.port, max_range=None) as lidar:
        scan = lidar.read_scan(timeout=10.0)
        assert scan.points.shape == (0, 2)
        assert emu.samples_sent >= 360


def test_lidar_survives_garbage_and_bad_check_bits() -> None:
    truth = np.array([[np.cos(a), np.sin(a)] for a in np.radians(np.arange(0, 360, 3) + 0.5)]) * 0.8
    with LidarEmulator(lambda: truth, speed=4.0, garbage_rate=0.02, bad_check_rate=0.01, seed=3) as emu:
        with RPLidar(emu.port) as lidar:
            scans = [lidar.read_scan(timeout=10.0, newest=False) for _ in range(6)]
            assert lidar.dropped_bytes > 0 and emu.garbage_bytes_sent > 0
    for scan in scans:
        r = np.hypot(scan.points[:, 0], scan.points[:, 1])
        on_ring = np.abs(r - 0.8) < 0.002
        assert on_ring.sum() >= 0.9 * len(truth)  # nearly every true point arrives
        assert (~on_ring).sum() <= 3  # few phantom points from garbage that looked valid


def test_silent_lidar_raises_timeout_within_the_timeout() -> None:
    with LidarEmulator(lambda: np.array([[0.5, 0.0]]), speed=4.0, silent_after=2) as emu:
        with RPLidar(emu.port) as lidar:
            lidar.read_scan(timeout=10.0, newest=False)  # revolution 1 (2 never completes)
            t0 = time.monotonic()
            with pytest.raises(LidarTimeout, match="no full revolution"):
                lidar.read_scan(timeout=0.5, newest=False)
            # not before the timeout; how late, on an injected clock: test_rplidar.py's ClockedPort tests
            assert time.monotonic() - t0 >= 0.5
            lidar.stop()
            with pytest.raises(LidarTimeout):
                lidar.health(timeout=0.2)  # silent: no answers either
        assert emu.silent


def test_lidar_vanishing_mid_scan_is_a_port_error() -> None:
    with LidarEmulator(lambda: np.array([[0.5, 0.0]]), speed=4.0, vanish_after=1.5) as emu:
        lidar = RPLidar(emu.port)
        with pytest.raises(LidarPortError, match="unplugged"):  # a port error, not a LidarTimeout
            for _ in range(10):
                lidar.read_scan(timeout=10.0)
        deadline = time.monotonic() + 10.0  # a hang guard, not a timing window
        while emu.running and time.monotonic() < deadline:
            time.sleep(0.01)  # the emulator thread ends right after closing the pty
        assert not emu.running and emu.error is None
        lidar.close()  # does not raise on a vanished device


def test_stop_ends_the_stream_and_reset_reboots() -> None:
    with LidarEmulator(speed=4.0, reset_time=0.05) as emu, RPLidar(emu.port) as lidar:
        lidar.start_scan()
        seen = emu.passes
        lidar.stop()
        # the emulator's thread reads STOP when it gets the CPU: wait for a whole pass after it
        assert emu.wait_for(lambda e: not e.scanning and e.passes > seen, 10.0)
        lidar._reset_input()  # anything on the wire before STOP took effect
        time.sleep(0.1)
        assert lidar._waiting() == 0
        lidar.reset(wait=0.2)
        assert lidar.health().status == 0  # the boot banner did not confuse the driver


def test_reconnect_resumes_scanning() -> None:
    with LidarEmulator(lambda: np.array([[0.5, 0.0]]), speed=4.0) as emu, RPLidar(emu.port) as lidar:
        lidar.read_scan(timeout=10.0)
        lidar.reconnect(timeout=10.0)
        assert lidar.scanning
        assert len(lidar.read_scan(timeout=10.0).points) == 1
        assert emu.requests.count(Command.SCAN) == 2


def test_request_with_bad_checksum_is_ignored() -> None:
    with LidarEmulator(speed=4.0) as emu, serial.Serial(emu.port, 115200, timeout=0.2) as port:
        good = encode_request(Command.SET_MOTOR_PWM, b"\x94\x02")
        port.write(good[:-1] + bytes([good[-1] ^ 1]) + encode_request(Command.GET_HEALTH))
        reply = port.read(10)
        assert reply == bytes.fromhex("a5 5a 03 00 00 00 06 00 00 00")
        assert emu.requests == [Command.GET_HEALTH]


def test_recorded_scans_come_back_through_the_driver(scans_dir: Path) -> None:
    first = recorded_scan_source(scans_dir)()
    with LidarEmulator(recorded_scan_source(scans_dir), speed=4.0) as emu, RPLidar(emu.port) as lidar:
        scan = lidar.read_scan(timeout=10.0, newest=False)
    # the emulator keeps one return per degree: every point the driver returns is one
    # of the recorded points (to the codec's resolution)
    d = np.hypot(*(scan.points[:, None, :] - first[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert len(scan.points) > 50 and d.max() < 0.001


# --------------------------------------------------------------------------- Maestro


def _raw(emu: MaestroEmulator) -> serial.Serial:
    return serial.Serial(emu.port, 115200, timeout=0.3)


def test_maestro_emulator_decodes_both_protocols() -> None:
    seen: list[tuple[float, float]] = []
    with MaestroEmulator(on_speeds=lambda left, right: seen.append((left, right))) as emu, _raw(emu) as port:
        port.write(bytes.fromhex("84 00 70 31"))  # channel 0: 6384 -> 1596 µs
        port.write(bytes.fromhex("AA 0C 04 01 10 2B"))  # channel 1: 5520 -> 1380 µs
        port.write(bytes.fromhex("AA 05 04 02 70 2E"))  # another device: ignored
        port.write(bytes.fromhex("90 01"))
        assert port.read(2) == (5520).to_bytes(2, "little")
        assert emu.targets[:3] == [6384, 5520, 0]
        assert seen[-1] == pytest.approx((0.96, 1.2))
        port.write(bytes.fromhex("9F 02 00 70 2E 70 2E"))
        assert emu.wait_for(lambda e: e.targets[:2] == [6000, 6000], 10.0)
        assert seen[-1] == (0.0, 0.0)
        port.write(bytes.fromhex("A1"))
        assert port.read(2) == b"\x00\x00"


def test_maestro_emulator_flags_protocol_errors_and_goes_home() -> None:
    with MaestroEmulator(home={0: 6000}) as emu, _raw(emu) as port:
        port.write(encode_set_target(0, 6400) + encode_set_target(1, 6400))
        port.write(b"\x05")  # a data byte where a command was expected
        port.write(bytes.fromhex("84 00 70 A2"))  # Set Target interrupted by Go Home
        port.write(bytes.fromhex("A1"))
        assert port.read(2) == (1 << 4).to_bytes(2, "little")
        assert emu.targets[:2] == [6000, 0]  # home positions: channel 0 configured, 1 off
        port.write(bytes.fromhex("A1"))
        assert port.read(2) == b"\x00\x00"


def test_maestro_emulator_serial_timeout_sends_channels_home() -> None:
    # the device's own clock is under the test's control: no scheduling luck involved
    clock = ManualClock(100.0)
    with MaestroEmulator(serial_timeout=0.1, clock=clock.now) as emu, _raw(emu) as port:
        port.write(encode_set_target(0, 6400))
        assert emu.wait_for(lambda e: e.targets[0] == 6400, 10.0)
        commanded = emu.events[-1][0]
        clock.advance(0.099)
        seen = emu.passes
        assert emu.wait_for(lambda e: e.passes >= seen + 2, 10.0)  # it looked at the new time
        assert emu.targets[0] == 6400  # not yet
        clock.advance(0.001)
        assert emu.wait_for(lambda e: e.targets[0] == 0, 10.0)
        assert emu.events[-1][0] - commanded == pytest.approx(0.1)
        port.write(bytes.fromhex("A1"))
        assert int.from_bytes(port.read(2), "little") == 1 << 5


def test_maestro_emulator_records_timed_events() -> None:
    with MaestroEmulator() as emu, _raw(emu) as port:
        t0 = time.monotonic()
        port.write(encode_set_target(0, 6200))
        assert emu.wait_for(lambda e: len(e.events) == 1, 10.0)
        t, ch, target = emu.events[0]
        assert (ch, target) == (0, 6200) and t0 <= t <= time.monotonic()


# ------------------------------------------------------------------------------- CLI

_HARNESS = textwrap.dedent(
    """
    import argparse, sys
    from clomp.runtime.cli import emulate as _cli_emulate
    from clomp.runtime.cli import CliError
    parser = argparse.ArgumentParser(prog="clomp")
    _cli_emulate.register(parser.add_subparsers())
    args = parser.parse_args(sys.argv[1:])
    try:
        sys.exit(args.func(args))
    except CliError as exc:
        print(f"clomp: error: {exc}", file=sys.stderr)
        sys.exit(2)
    """
)


def _cli(*argv: str, sigint_ignored: bool = False) -> subprocess.Popen[str]:
    """``clomp ARGV`` in a subprocess; ``sigint_ignored`` starts it as a background job of a
    non-interactive shell would be (SIGINT ignored)."""

    def ignore_sigint() -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    return subprocess.Popen(
        [sys.executable, "-c", _HARNESS, *argv],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=ignore_sigint if sigint_ignored else None,
    )


def _wait_for_port(proc: subprocess.Popen[str], label: str) -> str:
    """The port from the emulator's ``LABEL: /dev/pts/N`` line (then its ``next:`` line)."""
    assert proc.stdout is not None
    line = proc.stdout.readline().strip()
    assert line.startswith(f"{label}: /dev/"), (line, proc.stderr.read() if proc.stderr else "")
    port = line.split(": ", 1)[1]
    hint = proc.stdout.readline().strip()
    assert hint.startswith("next: clomp run ") and port in hint and "Ctrl-C" in hint, hint
    return port


@pytest.mark.parametrize("sigint_ignored", [False, True], ids=["foreground", "sigint-ignored-by-the-shell"])
def test_cli_emulate_maestro_prints_its_port_and_exits_cleanly_on_ctrl_c(sigint_ignored: bool) -> None:
    proc = _cli("emulate", "maestro", "--show-speeds", sigint_ignored=sigint_ignored)
    try:
        port = _wait_for_port(proc, "motors")
        with serial.Serial(port, 115200, timeout=0.5) as s:
            s.write(bytes.fromhex("9F 02 00 38 30 28 2D"))  # 6200, 5800 on channels 0, 1
            assert proc.stdout is not None
            assert proc.stdout.readline().strip() == "left=+0.500 right=+0.500"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)  # a hang guard: it exits promptly
    finally:
        proc.kill()
    assert proc.returncode == 0
    assert "Traceback" not in err


def test_cli_emulate_lidar_from_recorded_scans(tmp_path: Path) -> None:
    (tmp_path / "map0001.dat").write_text("0.50\t0.00\n")
    proc = _cli("emulate", "lidar", "--scans", str(tmp_path), "--speed", "4")
    try:
        port = _wait_for_port(proc, "lidar")
        with RPLidar(port) as lidar:
            np.testing.assert_allclose(lidar.read_scan(timeout=10.0).points, [[0.5, 0.0]], atol=0.001)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)  # a hang guard: it exits promptly
    finally:
        proc.kill()
    assert proc.returncode == 0 and "Traceback" not in err


def test_cli_emulate_imu_streams_a_turning_heading() -> None:
    proc = _cli("emulate", "imu", "--turn-rate", "90", "--noise", "0.1", "--seed", "1")
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline().strip()
        assert line.startswith("imu: /dev/"), (line, proc.stderr.read() if proc.stderr else "")
        port = line.split(": ", 1)[1]
        hint = proc.stdout.readline().strip()
        assert hint.startswith("next: ") and f"--imu {port}" in hint and "clomp run" in hint, hint
        # deadlines are not under test here (test_bno08x.py times them on simulated time)
        with Bno08xRvc(port, silence_timeout=30.0, start_timeout=30.0) as imu:
            assert imu.wait_for(lambda i: (r := i.rotation()) is not None and r > math.radians(10.0), 30.0)
            assert imu.fault is None and imu.decoder.bad_checksums == 0
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)  # a hang guard: it exits promptly
    finally:
        proc.kill()
    assert proc.returncode == 0 and "Traceback" not in err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["emulate", "lidar"], "--scans DIR"),
        (["emulate", "lidar", "--scans", "/nonexistent/scans"], "not found"),
        (["emulate", "lidar", "--scans", "{scans}", "--garbage", "2"], "probabilities"),
        (["emulate", "lidar", "--scans", "{scans}", "--error-code", "70000"], "0..65535"),
        (["emulate", "maestro", "--device-number", "200"], "0..127"),
        (["emulate", "imu", "--drop", "2"], "probability"),
        (["emulate", "imu", "--noise", "-1"], "noise"),
    ],
)
def test_cli_emulate_user_errors(argv: list[str], message: str, tmp_path: Path) -> None:
    (tmp_path / "map0001.dat").write_text("")
    proc = _cli(*[a.format(scans=tmp_path) for a in argv])
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 2
    assert message in err and "Traceback" not in err


def test_both_emulators_refuse_unknown_faults_and_bad_probabilities() -> None:
    """``inject`` (one body, PtyEmulator._set_faults): a misspelt fault or a rate outside [0, 1]
    is refused and nothing is switched; a known fault is set."""
    from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
    from clomp.runtime.devices.rplidar_emulator import LidarEmulator

    for make, rate in ((LidarEmulator, "garbage_rate"), (Bno08xEmulator, "drop_rate")):
        with make() as emu:
            with pytest.raises(ValueError, match="unknown fault"):
                emu.inject(silnet=True)
            with pytest.raises(ValueError, match="probability in"):
                emu.inject(**{rate: 1.5})
            assert getattr(emu, rate) != 1.5 and not emu.silent
            emu.inject(silent=True)
            assert emu.silent
