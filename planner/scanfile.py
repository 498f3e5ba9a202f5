"""Scan input: a LiDAR scan read from a file or an array, checked, as an N×2 float array.

:func:`load_scan` reads a text or ``.npy`` file (or takes an array), :func:`validate_scan`
checks an array, :func:`scan_files` lists a folder's scan files. Anything that is not a
valid scan raises one :class:`ScanError` saying why; nothing is read that could block
(a FIFO, a device) or exhaust memory (:data:`MAX_SCAN_BYTES`, :data:`MAX_SCAN_POINTS`).
"""

from __future__ import annotations

import io
import math
import os
import tokenize
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

from clomp.planner.inputs import read_input

__all__ = [
    "MAX_SCAN_BYTES",
    "MAX_SCAN_POINTS",
    "SCAN_SUFFIXES",
    "ScanError",
    "load_scan",
    "scan_files",
    "validate_scan",
]

#: the file name endings of scan files in a folder
SCAN_SUFFIXES: tuple[str, ...] = (".dat", ".txt", ".npy", ".xy")


class ScanError(ValueError):
    """A scan cannot be read or is not a valid N×2 array of finite coordinates.

    >>> try:
    ...     validate_scan(np.array([[np.nan, 0.0]]))
    ... except ScanError as exc:
    ...     print(exc)
    scan: point 0 is not finite (nan, 0.0)
    """


#: A scan holds at most this many points (an RPLIDAR A1 gives about 360 per revolution).
MAX_SCAN_POINTS = 50_000
#: A scan file is at most this many bytes (50,000 text lines of ``x y`` fit with room to spare).
MAX_SCAN_BYTES = 8 * 1024 * 1024
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


def _read_bounded(path: Path) -> bytes:
    """The bytes of a regular file of at most :data:`MAX_SCAN_BYTES`, or a ScanError
    (:func:`clomp.planner.inputs.read_input`: no special file is ever read)."""
    return read_input(path, "scan file", MAX_SCAN_BYTES, ScanError)


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
    if not all(type(n) is int and n >= 0 for n in shape):
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
