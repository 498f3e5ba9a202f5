"""RPLIDAR A1 codec, stream decoder and driver (against scripted serial objects)."""

from __future__ import annotations

import errno
import os
import random
import time

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.rplidar import (
    HEALTH_DESCRIPTOR,
    INFO_DESCRIPTOR,
    SCAN_DESCRIPTOR,
    Command,
    Descriptor,
    DeviceInfo,
    HealthStatus,
    LidarError,
    LidarHealthError,
    LidarPortError,
    LidarProtocolError,
    LidarSampleError,
    LidarTimeout,
    RPLidar,
    ScanDecoder,
    decode_health,
    decode_info,
    decode_sample,
    encode_descriptor,
    encode_health,
    encode_info,
    encode_request,
    encode_sample,
    parse_descriptor,
    polar_to_robot,
)

# ------------------------------------------------------------------ requests, descriptors


def test_requests_without_payload_are_two_bytes() -> None:
    assert encode_request(Command.STOP) == bytes.fromhex("a5 25")
    assert encode_request(Command.SCAN) == bytes.fromhex("a5 20")
    assert encode_request(Command.GET_HEALTH) == bytes.fromhex("a5 52")


def test_request_payload_has_length_and_xor_checksum() -> None:
    # A5 ^ F0 ^ 02 ^ 94 ^ 02 = C1
    pwm = encode_request(Command.SET_MOTOR_PWM, (660).to_bytes(2, "little"))
    assert pwm == bytes.fromhex("a5 f0 02 94 02 c1")


def test_payload_on_a_command_without_bit7_is_refused() -> None:
    with pytest.raises(ValueError, match="no payload"):
        encode_request(Command.GET_INFO, b"\x01")


def test_descriptors_decode_like_the_datasheet() -> None:
    assert parse_descriptor(bytes.fromhex("a5 5a 05 00 00 40 81")) == SCAN_DESCRIPTOR == Descriptor(5, 1, 0x81)
    assert parse_descriptor(bytes.fromhex("a5 5a 14 00 00 00 04")) == INFO_DESCRIPTOR
    assert parse_descriptor(bytes.fromhex("a5 5a 03 00 00 00 06")) == HEALTH_DESCRIPTOR


def test_descriptor_without_sync_is_a_protocol_error() -> None:
    with pytest.raises(LidarProtocolError, match="A5 5A"):
        parse_descriptor(bytes.fromhex("a5 00 05 00 00 40 81"))
    with pytest.raises(LidarProtocolError, match="7 bytes"):
        parse_descriptor(b"\xa5\x5a")


@given(st.integers(0, (1 << 30) - 1), st.integers(0, 3), st.integers(0, 255))
def test_descriptor_round_trip(length: int, mode: int, data_type: int) -> None:
    d = Descriptor(length, mode, data_type)
    assert parse_descriptor(encode_descriptor(d)) == d


# ----------------------------------------------------------------------------- samples


def test_sample_fields_from_hand_computed_bytes() -> None:
    # S=1, quality 15: 15<<2 | 0b01 = 0x3D; angle_q6 5760 (90°): b1 = 0x01, b2 = 45;
    # distance_q2 1000 (250 mm) little-endian E8 03
    assert decode_sample(bytes([0x3D, 0x01, 0x2D, 0xE8, 0x03])) == (True, 15, 90.0, 250.0)
    # S=0, quality 47: 47<<2 | 0b10 = 0xBE; angle_q6 12345 = 0x3039: low 7 bits 0x39 ->
    # b1 = 0x39<<1|1 = 0x73, b2 = 12345>>7 = 0x60; distance_q2 0xBEEF -> EF BE
    start, quality, angle, dist = decode_sample(bytes([0xBE, 0x73, 0x60, 0xEF, 0xBE]))
    assert (start, quality) == (False, 47)
    assert angle == 12345 / 64 == 192.890625
    assert dist == 0xBEEF / 4 == 12219.75


def test_encode_sample_matches_hand_computed_bytes() -> None:
    assert encode_sample(True, 15, 5760, 1000) == bytes([0x3D, 0x01, 0x2D, 0xE8, 0x03])
    assert encode_sample(False, 47, 12345, 0xBEEF) == bytes([0xBE, 0x73, 0x60, 0xEF, 0xBE])
    assert encode_sample(False, 47, 12345, 0xBEEF, check_bit=False)[1] == 0x72


