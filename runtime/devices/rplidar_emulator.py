"""An emulated RPLIDAR A1 on a pseudo-terminal, and the scan sources that feed it.

It speaks the protocol of :mod:`clomp.runtime.devices.rplidar_codec` byte for byte, paces
output like the hardware, and injects faults (garbage, bad check bits, silence, the
device vanishing) so the driver can be tested without hardware.

>>> import numpy as np
>>> with LidarEmulator(lambda: np.array([[0.5, 0.0]]), speed=4.0) as lidar:
...     lidar.port.startswith("/dev/")
True
"""

from __future__ import annotations

import os
import random
import re
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

from clomp.runtime.devices import rplidar_codec as _r
from clomp.runtime.devices._pty import PtyEmulator

__all__ = [
    "SampleStream",
    "ScanSource",
    "LidarEmulator",
    "load_scan_file",
    "recorded_scan_source",
    "scan_to_samples",
]

#: what the emulated LiDAR scans: a callable returning the current scan (N×2, metres, robot frame)
ScanSource = Callable[[], np.ndarray]
SampleStream = Callable[[], "list[tuple[float, float, bool]]"]
"""Samples measured since the last call, in order: (angle_deg clockwise, distance_mm, 0: no
return; whether it begins a revolution)."""

_MAP_FILE = re.compile(r"^map\d+\.dat$")


def load_scan_file(path: str | os.PathLike[str]) -> np.ndarray:
    """Read one recorded scan (``x<TAB>y`` per line, metres) as N×2; empty file → 0×2."""
    rows: list[tuple[float, float]] = []
    with open(path, encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, 1):
            fields = line.split()
            if not fields:
                continue
            try:
                if len(fields) != 2:
                    raise ValueError(f"expected 2 columns, got {len(fields)}")
                rows.append((float(fields[0]), float(fields[1])))
            except ValueError as exc:
                raise ValueError(f"{path}:{lineno}: not an 'x<TAB>y' line ({exc}): {line.rstrip()!r}") from None
    return np.array(rows, dtype=float).reshape(-1, 2)


def recorded_scan_source(folder: str | os.PathLike[str]) -> ScanSource:
    """A scan source cycling over the ``mapNNNN.dat`` files of ``folder`` in order.

    All files are read up front so a malformed file fails here, not mid-stream.
    An empty file is an empty scan (free space).
    """
    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(f"scan folder not found: {root}")
    files = sorted(p for p in root.iterdir() if _MAP_FILE.match(p.name))
    if not files:
        subdirs = sorted(p.name for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
        hint = f" (it has subfolders: {', '.join(subdirs)})" if subdirs else ""
        raise FileNotFoundError(f"no mapNNNN.dat files in {root}{hint}")
    scans = [load_scan_file(p) for p in files]
    state = {"i": 0}
    lock = threading.Lock()

    def source() -> np.ndarray:
        with lock:
            scan = scans[state["i"]]
            state["i"] = (state["i"] + 1) % len(scans)
        return scan.copy()

    return source


def scan_to_samples(points: np.ndarray, bins: int = 360) -> tuple[np.ndarray, np.ndarray]:
    """What an A1 would measure of a robot-frame scan: (angle_deg, distance_mm) per bin.

    Angles are clockwise from the front; bin k covers [k, k+1) × 360/bins degrees and
    keeps its nearest return (at that point's exact angle), so angles rise through a
    revolution as on the device; a bin without a return has distance 0 at its start.
    """
    step = 360.0 / bins
    angle = np.arange(bins) * step
    dist = np.zeros(bins)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts):
        r = np.hypot(pts[:, 0], pts[:, 1]) * 1000.0
        cw = np.degrees(-np.arctan2(pts[:, 1], pts[:, 0])) % 360.0
        idx = np.floor(cw / step).astype(int) % bins
        order = np.argsort(-r, kind="stable")  # farthest first: the nearest is written last
        order = order[r[order] > 0]
        dist[idx[order]] = r[order]
        angle[idx[order]] = cw[order]
    return angle, dist



