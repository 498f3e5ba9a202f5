"""Perception: a LiDAR scan becomes obstacle disturbances.

A scan is an N×2 array of points (metres, robot frame: x forward, y left). It is
validated, cropped to the sensor range, de-duplicated and clustered (points closer than
``cluster_distance`` belong to one object). Each cluster is covered tightly by thin
oriented boxes: a cluster is split along its principal axis until every piece is thin,
so a slanted wall becomes a slanted slab and an L-shaped corner two slabs, never one fat
axis-aligned box that would close a corridor.
"""

from __future__ import annotations

import functools
import io
import math
import os
import stat
import tokenize
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.lib import format as npy_format

from formal.model import Disturbance, DisturbanceKind

__all__ = [
    "MAX_SCAN_BYTES",
    "MAX_SCAN_POINTS",
    "SCAN_SUFFIXES",
    "Obstacles",
    "ScanError",
    "ScanWarning",
    "load_scan",
    "perceive",
    "range_warning",
    "scan_files",
    "validate_scan",
]

#: the file name endings of scan files in a folder
SCAN_SUFFIXES: tuple[str, ...] = (".dat", ".txt", ".npy", ".xy")

# a piece is "thin" when its points spread at most this much across its axis
_THIN = 0.0075
# surfaces are first cut into pieces of this much path length, then thick pieces halved
_PIECE = 0.08
# how far a box stands off its outermost points: the allowance for sensor noise
_PAD = 0.002
# which extent (rows u0, u1, t0, t1) gives each corner's along / across offset, and the
# sign of each row's pad
_CORNER_U = np.array([0, 1, 1, 0])
_CORNER_T = np.array([2, 2, 3, 3])
_SIGNS = np.array([[-1.0], [1.0], [-1.0], [1.0]])
_SIGNS_PAD = _SIGNS * _PAD
_SIGNS_PAD.flags.writeable = False
# from how many points repeats are dropped before the sort (below it the test costs what it saves)
_DEDUPE_FROM = 512


class ScanError(ValueError):
    """A scan cannot be read or is not a valid N×2 array of finite coordinates.

    >>> try:
    ...     validate_scan(np.array([[np.nan, 0.0]]))
    ... except ScanError as exc:
    ...     print(exc)
    scan: point 0 is not finite (nan, 0.0)
    """


class ScanWarning(UserWarning):
    """A scan was read but something about it is suspicious (e.g. points beyond the sensor range).

    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = perceive(np.array([[5.0, 0.0], [5.0, 0.02]]))
    >>> any(issubclass(w.category, ScanWarning) for w in caught)
    True
    """


#: A scan holds at most this many points (an RPLIDAR A1 gives about 360 per revolution).
MAX_SCAN_POINTS = 50_000
#: A scan file is at most this many bytes (50,000 text lines of ``x y`` fit with room to spare).
MAX_SCAN_BYTES = 8 * 1024 * 1024
# points this far beyond the sensor range (as a fraction of it) are worth a warning:
# recorded scans cropped at the range reach 1.104 m for a 1.1 m range
_RANGE_SLACK = 0.05
_EXCERPT = 60


def _excerpt(text: str) -> str:
    """``text`` for an error message: whole when short, else its start and its length."""
    text = text.strip()
    if len(text) <= _EXCERPT:
        return repr(text)
    return f"{text[:_EXCERPT]!r}… ({len(text):,} characters)"