@pytest.mark.parametrize("b0", [0x3C, 0x3F], ids=["S=0,notS=0", "S=1,notS=1"])
def test_sample_with_equal_start_flags_is_rejected(b0: int) -> None:
    with pytest.raises(LidarSampleError, match="start flags"):
        decode_sample(bytes([b0, 0x01, 0x2D, 0xE8, 0x03]))


def test_sample_with_check_bit_zero_is_rejected() -> None:
    with pytest.raises(LidarSampleError, match="check bit"):
        decode_sample(bytes([0x3D, 0x00, 0x2D, 0xE8, 0x03]))
    assert issubclass(LidarSampleError, LidarProtocolError) and issubclass(LidarProtocolError, LidarError)


@given(st.booleans(), st.integers(0, 63), st.integers(0, 32767), st.integers(0, 65535))
def test_sample_round_trip_over_full_ranges(start: bool, quality: int, angle_q6: int, distance_q2: int) -> None:
    raw = encode_sample(start, quality, angle_q6, distance_q2)
    assert len(raw) == 5
    assert decode_sample(raw) == (start, quality, angle_q6 / 64, distance_q2 / 4)


@pytest.mark.parametrize(
    "args", [(True, 64, 0, 0), (True, -1, 0, 0), (True, 0, 32768, 0), (True, 0, 0, 65536), (True, 0, -1, 0)]
)
def test_encode_sample_refuses_out_of_range_fields(args: tuple[bool, int, int, int]) -> None:
    with pytest.raises(ValueError):
        encode_sample(*args)


# ------------------------------------------------------------------------ info, health


def test_health_error_code_is_little_endian() -> None:
    health = decode_health(bytes([2, 0x34, 0x12]))
    assert health == HealthStatus(2, 0x1234)
    assert health.name == "error"
    assert decode_health(bytes([0, 0, 0])).name == "good"
    assert decode_health(bytes([1, 0x01, 0x00])) == HealthStatus(1, 1)


def test_info_fields() -> None:
    serial = bytes(range(0xA0, 0xB0))
    info = decode_info(bytes([0x18, 29, 1, 7]) + serial)
    assert (info.model, info.firmware_minor, info.firmware_major, info.hardware) == (0x18, 29, 1, 7)
    assert info.firmware == "1.29"
    assert info.serial_hex == "A0A1A2A3A4A5A6A7A8A9AAABACADAEAF"
    with pytest.raises(LidarProtocolError):
        decode_info(b"\x00" * 19)


@given(st.integers(0, 255), st.integers(0, 0xFFFF))
def test_health_round_trip(status: int, code: int) -> None:
    h = HealthStatus(status, code)
    assert decode_health(encode_health(h)) == h


@given(st.tuples(*[st.integers(0, 255)] * 4), st.binary(min_size=16, max_size=16))
def test_info_round_trip(head: tuple[int, int, int, int], serial: bytes) -> None:
    info = DeviceInfo(*head, serial)
    assert decode_info(encode_info(info)) == info


# ------------------------------------------------------------------------------- frame


def test_clockwise_angles_become_robot_frame_points() -> None:
    pts = polar_to_robot(np.array([0.0, 90.0, 180.0, 270.0]), np.array([1000.0, 500.0, 250.0, 2000.0]))
    np.testing.assert_allclose(pts, [[1.0, 0.0], [0.0, -0.5], [-0.25, 0.0], [0.0, 2.0]], atol=1e-12)


# ----------------------------------------------------------------------- stream decoder


def _revolution(n: int = 360, dist_q2: int = 4000, quality: int = 15) -> list[bytes]:
    """n samples evenly spread over 360° (the decoder expects A1-like steps of a few °)."""
    step = 360 * 64 // n
    return [encode_sample(k == 0, quality, k * step, dist_q2 + k) for k in range(n)]


def _sparse_revolution(returns: dict[int, tuple[int, int]]) -> list[bytes]:
    """360 samples 1° apart, all without a return except ``{degree: (distance_q2, quality)}``."""
    out = []
    for deg in range(360):
        dist, quality = returns.get(deg, (0, 0))
        out.append(encode_sample(deg == 0, quality, deg * 64, dist))
    return out