class LidarEmulator(PtyEmulator):
    """An RPLIDAR A1: answers GET_INFO, GET_HEALTH, GET_SAMPLERATE, SCAN/FORCE_SCAN,
    STOP and RESET; streams ``samples_per_rev`` samples per revolution at
    ``sample_rate × speed`` samples/s, each revolution made from one ``scan_source()``.

    Faults: ``garbage_rate`` (probability per sample of 1–8 random bytes before it),
    ``bad_check_rate`` (probability per sample of C = 0), ``silent_after`` (revolutions,
    then no output and no answers), ``vanish_after`` (revolutions, fractional for
    mid-scan; then the pty is closed). ``seed`` makes the faults reproducible.

    ``sample_stream`` (instead of ``scan_source``): a world that measures each sample at
    its own time (:meth:`clomp.runtime.backends.world.WorldRobot.stream`); each tick sends what it
    measured since the last, so a sample is on the wire when it is measured, as on the
    device, and the world sets the pace (``sample_rate`` and ``speed`` then only answer
    GET_SAMPLERATE).
    """

    _name = "lidar-emulator"
    BANNER = b"RP LIDAR System.\r\nFirmware Ver 1.29 - rtm, HW Ver 7\r\nModel: 18\r\n"

    def __init__(
        self,
        scan_source: ScanSource | None = None,
        *,
        speed: float = 1.0,
        sample_rate: float = 2000.0,
        samples_per_rev: int = 360,
        quality: int = 15,
        health_status: int = 0,
        health_error_code: int = 0,
        info: _r.DeviceInfo | None = None,
        garbage_rate: float = 0.0,
        bad_check_rate: float = 0.0,
        silent_after: int | None = None,
        vanish_after: float | None = None,
        reset_time: float = 0.05,
        max_backlog: int = 65536,
        seed: int | None = None,
        clock: Callable[[], float] | None = None,
        sample_stream: SampleStream | None = None,
    ) -> None:
        super().__init__(clock)
        if speed <= 0 or sample_rate <= 0:
            raise ValueError("speed and sample_rate must be positive")
        if samples_per_rev < 72:
            raise ValueError("samples_per_rev must be at least 72: an A1 sends samples a few degrees apart at most")
        if not (0 <= garbage_rate <= 1 and 0 <= bad_check_rate <= 1):
            raise ValueError("garbage_rate and bad_check_rate are probabilities in [0, 1]")
        self.scan_source: ScanSource = scan_source or (lambda: np.empty((0, 2)))
        self.sample_stream = sample_stream
        self.speed = speed
        self.sample_rate = sample_rate
        self.samples_per_rev = samples_per_rev
        self.quality = quality
        self.health = _r.HealthStatus(health_status, health_error_code)
        self.info = info or _r.DeviceInfo(0x18, 29, 1, 7, bytes(range(16)))
        self.garbage_rate = garbage_rate
        self.bad_check_rate = bad_check_rate
        self.silent_after = silent_after
        self.vanish_after = vanish_after
        self.reset_time = reset_time
        self.max_backlog = max_backlog
        self._rng = random.Random(seed)
        self._in = bytearray()
        self.requests: list[int] = []  # command bytes received, in order
        self.source_errors: list[BaseException] = []
        self.scanning = False
        self.silent = False
        self.revolutions_sent = 0
        self.samples_sent = 0
        self.garbage_bytes_sent = 0
        self.backlog_dropped = 0
        self._scan_t0 = 0.0
        self._scan_due_base = 0
        self._rev: list[tuple[int, int, int]] = []
        self._rev_index = 0
        self._synced = False
        self._busy_until: float | None = None

    # -- faults

    _FAULTS = ("silent", "garbage_rate", "bad_check_rate")

    def inject(self, **faults: float | bool) -> float:
        """Switch faults on or off now (``silent``, ``garbage_rate``, ``bad_check_rate``) and
        return the device's time of it: what a fault's consequences are timed from.

        >>> with LidarEmulator() as lidar:
        ...     lidar.inject(silent=True) <= lidar.clock() and lidar.silent
        True
        """
        return self._set_faults(faults, self._FAULTS, ("garbage_rate", "bad_check_rate"))

    # -- requests

    def _on_bytes(self, data: bytes, now: float) -> None:
        if self.silent or (self._busy_until is not None and now < self._busy_until):
            return  # silent, or rebooting after RESET: input is lost
        buf = self._in
        buf += data
        while True:
            start = buf.find(_r.SYNC_BYTE)
            if start < 0:
                buf.clear()
                return
            del buf[:start]
            if len(buf) < 2:
                return
            cmd = buf[1]
            if cmd & 0x80:
                if len(buf) < 3 or len(buf) < 4 + buf[2]:
                    return
                size = 4 + buf[2]
                checksum = 0
                for b in buf[: size - 1]:
                    checksum ^= b
                if checksum != buf[size - 1]:
                    del buf[:1]  # not a valid request: look for the next A5
                    continue
                del buf[:size]
            else:
                del buf[:2]
            self.requests.append(cmd)
            self._handle(cmd, now)

    def _handle(self, cmd: int, now: float) -> None:
        C = _r.Command
        if cmd in (C.STOP, C.RESET, C.SCAN, C.FORCE_SCAN, C.GET_INFO, C.GET_HEALTH, C.GET_SAMPLERATE):
            self.scanning = False  # a new request ends the running scan
            self._out.clear()  # what was not on the wire yet is never sent
        if cmd == C.RESET:
            self._busy_until = now + self.reset_time
        elif cmd in (C.SCAN, C.FORCE_SCAN):
            self._send(_r.encode_descriptor(_r.SCAN_DESCRIPTOR))
            self.scanning = True
            self._scan_t0 = now
            self._scan_due_base = 0
            self._rev_index = 0
            self._synced = False  # a streamed scan starts at the next revolution's first sample
        elif cmd == C.GET_INFO:
            self._send(_r.encode_descriptor(_r.INFO_DESCRIPTOR) + _r.encode_info(self.info))
        elif cmd == C.GET_HEALTH:
            self._send(_r.encode_descriptor(_r.HEALTH_DESCRIPTOR) + _r.encode_health(self.health))
        elif cmd == C.GET_SAMPLERATE:
            t_us = round(1e6 / self.sample_rate)
            payload = t_us.to_bytes(2, "little") + (t_us // 2).to_bytes(2, "little")
            self._send(_r.encode_descriptor(_r.SAMPLERATE_DESCRIPTOR) + payload)
        # SET_MOTOR_PWM and unknown commands: an A1 ignores them

    # -- streaming

    def _next_wakeup(self, now: float) -> float:
        if self._busy_until is not None:
            return min(self._busy_until, now + 0.05)
        if self.scanning and not self.silent:
            return now + 0.005
        return now + 0.05

    def _new_revolution(self) -> None:
        try:
            points = np.asarray(self.scan_source(), dtype=float).reshape(-1, 2)
        except Exception as exc:  # a broken source must not kill the device: empty scan
            self.source_errors.append(exc)
            points = np.empty((0, 2))
        angle, dist = scan_to_samples(points, self.samples_per_rev)
        full = _r.FULL_CIRCLE_Q6
        self._rev = [
            (
                int(round(a * 64)) % full,
                min(0xFFFF, int(round(d * 4))),
                self.quality if d > 0 else 0,
            )
            for a, d in zip(angle, dist)
        ]
        self._rev_index = 0

    def _tick(self, now: float) -> None:
        if self._busy_until is not None and now >= self._busy_until:
            self._busy_until = None
            self._in.clear()
            self._send(self.BANNER)
        if self.sample_stream is not None:
            self._stream(send=self.scanning and not self.silent)
            return
        if not self.scanning or self.silent:
            return
        due = int((now - self._scan_t0) * self.sample_rate * self.speed) - self._scan_due_base
        if due <= 0:
            return
        self._scan_due_base += due
        for _ in range(min(due, 4 * self.samples_per_rev)):
            if self._rev_index == 0:
                self._new_revolution()
            angle_q6, dist_q2, quality = self._rev[self._rev_index]
            first = self._rev_index == 0
            self._rev_index += 1
            if self._rev_index >= len(self._rev):
                self._rev_index = 0
            if not self._emit(first, quality, angle_q6, dist_q2, self._rev_index == 0):
                return

    def _stream(self, send: bool) -> None:
        """Send the samples the world measured since the last tick, as it measured them (the
        world keeps the time); not scanning or silent, they are taken and lost, as the
        device's are."""
        try:
            samples = self.sample_stream() if self.sample_stream is not None else []
        except Exception as exc:  # a broken source must not kill the device: nothing sent
            self.source_errors.append(exc)
            return
        if not send:
            return
        full = _r.FULL_CIRCLE_Q6
        for angle, dist, first in samples:
            if not self._synced:
                if not first:
                    continue  # measured before the scan began, or the rest of that revolution
                self._synced = True
            d = min(0xFFFF, int(round(dist * 4))) if dist > 0 else 0
            if not self._emit(bool(first), self.quality if d else 0, int(round(angle * 64)) % full, d, False):
                return

    def _emit(self, first: bool, quality: int, angle_q6: int, dist_q2: int, ends: bool) -> bool:
        """Send one sample (with the faults in force); ``ends``: it closes a paced
        revolution (a streamed one is counted when the next begins). False when the device
        has gone silent or vanished and nothing more may be sent."""
        rng = self._rng
        if first and self.sample_stream is not None and self.samples_sent:
            self.revolutions_sent += 1  # streamed: the previous revolution is complete as the next begins
            if self.silent_after is not None and self.revolutions_sent >= self.silent_after:
                self.silent = True
                return False
        sample = _r.encode_sample(
            first,
            quality,
            angle_q6,
            dist_q2,
            check_bit=not (self.bad_check_rate and rng.random() < self.bad_check_rate),
        )
        if self.garbage_rate and rng.random() < self.garbage_rate:
            junk = bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
            self.garbage_bytes_sent += len(junk)
            sample = junk + sample
        if len(self._out) + len(sample) <= self.max_backlog:
            self._send(sample)
        else:
            self.backlog_dropped += len(sample)  # the host is not reading: bytes lost
        self.samples_sent += 1
        if ends and self.sample_stream is None:
            self.revolutions_sent += 1
            if self.silent_after is not None and self.revolutions_sent >= self.silent_after:
                self.silent = True
                return False
        if self.vanish_after is not None and self.samples_sent >= self.vanish_after * self.samples_per_rev:
            self._flush()
            self._vanish.set()
            return False
        return True