def validate_scan(points: object, name: str = "scan") -> np.ndarray:
    """Return ``points`` as a float64 N×2 array, or raise :class:`ScanError` saying why.

    Complex values are refused (dropping the imaginary part would invent a scan); in a
    masked array a masked coordinate is a missing return and its point is dropped.

    >>> validate_scan([[0.5, 0.1]]).shape
    (1, 2)
    >>> validate_scan(np.ma.masked_invalid([[0.5, 0.1], [np.nan, 0.2]])).tolist()
    [[0.5, 0.1]]
    """
    if type(points) is np.ndarray and points.dtype == np.float64 and points.ndim == 2 and points.shape[1] == 2:
        # the common case (a float array from a driver or a file): one check
        if len(points) <= MAX_SCAN_POINTS and np.isfinite(points).all():
            return points
    mask = None
    if np.ma.isMaskedArray(points):
        mask = np.ma.getmaskarray(points)
        points = np.ma.getdata(points)
    try:
        raw = np.asarray(points)
    except (TypeError, ValueError) as exc:
        raise ScanError(f"{name}: not numeric ({_excerpt(str(exc))})") from None
    if np.iscomplexobj(raw):
        raise ScanError(f"{name}: complex values; a scan holds real x, y coordinates")
    if raw.dtype.kind not in "biuf" and raw.size:
        if raw.dtype.kind in "OUS":
            try:
                raw = raw.astype(np.float64)
            except (TypeError, ValueError) as exc:
                raise ScanError(f"{name}: not numeric ({_excerpt(str(exc))})") from None
        else:
            raise ScanError(f"{name}: not numeric (dtype {raw.dtype})")
    if raw.dtype.kind == "b" and raw.size:
        raise ScanError(f"{name}: boolean values; a scan holds real x, y coordinates")
    arr = raw.astype(np.float64, copy=False)
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ScanError(f"{name}: expected an N×2 array of x, y, got shape {arr.shape}")
    if mask is not None:
        mask = np.broadcast_to(mask, arr.shape)
        arr = arr[~mask.any(axis=1)]
    if len(arr) > MAX_SCAN_POINTS:
        raise ScanError(f"{name}: {len(arr):,} points, more than the limit of {MAX_SCAN_POINTS:,} per scan")
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise ScanError(f"{name}: point {i} is not finite ({arr[i, 0]}, {arr[i, 1]})")
    return arr


def _kind(mode: int) -> str | None:
    """What a non-regular file is, in words (None for a regular file)."""
    for test, what in (
        (stat.S_ISDIR, "is a folder, not a scan file"),
        (stat.S_ISFIFO, "is a FIFO (named pipe), not a scan file"),
        (stat.S_ISCHR, "is a character device, not a scan file"),
        (stat.S_ISBLK, "is a block device, not a scan file"),
        (stat.S_ISSOCK, "is a socket, not a scan file"),
    ):
        if test(mode):
            return what
    return None if stat.S_ISREG(mode) else "is not a regular file"