def test_decoder_assembles_revolutions_at_start_flags() -> None:
    partial = [encode_sample(False, 15, 350 * 64 + k * 64, 400) for k in range(10)]
    revs = [_revolution(72) for _ in range(3)]
    d = ScanDecoder()
    out = d.feed(b"".join(partial + revs[0] + revs[1] + revs[2]))
    assert len(out) == 2  # the third is complete only when the next start flag arrives
    assert d.discarded_samples == 10
    for rev in out:
        np.testing.assert_array_equal(rev.angle_deg, np.arange(72) * 5.0)
        np.testing.assert_array_equal(rev.distance_mm, (4000 + np.arange(72)) / 4)
        assert (rev.quality == 15).all()
    assert len(d.feed(_revolution(72)[0] + _revolution(72)[1])) == 1
    assert d.dropped_bytes == 0


@given(st.lists(st.integers(1, 40), min_size=1, max_size=60))
def test_decoder_is_independent_of_chunking(cuts: list[int]) -> None:
    stream = b"".join(sum((_revolution(72) for _ in range(4)), []))
    whole = ScanDecoder().feed(stream)
    d = ScanDecoder()
    got = []
    pos = 0
    for c in cuts:
        got += d.feed(stream[pos : pos + c])
        pos += c
    got += d.feed(stream[pos:])
    assert [r.angle_deg.tolist() for r in got] == [r.angle_deg.tolist() for r in whole]
    assert [r.distance_mm.tolist() for r in got] == [r.distance_mm.tolist() for r in whole]


def test_decoder_resyncs_after_garbage_and_counts_dropped_bytes() -> None:
    rev = _revolution(72)
    garbage = bytes([0xFF, 0x00, 0x13])
    stream = b"".join(rev[:10]) + garbage + b"".join(rev[10:]) + rev[0] + rev[1]
    d = ScanDecoder()
    (out,) = d.feed(stream)
    np.testing.assert_array_equal(out.angle_deg, np.arange(72) * 5.0)
    assert d.dropped_bytes == len(garbage)


def test_decoder_skips_leading_garbage() -> None:
    rev = _revolution(72)
    d = ScanDecoder()
    (out,) = d.feed(b"\x5a\xa5\x81\x07" + b"".join(rev) + rev[0] + rev[1])
    assert len(out) == 72
    assert d.dropped_bytes == 4


def test_decoder_drops_a_sample_with_a_bad_check_bit() -> None:
    rev = _revolution(72)
    bad = bytearray(rev[5])
    bad[1] &= 0xFE
    stream = b"".join(rev[:5]) + bytes(bad) + b"".join(rev[6:]) + rev[0] + rev[1]
    d = ScanDecoder()
    (out,) = d.feed(stream)
    assert len(out) == 71
    assert 25.0 not in out.angle_deg
    assert d.dropped_bytes == 5


def test_decoder_recovers_almost_everything_from_a_noisy_stream() -> None:
    rng = random.Random(7)
    n_rev = 100
    stream = bytearray()
    for _ in range(n_rev):
        for k in range(360):
            if rng.random() < 0.01:  # ~3.6 garbage bursts per revolution
                stream += bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
            stream += encode_sample(k == 0, 15, k * 64, rng.randrange(1, 4000))
    stream += encode_sample(True, 15, 0, 100) + encode_sample(False, 15, 64, 100)
    d = ScanDecoder()
    revs = d.feed(bytes(stream))
    assert abs(len(revs) - n_rev) <= 2
    assert sum(len(r) for r in revs) >= 0.99 * n_rev * 360
    assert sum(len(r) == 360 for r in revs) >= 0.9 * n_rev


# ------------------------------------------------------------------- driver with fakes


class ScriptedPort:
    """A serial-like object that answers known requests with canned bytes."""

    def __init__(self, replies: dict[bytes, bytes] | None = None, *, dtr_error: OSError | None = None) -> None:
        self.replies = replies or {}
        self.timeout: float | None = 0.01
        self.written = bytearray()
        self.rx = bytearray()
        self.dtr_log: list[bool] = []
        self._dtr_error = dtr_error
        self.closed = False

    @property
    def dtr(self) -> bool:
        return self.dtr_log[-1] if self.dtr_log else True

    @dtr.setter
    def dtr(self, value: bool) -> None:
        if self._dtr_error is not None:
            raise self._dtr_error
        self.dtr_log.append(value)

    def write(self, data: bytes) -> int:
        self.written += data
        self.rx += self.replies.get(bytes(data), b"")
        return len(data)

    def read(self, n: int = 1) -> bytes:
        if not self.rx:
            time.sleep(self.timeout or 0)
            return b""
        out = bytes(self.rx[:n])
        del self.rx[:n]
        return out

    @property
    def in_waiting(self) -> int:
        return len(self.rx)

    def reset_input_buffer(self) -> None:
        self.rx.clear()

    def flush(self) -> None:
        pass

    def close(self) -> None:
        self.closed = True


