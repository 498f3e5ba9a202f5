"""The BNO08x IMU's UART-RVC report as pure functions: bytes in, headings out.

In RVC mode (P0 strapped at power-up) a BNO080/085/086 needs no commands: it streams one
19-byte report every 10 ms at 115200 baud 8N1 — ``AA AA``, an index (+1 per report, wraps
at 256), yaw, pitch, roll (int16 LE, 0.01°; yaw ±180° since reset, counter-clockwise seen
from above), x, y, z acceleration (int16 LE, mg), three bytes (motion intent, motion
request, reserved; 0 on the BNO080) and a checksum, the sum of the 16 bytes from the index
to the last of those three, mod 256. :class:`RvcDecoder` turns any byte stream into
reports. No port, no clock: the driver (:mod:`clomp.runtime.devices.bno08x`) and the
emulator (:mod:`clomp.runtime.devices.bno08x_emulator`) are both built on it.

>>> frame = bytes.fromhex("AA AA DE 01 00 92 FF 25 08 8D FE EC FF D1 03 00 00 00 E7")
>>> [r] = RvcDecoder().feed(frame)  # the datasheet's worked example
>>> r.index, r.yaw_deg, r.pitch_deg, r.roll_deg, r.accel_mg
(222, 0.01, -1.1, 20.85, (-371, -20, 977))
>>> encode_report(r) == frame
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "HEADER",
    "REPORT_SIZE",
    "REPORT_RATE",
    "DEFAULT_BAUDRATE",
    "STANDARD_GRAVITY",
    "RvcReport",
    "RvcDecoder",
    "ImuError",
    "ImuPortError",
    "ImuProtocolError",
    "ImuTimeout",
    "encode_report",
    "checksum",
    "unwrap",
]

HEADER = b"\xaa\xaa"
_H = 0xAA
REPORT_SIZE = 19
#: reports per second in RVC mode
REPORT_RATE = 100.0
DEFAULT_BAUDRATE = 115200
#: m/s² per g (the report's accelerations are in mg)
STANDARD_GRAVITY = 9.80665
_ANGLE_LIMIT = 18000  # |angle| in 0.01°: anything beyond is not an angle the device reports
_INT16 = (-32768, 32767)


# ---------------------------------------------------------------------------- errors


class ImuError(Exception):
    """Base class of every error raised by the IMU layer (as ``LidarError`` is the
    LiDAR's: a backend turns either into its robot fault)."""


class ImuPortError(ImuError):
    """The serial port cannot be opened, or it failed (device unplugged, pty closed)."""


class ImuProtocolError(ImuError):
    """Bytes arrive but no valid report among them (wrong baud rate, not in RVC mode, noise)."""


class ImuTimeout(ImuError):
    """No byte at all within the deadline: the device is silent (unpowered, disconnected)."""


# ----------------------------------------------------------------------------- codec


def checksum(body: bytes) -> int:
    """The RVC checksum of a report's 16 bytes from the index to the reserved byte.

    >>> checksum(bytes.fromhex("DE 01 00 92 FF 25 08 8D FE EC FF D1 03 00 00 00"))
    231
    """
    return sum(body) & 0xFF


def unwrap(previous: float, angle: float) -> float:
    """The angle equal to ``angle`` modulo 2π that is nearest to ``previous`` (radians).

    Follows a heading through the device's ±180° wrap: successive reports are 10 ms apart,
    far less than half a turn for a ground robot.

    >>> round(unwrap(math.radians(179.0), math.radians(-179.0)), 6) == round(math.radians(181.0), 6)
    True
    """
    return previous + math.remainder(angle - previous, math.tau)


@dataclass(frozen=True)
class RvcReport:
    """One RVC report as sent: angles in 0.01° and accelerations in mg, as integers.

    The properties give the SI values: :attr:`yaw`, :attr:`pitch`, :attr:`roll` in radians
    (yaw counter-clockwise seen from above, within ±π), :attr:`yaw_deg` etc. in degrees,
    :attr:`accel` in m/s². Build one from SI values with :meth:`of`.

    >>> r = RvcReport.of(7, yaw=math.pi / 2, accel=(0.0, 0.0, STANDARD_GRAVITY))
    >>> r.yaw_cdeg, r.accel_mg, round(r.yaw, 4)
    (9000, (0, 0, 1000), 1.5708)
    """

    index: int
    yaw_cdeg: int
    pitch_cdeg: int = 0
    roll_cdeg: int = 0
    accel_mg: tuple[int, int, int] = (0, 0, 1000)
    motion_intent: int = 0
    motion_request: int = 0
    reserved: int = 0

    @classmethod
    def of(
        cls,
        index: int,
        yaw: float,
        pitch: float = 0.0,
        roll: float = 0.0,
        accel: tuple[float, float, float] = (0.0, 0.0, STANDARD_GRAVITY),
    ) -> RvcReport:
        """A report from radians and m/s², rounded to the wire's units; angles wrapped to ±180°
        and accelerations clamped to int16 mg, as the device would send them."""

        def cdeg(a: float) -> int:
            return round(math.remainder(math.degrees(a), 360.0) * 100.0)

        def mg(v: float) -> int:
            return min(max(round(v / STANDARD_GRAVITY * 1000.0), _INT16[0]), _INT16[1])

        ax, ay, az = accel
        return cls(index & 0xFF, cdeg(yaw), cdeg(pitch), cdeg(roll), (mg(ax), mg(ay), mg(az)))

    @property
    def yaw_deg(self) -> float:
        """Yaw in degrees (counter-clockwise seen from above, ±180)."""
        return self.yaw_cdeg / 100.0

    @property
    def pitch_deg(self) -> float:
        """Pitch in degrees."""
        return self.pitch_cdeg / 100.0

    @property
    def roll_deg(self) -> float:
        """Roll in degrees."""
        return self.roll_cdeg / 100.0

    @property
    def yaw(self) -> float:
        """Yaw in radians (counter-clockwise seen from above, within ±π)."""
        return math.radians(self.yaw_deg)

    @property
    def pitch(self) -> float:
        """Pitch in radians."""
        return math.radians(self.pitch_deg)

    @property
    def roll(self) -> float:
        """Roll in radians."""
        return math.radians(self.roll_deg)

    @property
    def accel(self) -> tuple[float, float, float]:
        """x, y, z acceleration in m/s² (gravity included: about +9.8 on z when level)."""
        x, y, z = (v * STANDARD_GRAVITY / 1000.0 for v in self.accel_mg)
        return x, y, z


def encode_report(report: RvcReport) -> bytes:
    """The 19 bytes of ``report`` on the wire; ValueError for a field out of its range."""
    angles = (report.yaw_cdeg, report.pitch_cdeg, report.roll_cdeg)
    if any(abs(a) > _ANGLE_LIMIT for a in angles):
        raise ValueError(f"angles are within ±18000 (0.01°), got {angles}")
    if not all(_INT16[0] <= a <= _INT16[1] for a in report.accel_mg):
        raise ValueError(f"accelerations are int16 mg, got {report.accel_mg}")
    tail = (report.index, report.motion_intent, report.motion_request, report.reserved)
    if not all(0 <= b <= 0xFF for b in tail):
        raise ValueError(f"index and the three last bytes are u8, got {tail}")
    body = bytes((report.index,)) + b"".join(
        v.to_bytes(2, "little", signed=True) for v in (*angles, *report.accel_mg)
    ) + bytes(tail[1:])
    return HEADER + body + bytes((checksum(body),))


def _decode(w: bytes | bytearray) -> RvcReport:
    def i16(k: int) -> int:
        return int.from_bytes(w[k:k + 2], "little", signed=True)

    return RvcReport(w[2], i16(3), i16(5), i16(7), (i16(9), i16(11), i16(13)), w[15], w[16], w[17])


def _valid(buf: bytearray, i: int) -> bool:
    """Whether the 19 bytes at ``i`` (present, starting ``AA AA``) pass the checksum and
    hold angles the device can report."""
    if sum(buf[i + 2:i + 18]) & 0xFF != buf[i + 18]:
        return False
    return all(abs(int.from_bytes(buf[k:k + 2], "little", signed=True)) <= _ANGLE_LIMIT for k in (i + 3, i + 5, i + 7))


class RvcDecoder:
    """Incremental decoder of the RVC stream: bytes in, reports out, never an exception.

    A report is a 19-byte window starting ``AA AA`` whose checksum matches and whose angles
    are within ±180°; bytes that begin no such window are skipped one at a time
    (``dropped_bytes``; a window with a header and a wrong checksum also counts in
    ``bad_checksums``), so the decoder resynchronises on the next ``AA AA`` whatever came
    before. ``lost_reports`` adds up the gaps in the index between reports handed on (the
    index wraps at 256, so more than 255 reports lost in a row are undercounted).

    **Never two reports in one.** An 8-bit checksum lets one window in 256 through by
    chance, so a window is not taken while a valid window begins inside it (at an ``AA AA``
    within it): that is either a truncated report (a byte lost on the line, or garbage
    ending in ``AA AA``) followed by a real one, or a real report whose data holds ``AA AA``.
    The two are told apart by what follows each window (a report is followed by the next
    report's ``AA AA``), else by the index (the one that follows the last report's), else a
    window right after the last report keeps its place and one after skipped bytes gives
    way to the later window. A report that could hold such a beginning (its checksum or index
    ``AA``, or ``AA AA`` among its data: about one report in 128) is therefore handed on
    only when the next report's first bytes arrive, 10 ms later; every decision waits for
    the bytes it needs, so any split of a stream into chunks gives the same reports.

    >>> frames = b"".join(encode_report(RvcReport(i, 100 * i)) for i in (0, 1, 3))
    >>> d = RvcDecoder()
    >>> [r.index for r in d.feed(b"\\x55" + frames[:30])], [r.index for r in d.feed(frames[30:])]
    ([0], [1, 3])
    >>> d.lost_reports, d.dropped_bytes, d.reports
    (1, 1, 3)
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self._skipped = 0  # bytes skipped since the last report handed on
        self._last_index: int | None = None
        self.reports = 0
        self.lost_reports = 0
        self.dropped_bytes = 0
        self.bad_checksums = 0

    @property
    def pending_bytes(self) -> int:
        """Bytes held for a decision (fewer than three reports' worth)."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[RvcReport]:
        """Add a chunk of bytes; return the reports it completed (oldest first)."""
        buf = self._buf
        buf += data
        out: list[RvcReport] = []
        i = 0
        while True:
            n = len(buf)
            if n - i < 2:
                break
            if buf[i] != _H or buf[i + 1] != _H:
                i = self._skip(i)
                continue
            if n - i < REPORT_SIZE:
                break
            if not _valid(buf, i):
                self.bad_checksums += sum(buf[i + 2:i + 18]) & 0xFF != buf[i + 18]
                i = self._skip(i)
                continue
            later = self._later_window(buf, i)
            if later is None:
                break  # the bytes that decide have not arrived yet
            if later > i:
                self.dropped_bytes += later - i
                self._skipped += later - i
                i = later
                continue
            out.append(self._accept(buf, i))
            i += REPORT_SIZE
        del buf[:i]
        return out

    def _skip(self, i: int) -> int:
        self.dropped_bytes += 1
        self._skipped += 1
        return i + 1

    def _accept(self, buf: bytearray, i: int) -> RvcReport:
        report = _decode(buf[i:i + REPORT_SIZE])
        if self._last_index is not None:
            self.lost_reports += (report.index - self._last_index - 1) % 256
        self._last_index = report.index
        self._skipped = 0
        self.reports += 1
        return report

    def _later_window(self, buf: bytearray, i: int) -> int | None:
        """``i`` if the valid window at ``i`` is to be taken, the start of a valid window
        inside it that wins over it, or None while the bytes that decide are missing."""
        n = len(buf)
        for j in range(i + 1, i + REPORT_SIZE):
            if buf[j] != _H:
                continue
            if j + 1 >= n:
                return None
            if buf[j + 1] != _H:
                continue
            if n - j < REPORT_SIZE:
                return None
            if not _valid(buf, j):
                continue
            if n < j + REPORT_SIZE + 2:
                return None
            if self._prefer_later(buf, i, j):
                return j
        return i

    def _prefer_later(self, buf: bytearray, i: int, j: int) -> bool:
        """Whether the valid window at ``j``, which begins inside the valid window at ``i``,
        is the report: the one followed by a header, else the one whose index follows the
        last report's, else ``i`` right after the last report and ``j`` after skipped bytes."""

        def followed(k: int) -> bool:
            return buf[k + REPORT_SIZE] == _H and buf[k + REPORT_SIZE + 1] == _H

        def continues(k: int) -> bool:
            return self._last_index is not None and buf[k + 2] == (self._last_index + 1) & 0xFF

        for evidence in (followed, continues):
            ei, ej = evidence(i), evidence(j)
            if ei != ej:
                return ej
        return self._skipped > 0