def _read_bounded(path: Path) -> bytes:
    """The bytes of a regular file of at most :data:`MAX_SCAN_BYTES`, or a ScanError.

    The file is opened without blocking (a FIFO would block an ordinary open until a
    writer appears) and its type checked on the open descriptor, so no special file is
    ever read; the read itself stops after the limit (``/proc`` files report size 0).
    """
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise ScanError(f"{path}: no such file") from None
    except PermissionError:
        raise ScanError(f"{path}: cannot read: permission denied") from None
    except OSError as exc:
        raise ScanError(f"{path}: cannot open: {exc.strerror or exc}") from None
    try:
        info = os.fstat(fd)
        what = _kind(info.st_mode)
        if what:
            raise ScanError(f"{path}: {what}")
        if info.st_size > MAX_SCAN_BYTES:
            raise ScanError(f"{path}: {info.st_size:,} bytes, larger than the {MAX_SCAN_BYTES // 2**20} MiB limit for a scan file")
        chunks: list[bytes] = []
        total = 0
        while total <= MAX_SCAN_BYTES:
            chunk = os.read(fd, min(1 << 20, MAX_SCAN_BYTES + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > MAX_SCAN_BYTES:
            raise ScanError(f"{path}: larger than the {MAX_SCAN_BYTES // 2**20} MiB limit for a scan file")
        return b"".join(chunks)
    except OSError as exc:
        raise ScanError(f"{path}: cannot read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


def _parse_npy(path: Path, data: bytes) -> np.ndarray:
    """An N×2 array from the bytes of a ``.npy`` file, the header checked before any allocation."""
    fp = io.BytesIO(data)
    try:
        version = npy_format.read_magic(fp)
        if version == (1, 0):
            shape, fortran, dtype = npy_format.read_array_header_1_0(fp)
        elif version == (2, 0):
            shape, fortran, dtype = npy_format.read_array_header_2_0(fp)
        else:
            raise ScanError(f"{path}: unsupported .npy format version {version[0]}.{version[1]}")
    except ScanError:
        raise
    except (ValueError, SyntaxError, tokenize.TokenError, EOFError, UnicodeDecodeError, TypeError, KeyError) as exc:
        raise ScanError(f"{path}: not a readable .npy array (bad header: {_excerpt(str(exc))})") from None
    if dtype.kind == "c":
        raise ScanError(f"{path}: complex values; a scan holds real x, y coordinates")
    if dtype.kind not in "iuf" or dtype.hasobject or dtype.fields is not None or dtype.subdtype is not None:
        raise ScanError(f"{path}: not a numeric .npy array (dtype {dtype})")
    if not all(isinstance(n, int) and n >= 0 for n in shape):
        raise ScanError(f"{path}: not a readable .npy array (bad shape {tuple(shape)!r} in header)")
    count = math.prod(shape)
    if count == 0:
        return np.zeros((0, 2))
    if len(shape) != 2 or shape[1] != 2:
        raise ScanError(f"{path}: expected an N×2 array of x, y, got shape {tuple(shape)}")
    if shape[0] > MAX_SCAN_POINTS:
        raise ScanError(f"{path}: {shape[0]:,} points, more than the limit of {MAX_SCAN_POINTS:,} per scan")
    offset = fp.tell()
    need = count * dtype.itemsize
    if len(data) - offset < need:
        raise ScanError(f"{path}: truncated .npy array ({len(data) - offset:,} of {need:,} data bytes)")
    arr = np.frombuffer(data, dtype=dtype, count=count, offset=offset).reshape(shape, order="F" if fortran else "C")
    return validate_scan(arr, str(path))


def _parse_text(path: Path, data: bytes) -> np.ndarray:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ScanError(f"{path}: not a text scan file (binary content)") from None
    rows: list[tuple[float, float]] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        stripped = line.split("#", 1)[0].strip()
        if not stripped:
            continue
        parts = stripped.replace(",", " ").split()
        if len(parts) != 2:
            raise ScanError(f"{path}:{lineno}: expected two numbers 'x y', got {_excerpt(line)}")
        try:
            x, y = float(parts[0]), float(parts[1])
        except ValueError:
            raise ScanError(f"{path}:{lineno}: not a number in {_excerpt(line)}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ScanError(f"{path}:{lineno}: coordinate is not finite in {_excerpt(line)}")
        if len(rows) == MAX_SCAN_POINTS:
            raise ScanError(f"{path}:{lineno}: more than the limit of {MAX_SCAN_POINTS:,} points per scan")
        rows.append((x, y))
    return np.array(rows, dtype=np.float64).reshape(-1, 2)


def load_scan(source: str | os.PathLike[str] | np.ndarray) -> np.ndarray:
    """Read a scan: a text file or a ``.npy`` N×2 array (metres), or an array.

    A text scan has one point per line, ``x y`` separated by spaces, tabs or a comma;
    ``#`` starts a comment; blank lines are skipped. An empty file is a scan with no
    returns (free space). Anything else — a special file (FIFO, device, folder), an
    unreadable or oversized file (:data:`MAX_SCAN_BYTES`, :data:`MAX_SCAN_POINTS`), a
    malformed line or header — raises one :class:`ScanError` naming the file.

    >>> load_scan(np.array([[0.5, 0.0]])).tolist()
    [[0.5, 0.0]]
    """
    if not isinstance(source, (str, os.PathLike)):
        return validate_scan(source)
    path = Path(source)
    data = _read_bounded(path)
    if path.suffix == ".npy" or data.startswith(b"\x93NUMPY"):
        return _parse_npy(path, data)
    return _parse_text(path, data)


def scan_files(folder: str | os.PathLike[str], suffixes: tuple[str, ...] = SCAN_SUFFIXES) -> list[Path]:
    """The scan files of ``folder`` (by suffix, sorted by name), or a ScanError saying why not.

    Only the names are listed here; each file is checked when it is read, so one bad
    file does not hide the others.

    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> for name in ("map0002.dat", "map0001.dat", "notes.md"):
    ...     _ = (folder / name).write_text("0.5 0.0")
    >>> [p.name for p in scan_files(folder)]
    ['map0001.dat', 'map0002.dat']
    """
    root = Path(folder)
    try:
        entries = sorted(root.iterdir())
    except FileNotFoundError:
        raise ScanError(f"{root}: no such folder") from None
    except NotADirectoryError:
        raise ScanError(f"{root}: not a folder") from None
    except PermissionError:
        raise ScanError(f"{root}: cannot list the folder: permission denied") from None
    except OSError as exc:
        raise ScanError(f"{root}: cannot list the folder: {exc.strerror or exc}") from None
    files = [p for p in entries if p.suffix in suffixes and not p.name.startswith(".")]
    if not files:
        raise ScanError(f"{root}: no scan files ({', '.join('*' + s for s in suffixes)}) in this folder")
    return files


def range_warning(points: np.ndarray, sensor_range: float) -> str | None:
    """A warning when points lie beyond the sensor range (they are ignored), else None.

    When most of the scan lies far beyond the range, the coordinates are probably not
    in metres, and the warning says so.

    >>> range_warning(np.array([[300.0, 0.0], [0.5, 0.0]]), 1.1)
    '1 of 2 points lies beyond the 1.1 m sensor range and is ignored'
    """
    if not len(points):
        return None
    r = np.hypot(points[:, 0], points[:, 1])
    far = int(np.count_nonzero(r > sensor_range * (1 + _RANGE_SLACK)))
    if not far:
        return None
    n = len(points)
    msg = (
        f"{far} of {n} point{'s' if n != 1 else ''} {'lies' if far == 1 else 'lie'} beyond the "
        f"{sensor_range:g} m sensor range and {'is' if far == 1 else 'are'} ignored"
    )
    if far * 2 > len(points) and float(np.median(r)) > 10 * sensor_range:
        msg += f" (median distance {float(np.median(r)):g}: scans are in metres — is this one in millimetres?)"
    return msg


@dataclass(frozen=True, eq=False)
class Obstacles:
    """The obstacle disturbances of one scan, with arrays for fast geometry.

    ``boxes`` is M×4×2 (the corners of each oriented box, counter-clockwise),
    ``centres`` M×2 and ``radii`` M (circumradius of each box). ``points`` are the
    sensed points the boxes cover (N×2) and box ``i`` covers
    ``points[starts[i]:starts[i + 1]]``. ``exempt`` counts the returns perception
    dropped because they lay inside the robot's body at the planning origin.
    ``disturbances[i]`` is the :class:`Disturbance` of box ``i`` (its ident is ``i``),
    built on first use (a plan usually needs none of them).

    >>> obs = Obstacles.from_boxes([[(0.5, -0.1), (0.6, -0.1), (0.6, 0.1), (0.5, 0.1)]])
    >>> len(obs), obs.contains_point(0.55, 0.0), obs.contains_point(0.0, 0.0)
    (1, 0, None)
    """

    boxes: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    starts: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.intp))
    exempt: int = 0

    def __post_init__(self) -> None:
        # a hand-built value with arrays that disagree would fail deep in the planner with a
        # bare numpy broadcast error; say what is wrong here instead (a few len() calls)
        m = len(self.boxes)
        if len(self.centres) != m or len(self.radii) != m or len(self.starts) != m + 1 or (
            int(self.starts[-1]) != len(self.points) if len(self.starts) else True
        ):
            raise ValueError(
                f"Obstacles: {m} boxes need {m} centres, {m} radii and {m + 1} starts ending at the "
                f"{len(self.points)} points, got {len(self.centres)}, {len(self.radii)} and {len(self.starts)} "
                "(build them with Obstacles.from_boxes or perceive)"
            )

    @functools.cached_property
    def owner(self) -> np.ndarray:
        """For every point, the index of the box that covers it."""
        return np.repeat(np.arange(len(self.boxes)), self.starts[1:] - self.starts[:-1])

    def __len__(self) -> int:
        return len(self.boxes)

    @functools.cached_property
    def disturbances(self) -> tuple[Disturbance, ...]:
        """One obstacle :class:`Disturbance` per box (centre and outline)."""
        return tuple(
            Disturbance(DisturbanceKind.OBSTACLE, float(c[0]), float(c[1]), tuple((float(x), float(y)) for x, y in b), i)
            for i, (b, c) in enumerate(zip(self.boxes.tolist(), self.centres.tolist()))
        )

    def box_points(self, i: int) -> np.ndarray:
        """The sensed points box ``i`` covers (its outline sampled every 5 mm for a box not made from a scan)."""
        return self.points[self.starts[i] : self.starts[i + 1]]

    @classmethod
    def from_boxes(cls, boxes: list[np.ndarray] | np.ndarray | list[Any]) -> "Obstacles":
        """Build from a list of 4×2 convex quadrilaterals (counter-clockwise)."""
        arr = np.asarray(boxes, dtype=np.float64).reshape(-1, 4, 2)
        centres = arr.mean(axis=1)
        radii = np.linalg.norm(arr - centres[:, None, :], axis=2).max(axis=1) if len(arr) else np.zeros(0)
        pieces = [_outline(b) for b in arr]
        starts = np.cumsum([0] + [len(p) for p in pieces]).astype(np.intp)
        pts = np.concatenate(pieces) if pieces else np.zeros((0, 2))
        return cls(arr, centres, radii, pts, starts)

    def contains_point(self, x: float, y: float, margin: float = 0.0) -> int | None:
        """The index of a box containing (x, y) (grown by ``margin``), or None."""
        if not len(self.boxes):
            return None
        near = np.flatnonzero(np.hypot(self.centres[:, 0] - x, self.centres[:, 1] - y) <= self.radii + margin + 1e-12)
        for i in near.tolist():
            if _point_in_convex(self.boxes[i], x, y, margin):
                return int(i)
        return None


_NONE = Obstacles(np.zeros((0, 4, 2)), np.zeros((0, 2)), np.zeros(0))


def _outline(box: np.ndarray, step: float = 0.005) -> np.ndarray:
    out = []
    for k in range(4):
        a, b = box[k], box[(k + 1) % 4]
        n = max(1, int(math.ceil(float(np.hypot(*(b - a))) / step)))
        t = np.arange(n)[:, None] / n
        out.append(a + t * (b - a))
    return np.concatenate(out)


def _point_in_convex(box: np.ndarray, x: float, y: float, margin: float) -> bool:
    n = len(box)
    for k in range(n):
        ax, ay = box[k]
        bx, by = box[(k + 1) % n]
        ex, ey = bx - ax, by - ay
        norm = math.hypot(ex, ey) or 1.0
        # signed distance to the left of the edge (inside for a CCW polygon)
        if (ex * (y - ay) - ey * (x - ax)) / norm < -margin:
            return False
    return True


def _frames(z: np.ndarray, bounds: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per piece (points ``bounds[i]:bounds[i+1]`` of ``z``, complex x + iy): its first
    point ``a`` and the unit chord ``e`` to its last point; per point ``w = (z - a) / e``,
    whose real part is the offset along the chord and imaginary part the offset across it
    (so the extents are one ``reduceat`` each). Methods rather than numpy's functions:
    on a few hundred points the call overhead is most of the cost."""
    a = z.take(bounds[:-1])
    e = z.take(bounds[1:] - 1) - a
    norm = np.abs(e)
    if norm.min() < 1e-9:
        single = norm < 1e-9
        norm[single] = 1.0
        e[single] = 1.0
    e /= norm
    # each piece's a and e repeated over its points (as a gather by piece index would)
    return a, e, (z - a.repeat(counts)) * e.conj().repeat(counts)


def perceive(
    points: np.ndarray,
    sensor_range: float = 1.1,
    cluster_distance: float = 0.1,
    *,
    pad: float = _PAD,
    body: tuple[float, float, float] | None = None,
) -> Obstacles:
    """Turn a scan into obstacle disturbances (see the module docstring).

    Points beyond ``sensor_range`` are dropped (the paper's robot ignored them), with a
    :class:`ScanWarning` (see :func:`range_warning`), as are returns at the sensor
    itself (closer than 1 mm). ``pad`` is how far a box stands off its outermost points
    (the allowance for sensor noise). ``body`` = ``(rear, front, half_width)`` is the
    robot's body at the planning origin: returns inside it are its own (or already under
    it) and are dropped, counted in ``Obstacles.exempt``; nothing outside the body is
    exempt.

    >>> wall = np.c_[np.full(41, 0.5), np.linspace(-0.2, 0.2, 41)]
    >>> obs = perceive(wall)
    >>> bool(obs.contains_point(0.5, 0.0) is not None), bool(obs.contains_point(0.52, 0.0) is None)
    (True, True)
    >>> round(float((obs.boxes[:, :, 0].max(axis=1) - obs.boxes[:, :, 0].min(axis=1)).max()), 3)  # 4 mm thin
    0.004
    """
    pts = validate_scan(points)
    exempt = 0
    if not len(pts):
        return _NONE
    x, y = pts[:, 0], pts[:, 1]
    r2 = x * x + y * y
    keep = (r2 <= sensor_range * sensor_range) & (r2 > 1e-6)
    if body is not None:
        rear, front, half = body
        near = (keep & (r2 < rear * rear + half * half)).nonzero()[0]
        if len(near):
            nx, ny = x[near], y[near]
            own = near[(nx > -rear) & (nx < front) & (np.abs(ny) < half)]
            exempt = len(own)
            keep[own] = False
    kept = int(np.count_nonzero(keep))
    if kept < len(pts):
        if (r2 > (sensor_range * (1 + _RANGE_SLACK)) ** 2).any():
            warning = range_warning(pts, sensor_range)
            if warning:
                warnings.warn(ScanWarning(warning), stacklevel=2)
        if not kept:
            return _NONE if not exempt else Obstacles(_NONE.boxes, _NONE.centres, _NONE.radii, exempt=exempt)
    # the points as complex numbers x + iy from here on (a piece's frame is then one
    # product per point)
    zall = np.ascontiguousarray(pts).view(np.complex128).ravel()
    if len(pts) > _DEDUPE_FROM:
        # a recorded scan repeats most returns (3 of 4 on the shared scans): a point
        # bit-equal to the one before it in the scan is dropped before the sort. Sorted
        # stably by bearing it would follow that same point at once (an equal bearing
        # keeps the scan's order), and be dropped below as a zero step, leaving every
        # other step as it was: the same surfaces, with less to sort
        bits = zall.view(np.int64)
        keep[1:] &= (bits[2::2] != bits[:-2:2]) | (bits[3::2] != bits[1:-2:2])
    idx = keep.nonzero()[0]
    # order along the surfaces the sensor saw: by bearing from the sensor
    z = zall.take(idx.take(np.arctan2(y.take(idx), x.take(idx)).argsort(kind="stable")))
    n = len(z)
    d = np.empty(n, dtype=np.complex128)
    np.subtract(z[1:], z[:-1], out=d[1:])
    d[0] = z[0] - z[-1]
    step = np.hypot(d.real, d.imag)
    if n > 1:
        uniq = step > 1e-4  # recorded scans repeat points: a repeat is a zero step
        distinct = np.count_nonzero(uniq)
        if distinct < n:
            if not distinct:
                uniq[0] = True
            z, step = z[uniq], step[uniq]
            n = len(z)
    brk = step > cluster_distance
    first = int(brk.argmax())
    if brk[first]:
        # start at a break, so that a surface crossing the bearing ±π is not cut
        if first:
            z = np.concatenate((z[first:], z[:first]))
            brk = np.concatenate((brk[first:], brk[:first]))
            step = np.concatenate((step[first:], step[:first]))
    else:
        brk[0] = True
    # pieces: surfaces cut every _PIECE metres of path, then halved while thick
    cell = (np.where(brk, 0.0, step).cumsum() * (1.0 / _PIECE)).astype(np.int64)
    cut = np.empty(n + 1, dtype=bool)  # where a piece starts, and the end (n)
    cut[:n] = brk
    cut[1:n] |= cell[1:] != cell[:-1]
    cut[n] = True
    while True:
        bounds = cut.nonzero()[0]
        starts = bounds[:-1]
        counts = bounds[1:] - starts
        a, e, w = _frames(z, bounds, counts)
        t = w.imag
        t0, t1 = np.minimum.reduceat(t, starts), np.maximum.reduceat(t, starts)
        # only the spread across a piece decides whether it is halved
        fat = (t1 - t0 > _THIN) & (counts > 2)
        if not np.count_nonzero(fat):
            break
        cut[starts[fat] + counts[fat] // 2] = True
    u = w.real
    # the extents, padded: rows u0, u1, t0, t1
    ext = np.array((np.minimum.reduceat(u, starts), np.maximum.reduceat(u, starts), t0, t1))
    ext += _SIGNS_PAD if pad == _PAD else _SIGNS * pad
    # corners a + (u + i·t)·e, counter-clockwise: (u0,t0) (u1,t0) (u1,t1) (u0,t1)
    local = ext.take(_CORNER_U, axis=0) + 1j * ext.take(_CORNER_T, axis=0)
    corners = np.ascontiguousarray((local * e + a).T)
    m = len(starts)
    boxes = corners.view(np.float64).reshape(m, 4, 2)
    centres = ((corners[:, 0] + corners[:, 2]) * 0.5).view(np.float64).reshape(m, 2)
    radii = np.abs(local[2] - local[0]) * 0.5
    return Obstacles(boxes, centres, radii, z.view(np.float64).reshape(n, 2), bounds, exempt)