def _scan_reply(samples: list[bytes]) -> bytes:
    return encode_descriptor(SCAN_DESCRIPTOR) + b"".join(samples)


def test_info_and_health_from_a_serial_like_object() -> None:
    info = DeviceInfo(0x18, 29, 1, 7, bytes(16))
    port = ScriptedPort(
        {
            encode_request(Command.GET_INFO): b"RP LIDAR banner\r\n" + encode_descriptor(INFO_DESCRIPTOR) + encode_info(info),
            encode_request(Command.GET_HEALTH): encode_descriptor(HEALTH_DESCRIPTOR) + bytes([1, 0x02, 0x01]),
        }
    )
    lidar = RPLidar(port, motor_control="none")
    assert lidar.info() == info
    assert lidar.health() == HealthStatus(1, 0x0102)  # a warning is returned, not raised
    lidar.close()
    assert not port.closed  # a port object we were given is not ours to close


def test_health_error_status_raises_with_little_endian_code() -> None:
    port = ScriptedPort({encode_request(Command.GET_HEALTH): encode_descriptor(HEALTH_DESCRIPTOR) + bytes([2, 0x34, 0x12])})
    with pytest.raises(LidarHealthError, match="0x1234") as err:
        RPLidar(port, motor_control="none").health()
    assert err.value.error_code == 0x1234 and err.value.status == 2


def test_wrong_descriptor_is_a_protocol_error() -> None:
    port = ScriptedPort({encode_request(Command.GET_HEALTH): encode_descriptor(INFO_DESCRIPTOR) + bytes(20)})
    with pytest.raises(LidarProtocolError, match="GET_HEALTH"):
        RPLidar(port, motor_control="none").health()


def test_scan_points_are_in_robot_frame_without_zero_and_far_returns() -> None:
    rev = _sparse_revolution(
        {
            0: (2000, 10),  # 0°, 0.5 m: straight ahead
            90: (1200, 11),  # 90° clockwise, 0.3 m: to the right
            180: (0, 12),  # no return
            270: (4000, 13),  # 270° clockwise, 1.0 m: to the left
            300: (8000, 14),  # 2 m: beyond the default 1.1 m
        }
    )
    samples = rev + rev[:2]
    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply(samples)})
    lidar = RPLidar(port, motor_control="none")
    t0 = time.monotonic()
    scan = lidar.read_scan(timeout=1.0)
    np.testing.assert_allclose(scan.points, [[0.5, 0.0], [0.0, -0.3], [0.0, 1.0]], atol=1e-12)
    assert scan.quality is not None and scan.quality.tolist() == [10, 11, 13]
    assert t0 <= scan.timestamp <= time.monotonic()

    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply(samples)})
    uncropped = RPLidar(port, motor_control="none", max_range=None).read_scan(timeout=1.0)
    assert len(uncropped.points) == 4


def test_dtr_runs_the_motor_low_and_stop_sends_stop_then_motor_off() -> None:
    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply([])})
    lidar = RPLidar(port)
    lidar.start_scan()
    assert port.dtr_log == [False]  # A1: DTR low runs the motor
    lidar.stop()
    assert port.dtr_log == [False, True]
    assert port.written.endswith(encode_request(Command.STOP))
    assert not lidar.scanning


def test_dtr_unsupported_on_a_pty_is_tolerated() -> None:
    port = ScriptedPort(
        {encode_request(Command.SCAN): _scan_reply([])}, dtr_error=OSError(errno.ENOTTY, "Inappropriate ioctl for device")
    )
    lidar = RPLidar(port)
    lidar.start_scan()
    lidar.stop()
    assert lidar.scanning is False


def test_dtr_failure_of_a_vanished_device_is_a_port_error() -> None:
    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply([])}, dtr_error=OSError(errno.EIO, "I/O error"))
    with pytest.raises(LidarPortError, match="motor"):
        RPLidar(port).start_scan()


def test_motor_control_callable() -> None:
    calls: list[bool] = []
    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply([])})
    lidar = RPLidar(port, motor_control=calls.append)
    lidar.start_scan()
    lidar.stop()
    assert calls == [True, False]


