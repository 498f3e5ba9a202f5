"""The SLAMTEC RPLIDAR A1 serial protocol as pure functions: bytes in, values out.

No port, no clock: requests, response descriptors, scan samples, device info and health
encode and decode here, and :class:`ScanDecoder` turns an arbitrary byte stream into
full revolutions. The driver (:mod:`clomp.runtime.devices.rplidar`) and the emulator
(:mod:`clomp.runtime.devices.rplidar_emulator`) are both built on it, and so are the tests.

>>> encode_request(Command.GET_HEALTH).hex(" ")
'a5 52'
>>> decode_sample(bytes([0x3D, 0x01, 0x2D, 0xE8, 0x03]))
(True, 15, 90.0, 250.0)
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Command",
    "Descriptor",
    "DeviceInfo",
    "HealthStatus",
    "Revolution",
    "ScanDecoder",
    "LidarError",
    "LidarPortError",
    "LidarProtocolError",
    "LidarSampleError",
    "LidarTimeout",
    "LidarHealthError",
    "encode_request",
    "encode_descriptor",
    "parse_descriptor",
    "encode_sample",
    "decode_sample",
    "encode_info",
    "decode_info",
    "encode_health",
    "decode_health",
    "polar_to_robot",
    "SCAN_DESCRIPTOR",
    "INFO_DESCRIPTOR",
    "HEALTH_DESCRIPTOR",
    "SAMPLERATE_DESCRIPTOR",
    "DEFAULT_BAUDRATE",
    "SAMPLE_SIZE",
    "SYNC_BYTE",
    "SYNC_BYTE2",
]

SYNC_BYTE = 0xA5
SYNC_BYTE2 = 0x5A
DEFAULT_BAUDRATE = 115200
SAMPLE_SIZE = 5
FULL_CIRCLE_Q6 = 360 * 64
# plausible angle step between consecutive samples (A1: 0.2-2° apart, a few may be lost)
_MAX_STEP_Q6 = 10 * 64
_BACK_STEP_Q6 = 2 * 64
_RECENT_BYTES = 3 * SAMPLE_SIZE + 1
# at most this many samples at the end of a sweep are taken for strays (see ScanDecoder)
_MAX_STRAYS = 8
# this many samples in a row without a new furthest angle: a misaligned lock, not a sweep
_MAX_STALL = 6


class Command(enum.IntEnum):
    """Request command bytes (sent after ``A5``)."""

    STOP = 0x25
    RESET = 0x40
    SCAN = 0x20
    FORCE_SCAN = 0x21
    GET_INFO = 0x50
    GET_HEALTH = 0x52
    GET_SAMPLERATE = 0x59
    SET_MOTOR_PWM = 0xF0


# ---------------------------------------------------------------------------- errors


class LidarError(Exception):
    """Base class of every error raised by the LiDAR layer."""


class LidarPortError(LidarError):
    """The serial port cannot be opened, or it failed (device unplugged, pty closed)."""


class LidarProtocolError(LidarError):
    """The device sent bytes that do not follow the protocol (bad descriptor, sample)."""


class LidarSampleError(LidarProtocolError):
    """A 5-byte scan sample is malformed: S == not-S, or the check bit C is 0."""


class LidarTimeout(LidarError):
    """The device did not answer, or sent no full revolution, within the timeout."""


class LidarHealthError(LidarError):
    """GET_HEALTH reported status 2 (error): the device needs a reset or service."""

    def __init__(self, status: int, error_code: int) -> None:
        self.status = status
        self.error_code = error_code
        super().__init__(
            f"RPLIDAR reports health status {status} (error) with error code "
            f"{error_code} (0x{error_code:04X}); try reset() or power-cycle the device"
        )


# ----------------------------------------------------------------------------- codec


def encode_request(cmd: int, payload: bytes = b"") -> bytes:
    """The bytes of a request: ``A5 cmd`` or ``A5 cmd len payload checksum``.

    A payload is sent only for commands with bit 7 set; the checksum is the XOR of
    every byte before it, ``A5`` included.

    >>> encode_request(Command.SET_MOTOR_PWM, (660).to_bytes(2, "little")).hex(" ")
    'a5 f0 02 94 02 c1'
    """
    if not 0 <= cmd <= 0xFF:
        raise ValueError(f"command byte out of range: {cmd}")
    if not cmd & 0x80:
        if payload:
            raise ValueError(f"command 0x{cmd:02X} has bit 7 clear and takes no payload")
        return bytes((SYNC_BYTE, cmd))
    if len(payload) > 0xFF:
        raise ValueError(f"payload too long ({len(payload)} bytes, at most 255)")
    body = bytes((SYNC_BYTE, cmd, len(payload))) + bytes(payload)
    checksum = 0
    for b in body:
        checksum ^= b
    return body + bytes((checksum,))


@dataclass(frozen=True)
class Descriptor:
    """A response descriptor: packet length, send mode (0 single, 1 multiple), data type."""

    length: int
    mode: int
    data_type: int


SCAN_DESCRIPTOR = Descriptor(5, 1, 0x81)
INFO_DESCRIPTOR = Descriptor(20, 0, 0x04)
HEALTH_DESCRIPTOR = Descriptor(3, 0, 0x06)
SAMPLERATE_DESCRIPTOR = Descriptor(4, 0, 0x15)


def encode_descriptor(descriptor: Descriptor) -> bytes:
    """The 7 bytes ``A5 5A <u32 LE: length | mode << 30> <type>``."""
    if not 0 <= descriptor.length < 1 << 30 or not 0 <= descriptor.mode <= 3:
        raise ValueError(f"descriptor fields out of range: {descriptor}")
    word = descriptor.length | (descriptor.mode << 30)
    return bytes((SYNC_BYTE, SYNC_BYTE2)) + word.to_bytes(4, "little") + bytes(
        (descriptor.data_type,)
    )


def parse_descriptor(data: bytes) -> Descriptor:
    """Decode a 7-byte response descriptor; raises LidarProtocolError if not one.

    >>> parse_descriptor(bytes.fromhex("a55a0500004081"))
    Descriptor(length=5, mode=1, data_type=129)
    """
    if len(data) != 7:
        raise LidarProtocolError(f"a descriptor is 7 bytes, got {len(data)}: {data.hex(' ')}")
    if data[0] != SYNC_BYTE or data[1] != SYNC_BYTE2:
        raise LidarProtocolError(f"descriptor does not start with A5 5A: {data.hex(' ')}")
    word = int.from_bytes(data[2:6], "little")
    return Descriptor(length=word & 0x3FFFFFFF, mode=word >> 30, data_type=data[6])


def encode_sample(
    start: bool, quality: int, angle_q6: int, distance_q2: int, *, check_bit: bool = True
) -> bytes:
    """The 5 bytes of one scan sample (``check_bit=False`` makes a malformed one)."""
    if not 0 <= quality <= 63:
        raise ValueError(f"quality must be in 0..63, got {quality}")
    if not 0 <= angle_q6 <= 0x7FFF:
        raise ValueError(f"angle_q6 must be in 0..32767, got {angle_q6}")
    if not 0 <= distance_q2 <= 0xFFFF:
        raise ValueError(f"distance_q2 must be in 0..65535, got {distance_q2}")
    b0 = (quality << 2) | (0b01 if start else 0b10)
    b1 = ((angle_q6 & 0x7F) << 1) | (1 if check_bit else 0)
    b2 = angle_q6 >> 7
    return bytes((b0, b1, b2)) + distance_q2.to_bytes(2, "little")


def _well_formed(b0: int, b1: int) -> bool:
    return ((b0 ^ (b0 >> 1)) & 1) == 1 and (b1 & 1) == 1


def decode_sample(data: bytes) -> tuple[bool, int, float, float]:
    """Decode one 5-byte sample into (start_flag, quality, angle_deg, distance_mm).

    The angle is clockwise from the sensor's front; distance 0 means no return.
    Raises LidarSampleError when S == not-S or the check bit is 0.
    """
    if len(data) != SAMPLE_SIZE:
        raise ValueError(f"a scan sample is 5 bytes, got {len(data)}")
    b0, b1, b2, b3, b4 = data
    s, not_s = b0 & 1, (b0 >> 1) & 1
    if s == not_s:
        raise LidarSampleError(
            f"bad start flags S={s} not-S={not_s} in sample {bytes(data).hex(' ')}"
        )
    if not b1 & 1:
        raise LidarSampleError(f"check bit C=0 in sample {bytes(data).hex(' ')}")
    angle_q6 = (b1 >> 1) | (b2 << 7)
    distance_q2 = b3 | (b4 << 8)
    return bool(s), b0 >> 2, angle_q6 / 64.0, distance_q2 / 4.0


@dataclass(frozen=True)
class DeviceInfo:
    """GET_INFO reply: model, firmware version, hardware revision, 16-byte serial."""

    model: int
    firmware_minor: int
    firmware_major: int
    hardware: int
    serial_number: bytes

    @property
    def firmware(self) -> str:
        """Firmware version as ``major.minor`` (minor zero-padded, like SLAMTEC's tools)."""
        return f"{self.firmware_major}.{self.firmware_minor:02d}"

    @property
    def serial_hex(self) -> str:
        """The serial number as 32 upper-case hex digits."""
        return self.serial_number.hex().upper()


def encode_info(info: DeviceInfo) -> bytes:
    """The 20 payload bytes of a GET_INFO reply."""
    if len(info.serial_number) != 16:
        raise ValueError("the serial number is 16 bytes")
    return (
        bytes((info.model, info.firmware_minor, info.firmware_major, info.hardware))
        + info.serial_number
    )


def decode_info(data: bytes) -> DeviceInfo:
    """Decode the 20 payload bytes of a GET_INFO reply."""
    if len(data) != 20:
        raise LidarProtocolError(f"GET_INFO payload is 20 bytes, got {len(data)}")
    return DeviceInfo(data[0], data[1], data[2], data[3], bytes(data[4:20]))


_HEALTH_NAMES = {0: "good", 1: "warning", 2: "error"}


@dataclass(frozen=True)
class HealthStatus:
    """GET_HEALTH reply: status (0 good, 1 warning, 2 error) and a device error code."""

    status: int
    error_code: int

    @property
    def name(self) -> str:
        """``good``, ``warning``, ``error`` or ``unknown``."""
        return _HEALTH_NAMES.get(self.status, "unknown")


def encode_health(health: HealthStatus) -> bytes:
    """The 3 payload bytes of a GET_HEALTH reply (error code u16 little-endian)."""
    return bytes((health.status,)) + health.error_code.to_bytes(2, "little")


def decode_health(data: bytes) -> HealthStatus:
    """Decode the 3 payload bytes of GET_HEALTH; the error code is u16 little-endian.

    >>> decode_health(bytes([2, 0x34, 0x12]))
    HealthStatus(status=2, error_code=4660)
    """
    if len(data) != 3:
        raise LidarProtocolError(f"GET_HEALTH payload is 3 bytes, got {len(data)}")
    return HealthStatus(data[0], data[1] | (data[2] << 8))


def polar_to_robot(angle_deg: np.ndarray, distance_mm: np.ndarray) -> np.ndarray:
    """N×2 robot-frame points (x forward, y left, metres) from the A1's polar samples.

    The A1 measures angles clockwise seen from above, so y = -r·sin(angle).
    """
    a = np.radians(np.asarray(angle_deg, dtype=float))
    r = np.asarray(distance_mm, dtype=float) / 1000.0
    return np.column_stack((r * np.cos(a), -r * np.sin(a)))


# --------------------------------------------------------------------- stream decoder


@dataclass(frozen=True)
class Revolution:
    """The samples of one 360° revolution, in the order received."""

    angle_deg: np.ndarray
    distance_mm: np.ndarray
    quality: np.ndarray

    def __len__(self) -> int:
        return len(self.angle_deg)

    def _kept(self, max_range: float | None) -> np.ndarray:
        keep = self.distance_mm > 0
        if max_range is not None:
            keep &= self.distance_mm <= max_range * 1000.0
        return keep

    def to_points(self, max_range: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(points N×2 in metres, quality N) without zero distances, cropped to max_range."""
        keep = self._kept(max_range)
        points = polar_to_robot(self.angle_deg[keep], self.distance_mm[keep])
        return points, self.quality[keep]

    def point_times(self, period: float, max_range: float | None = None) -> np.ndarray:
        """When each point of :meth:`to_points` was measured (s, <= 0), relative to the
        revolution's end, for a sweep of ``period`` s: the A1 turns at a steady rate and
        the revolution ends where the next begins, at 360°, so a sample at angle a was
        measured (360 - a) / 360 of a period before that.

        >>> rev = Revolution(np.array([0.0, 90.0, 270.0]), np.array([500.0, 0.0, 800.0]), np.array([15, 0, 15]))
        >>> rev.point_times(0.2).tolist()
        [-0.2, -0.05]
        """
        a = np.clip(self.angle_deg[self._kept(max_range)], 0.0, 360.0)
        out: np.ndarray = (a / 360.0 - 1.0) * period
        return out


class ScanDecoder:
    """Incremental decoder of the SCAN sample stream: bytes in, full revolutions out.

    **Samples.** A sample is accepted when it is well-formed (S ≠ not-S, C = 1, angle <
    360°) and its angle is a plausible step (-2°..+10° per sample; consecutive A1
    samples are 0.2-2° apart) from the sample accepted just before it. After skipped
    bytes it must in addition be confirmed by the well-formed sample right after it,
    a step forward of less than 10° (misaligned bytes of samples with equal fields
    read as a steady run at one angle, which such a check refuses);
    the check against the last accepted sample is dropped once more than 3 samples'
    worth of bytes were skipped. Otherwise one byte is skipped (``dropped_bytes``).
    Checking single samples is not enough: one byte off, C = 1 reads as S = 1, so a
    decoder would lock onto misaligned data and split revolutions.

    **Revolutions.** A revolution is one sweep of rising angles. It ends at the first
    accepted sample more than 2° below the furthest angle of the sweep so far, with or
    without its start flag: normally the wrap past 0° (the flagged sample may be lost
    in garbage), otherwise a sweep broken off by garbage. Comparing with the furthest
    angle rather than the last sample means one stray sample between two revolutions
    cannot hide the wrap and merge them. When the new sample is not flagged and at most
    8 samples at the end of the sweep lie above it, those are strays taken from garbage
    (misaligned bytes can pass as a short run of samples): they are dropped and the
    sweep goes on. A start flag within the first few degrees of a sweep restarts it
    there (the samples before it were strays); other start flags are counted in
    ``ignored_start_flags``. Samples before the first start flag are discarded
    (``discarded_samples``). A sweep that stops turning (6 samples in a row without a
    new furthest angle) is a misaligned lock: those samples are dropped and the
    decoder resynchronises.

    **Only revolutions that look like one are handed on**: at least ``min_samples``
    samples covering at least ``min_coverage_deg`` degrees (counted in 10° sectors).
    Others are dropped and counted in ``rejected_revolutions``, so pure noise yields
    none. A revolution growing beyond ``max_samples`` without wrapping (a stream stuck
    at one angle) is dropped as it grows, so pending samples stay bounded.

    >>> rev = [encode_sample(k == 0, 10, k * 9 * 64, 400) for k in range(40)]  # 9° apart
    >>> d = ScanDecoder(min_samples=40)
    >>> [len(r) for r in d.feed(b"".join(rev * 3) + rev[0])]
    [40, 40, 40]
    >>> [len(r) for r in d.feed(b"".join(rev[:20]) + b"".join(rev))], d.rejected_revolutions
    ([], 1)
    """

    def __init__(
        self,
        *,
        min_samples: int = 50,
        min_coverage_deg: float = 320.0,
        max_samples: int = 2000,
    ) -> None:
        if not 1 <= min_samples <= max_samples:
            raise ValueError(f"need 1 <= min_samples <= max_samples, got {min_samples}, {max_samples}")
        self.min_samples = min_samples
        self.min_coverage_deg = float(min_coverage_deg)
        self.max_samples = max_samples
        self._buf = bytearray()
        self._started = False
        self._since_accept = _RECENT_BYTES  # bytes skipped since the last accepted sample
        self._last_q6 = 0
        self._first_q6 = 0  # first and furthest angle of the current revolution
        self._max_q6 = 0
        self._stall = 0  # consecutive samples that did not turn the sweep further
        self._angle: list[int] = []  # angle_q6 of each sample of the revolution
        self._dist: list[float] = []
        self._qual: list[int] = []
        self.dropped_bytes = 0
        self.samples = 0
        self.discarded_samples = 0
        self.ignored_start_flags = 0
        self.revolutions = 0
        self.rejected_revolutions = 0

    @property
    def pending_samples(self) -> int:
        """Samples of the revolution in progress (never more than ``max_samples``)."""
        return len(self._angle)

    @staticmethod
    def _angle_at(buf: bytearray, i: int) -> int:
        """angle_q6 of a well-formed sample at i, or -1 if it is malformed."""
        b0, b1 = buf[i], buf[i + 1]
        if not _well_formed(b0, b1):
            return -1
        a = (b1 >> 1) | (buf[i + 2] << 7)
        return a if a < FULL_CIRCLE_Q6 else -1

    @staticmethod
    def _plausible_step(a: int, b: int, skipped: int = 0) -> bool:
        # after skipping bytes, samples may have been lost: allow a larger forward step
        forward = _MAX_STEP_Q6 * (1 + (skipped + SAMPLE_SIZE - 1) // SAMPLE_SIZE)
        return (b - a + _BACK_STEP_Q6) % FULL_CIRCLE_Q6 < _BACK_STEP_Q6 + forward

    def feed(self, data: bytes) -> list[Revolution]:
        """Add a chunk of bytes; return the revolutions it completed (oldest first)."""
        buf = self._buf
        buf += data
        done: list[Revolution] = []
        i, n = 0, len(buf)
        while n - i >= SAMPLE_SIZE:
            a = self._accepted_angle(buf, i, n)
            if a is None:
                break  # wait for the next sample to confirm this one
            if a < 0:
                i += 1
                self.dropped_bytes += 1
                self._since_accept += 1
                continue
            b0, b3, b4 = buf[i], buf[i + 3], buf[i + 4]
            i += SAMPLE_SIZE
            self._last_q6 = a
            self._since_accept = 0
            self.samples += 1
            if not self._place(a, bool(b0 & 1), done):
                continue
            self._add(a, (b3 | (b4 << 8)) / 4.0, b0 >> 2)
            if self._stall >= _MAX_STALL:
                self._drop_stall(a)
                i -= SAMPLE_SIZE - 1  # look for the true alignment from the byte after its last start
            elif len(self._angle) > self.max_samples:
                self._drop_overgrown(a)
        del buf[:i]
        return done

    def _accepted_angle(self, buf: bytearray, i: int, n: int) -> int | None:
        """angle_q6 of the sample at ``i`` when it is accepted (see the class docstring),
        -1 when it is not, None when the sample that must confirm it has not come yet."""
        a = self._angle_at(buf, i)
        since = self._since_accept
        if a >= 0 and since < _RECENT_BYTES and not self._plausible_step(self._last_q6, a, since):
            a = -1
        if a >= 0 and since > 0:
            if n - i < 2 * SAMPLE_SIZE:
                return None
            b = self._angle_at(buf, i + SAMPLE_SIZE)
            if b < 0 or not 0 < (b - a) % FULL_CIRCLE_Q6 < _MAX_STEP_Q6:
                # a confirming sample must move on: bytes one off a run of samples
                # with equal fields read as samples of one constant angle
                a = -1
        return a

    def _place(self, a: int, flagged: bool, done: list[Revolution]) -> bool:
        """Where an accepted sample at ``a`` falls: before the first start flag (discarded:
        False), past the wrap (the revolution closes onto ``done``, a new one begins), or
        on a start flag that restarts or does not restart the sweep. True: add it."""
        if not self._started:
            if not flagged:
                self.discarded_samples += 1
                return False
            self._started = True
            self._begin(a)
        elif a < self._max_q6 - _BACK_STEP_Q6 and (flagged or not self._drop_strays_above(a)):
            # the sweep wrapped past 0° (or broke off): a new revolution
            rev = self._close_revolution()
            if rev is not None:
                done.append(rev)
            self._begin(a)
        elif flagged:
            if self._max_q6 - self._first_q6 <= _MAX_STEP_Q6 and a < self._max_q6:
                # a revolution begins with its flagged sample: what came before were strays
                self.discarded_samples += len(self._angle)
                stall = self._stall
                self._begin(a)
                self._stall = stall + 1  # a flagged run at one angle is still a stall
            else:
                self.ignored_start_flags += 1
        return True

    def _add(self, a: int, distance_mm: float, quality: int) -> None:
        """Append a sample to the revolution, counting it towards a stall unless it turns the sweep further."""
        if self._angle:
            self._stall = self._stall + 1 if a <= self._max_q6 else 0
        self._max_q6 = max(self._max_q6, a)
        self._angle.append(a)
        self._dist.append(distance_mm)
        self._qual.append(quality)

    def _drop_stall(self, a: int) -> None:
        """A sweep that stopped turning is misaligned bytes read as samples: drop the run."""
        keep = len(self._angle) - self._stall
        self.discarded_samples += self._stall
        del self._angle[keep:], self._dist[keep:], self._qual[keep:]
        self._max_q6 = max(self._angle, default=a)
        self._stall = 0
        self._since_accept = _RECENT_BYTES

    def _drop_overgrown(self, a: int) -> None:
        """No wrap in far more samples than a revolution has: not a revolution."""
        self.rejected_revolutions += 1
        self.discarded_samples += len(self._angle)
        self._started = False
        self._begin(a)

    def _begin(self, a: int) -> None:
        self._angle, self._dist, self._qual = [], [], []
        self._stall = 0
        self._first_q6 = self._max_q6 = a

    def _drop_strays_above(self, a: int) -> bool:
        """Drop the last few samples when they alone lie above ``a`` (strays from garbage
        that a real sample has just contradicted); False when more would have to go."""
        k = len(self._angle)
        while k and self._angle[k - 1] > a and len(self._angle) - k < _MAX_STRAYS:
            k -= 1
        if k == 0 or max(self._angle[:k]) > a + _BACK_STEP_Q6:
            return False
        self.discarded_samples += len(self._angle) - k
        del self._angle[k:], self._dist[k:], self._qual[k:]
        self._max_q6 = max(self._angle)
        return True

    def _looks_like_a_revolution(self) -> bool:
        if len(self._angle) < self.min_samples:
            return False
        sectors = np.unique(np.asarray(self._angle) // (10 * 64))
        return 10.0 * len(sectors) >= self.min_coverage_deg

    def _close_revolution(self) -> Revolution | None:
        if not self._looks_like_a_revolution():
            self.rejected_revolutions += 1
            self.discarded_samples += len(self._angle)
            return None
        rev = Revolution(
            np.array(self._angle, dtype=float) / 64.0,
            np.array(self._dist, dtype=float),
            np.array(self._qual, dtype=np.uint8),
        )
        self.revolutions += 1
        return rev