def test_queries_while_scanning_are_refused() -> None:
    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply([])})
    lidar = RPLidar(port, motor_control="none")
    lidar.start_scan()
    with pytest.raises(LidarError, match="stop"):
        lidar.health()


class InFlightPort(ScriptedPort):
    """A device whose samples already sent keep arriving after STOP (one chunk each time the
    driver looks), as through a USB adapter's buffer; later replies queue behind them."""

    def __init__(self, replies: dict[bytes, bytes], in_flight: list[bytes]) -> None:
        super().__init__(replies)
        self._in_flight_after_stop = in_flight
        self.in_flight: list[bytes] = []

    def _arrive(self) -> None:
        if self.in_flight:
            self.rx += self.in_flight.pop(0)

    def write(self, data: bytes) -> int:
        reply = self.replies.get(bytes(data), b"")
        self.written += data
        if bytes(data) == encode_request(Command.STOP):
            self.in_flight = list(self._in_flight_after_stop)
        elif self.in_flight:
            self.in_flight.append(reply)  # behind the bytes still on their way
        else:
            self.rx += reply
        return len(data)

    def read(self, n: int = 1) -> bytes:
        self._arrive()
        return super().read(n)

    @property
    def in_waiting(self) -> int:
        self._arrive()
        return len(self.rx)


def _tail_with_a_false_sync() -> list[bytes]:
    # angle_q6 bits 7-14 = 0xA5 (330.0°..331.9°) followed by distance_q2's low byte 0x5A: "A5 5A"
    tail = [encode_sample(False, 15, (0xA5 << 7) + k, 0x0100 + 0x5A) for k in range(0, 128, 16)]
    assert all(b"\xa5\x5a" in s for s in tail)
    return [b"".join(tail[i:i + 2]) for i in range(0, len(tail), 2)]



@pytest.mark.parametrize("then", ["health", "scan"])
def test_stop_drains_the_samples_still_in_flight_before_the_next_request(then: str) -> None:
    """The revolution in flight when STOP went out must not reach the next request's reply."""
    rev = _sparse_revolution({0: (2000, 10)})
    health = encode_descriptor(HEALTH_DESCRIPTOR) + bytes([0, 0, 0])
    port = InFlightPort(
        {encode_request(Command.SCAN): _scan_reply(rev + rev[:2]), encode_request(Command.GET_HEALTH): health},
        _tail_with_a_false_sync(),
    )
    lidar = RPLidar(port, motor_control="none", timeout=1.0)
    lidar.read_scan(timeout=1.0)
    lidar.stop()
    assert not port.in_flight  # the device had really stopped when stop() returned
    if then == "health":
        assert lidar.health() == HealthStatus(0, 0)
    else:
        scan = lidar.read_scan(timeout=1.0)
        np.testing.assert_allclose(scan.points, [[0.5, 0.0]], atol=1e-12)


class ClockedPort(ScriptedPort):
    """A scripted port on the test's clock: a read that finds nothing lets its timeout pass on
    that clock instead of sleeping, so how late a timeout comes is exact, whatever the load."""

    def __init__(self, replies: dict[bytes, bytes] | None = None) -> None:
        super().__init__(replies)
        self.clock = ManualClock(100.0)

    def read(self, n: int = 1) -> bytes:
        if not self.rx:
            self.clock.advance(self.timeout or 0.0)
            return b""
        return super().read(n)


def test_silent_device_times_out_on_queries() -> None:
    port = ClockedPort()
    lidar = RPLidar(port, motor_control="none", clock=port.clock.now)
    for call in (lambda: lidar.info(timeout=0.3), lambda: lidar.start_scan(timeout=0.3)):
        t0 = port.clock.now()
        with pytest.raises(LidarTimeout):
            call()
        # not before the timeout, and late by at most one read of the port
        assert 0.3 <= port.clock.now() - t0 <= 0.3 + port.timeout + 1e-9


def test_a_reader_kept_from_running_past_its_deadline_still_reads_what_is_waiting() -> None:
    """On a busy computer the reading thread may run again only after its deadline: the
    revolution already waiting in the port is returned, not a timeout (the stream watch would
    call a streaming LiDAR silent). Time jumps 1 s at every look at the clock: always late."""
    rev = _revolution()
    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply(rev + rev[:2])})
    ticks = iter(range(1000, 10**6))
    lidar = RPLidar(port, motor_control="none", clock=lambda: float(next(ticks)))
    lidar.start_scan()
    frame = lidar.read_scan(timeout=0.05)
    assert len(frame.points) == 360
    with pytest.raises(LidarTimeout, match="no full revolution"):  # and once nothing is waiting: late is late
        lidar.read_scan(timeout=0.05)


def test_device_silent_after_the_descriptor_times_out_on_read_scan() -> None:
    port = ClockedPort({encode_request(Command.SCAN): _scan_reply(_revolution()[:200])})
    lidar = RPLidar(port, motor_control="none", clock=port.clock.now)
    lidar.start_scan()
    t0 = port.clock.now()
    with pytest.raises(LidarTimeout, match="no full revolution"):
        lidar.read_scan(timeout=0.3)
    assert 0.3 <= port.clock.now() - t0 <= 0.3 + port.timeout + 1e-9


def test_silent_pty_times_out() -> None:
    master, slave = os.openpty()
    try:
        lidar = RPLidar(os.ttyname(slave))
        t0 = time.monotonic()
        with pytest.raises(LidarTimeout):
            lidar.health(timeout=0.3)
        # not before the timeout; how late, on an injected clock: test_silent_device_times_out_on_queries
        assert time.monotonic() - t0 >= 0.3
        lidar.close()
    finally:
        os.close(master)
        os.close(slave)


def test_missing_port_is_a_port_error() -> None:
    with pytest.raises(LidarPortError, match="/dev/does-not-exist"):
        RPLidar("/dev/does-not-exist")


def test_loop_url_is_accepted() -> None:
    lidar = RPLidar("loop://", timeout=0.2)
    assert lidar.port_name == "loop://"
    with pytest.raises((LidarTimeout, LidarProtocolError)):
        lidar.health()  # loop:// echoes the request back: no descriptor ever comes
    lidar.close()


def test_newest_skips_backlog_and_iter_scans_keeps_every_revolution() -> None:
    revs = [r for _ in range(4) for r in _revolution(72)] + _revolution(72)[:2]
    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply(revs)})
    lidar = RPLidar(port, motor_control="none")
    lidar.read_scan(timeout=1.0)
    assert lidar.skipped_scans == 3

    port = ScriptedPort({encode_request(Command.SCAN): _scan_reply(revs)})
    lidar = RPLidar(port, motor_control="none")
    scans = lidar.iter_scans(timeout=1.0)
    assert [len(next(scans).points) for _ in range(4)] == [72] * 4
    assert lidar.skipped_scans == 0


def test_each_point_carries_when_it_was_measured_once_a_revolution_was_timed() -> None:
    """A revolution's samples come in the order the A1 measured them, at a steady turn: the
    driver times the revolution from the ends of the revolutions before it and each point
    from its angle, so the last point is the newest and the first a period older. The first
    revolution, with no period yet, carries no times rather than guessed ones."""
    from clomp.runtime.devices.rplidar_emulator import LidarEmulator
    from tests.runtime._simline import SimLine

    ring = np.c_[0.6 * np.cos(np.radians(np.arange(0, 360, 3))), 0.6 * np.sin(np.radians(np.arange(0, 360, 3)))]
    clock = ManualClock(50.0)
    device = LidarEmulator(lambda: ring, sample_rate=2000.0, samples_per_rev=360, clock=clock.now)  # 0.18 s a turn
    lidar = RPLidar(SimLine(device, clock, name="sim-lidar"), motor_control="none", clock=clock.now)
    try:
        frames = [lidar.read_scan(timeout=2.0, newest=False) for _ in range(5)]
    finally:
        lidar.close()
    assert frames[0].point_times is None
    assert lidar.period is not None and abs(lidar.period - 0.18) < 0.006
    for f in frames[1:]:
        assert f.point_times is not None and len(f.point_times) == len(f.points) == 120
        cw = np.degrees(-np.arctan2(f.points[:, 1], f.points[:, 0])) % 360.0
        np.testing.assert_allclose(f.point_times, (cw / 360.0 - 1.0) * 0.18, atol=0.008)
        assert np.all(np.diff(f.point_times) >= 0) and f.point_times[-1] <= 0.0
    stamps = np.diff([f.timestamp for f in frames])
    np.testing.assert_allclose(stamps, 0.18, atol=0.006)
