"""Input files: every file clomp reads, opened the one safe way.

:func:`read_input` returns the bytes of a regular file of bounded size, :func:`open_input`
an open binary file to stream (run logs), :func:`load_json` decodes JSON with limits on
nesting depth and number length, :func:`check_output` checks a path before anything is
written to it, and :func:`safe_name` turns a name taken from an input into a file name.
A special file (FIFO, device, socket, folder) is refused before a byte is read, so nothing
blocks or reads forever; every refusal is one :class:`InputError` (or the caller's
subclass) naming the file and the reason.

Limits (documented in the README's "Inputs" section): :data:`MAX_JSON_BYTES` for a
scenario, map, property or preset file, :data:`MAX_LINE_BYTES` for one record of a run
log, :data:`MAX_JSON_DEPTH` and :data:`MAX_INT_DIGITS` in any JSON document.
"""

from __future__ import annotations

import json
import os
import re
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = [
    "MAX_INT_DIGITS",
    "MAX_JSON_BYTES",
    "MAX_JSON_DEPTH",
    "MAX_LINE_BYTES",
    "InputError",
    "check_output",
    "json_lines",
    "load_json",
    "open_input",
    "read_input",
    "read_text",
    "safe_name",
    "special_kind",
]

#: a scenario, map, property file or noise preset file holds at most this many bytes
MAX_JSON_BYTES = 64 * 1024 * 1024
#: one record (line) of a run log holds at most this many bytes (a 50,000-point scan is ~2 MB)
MAX_LINE_BYTES = 16 * 1024 * 1024
#: arrays and objects nest at most this deep in any JSON input (a map nests 6 deep)
MAX_JSON_DEPTH = 64
#: an integer in a JSON input has at most this many digits
MAX_INT_DIGITS = 30


class InputError(ValueError):
    """An input file cannot be used: missing, special, unreadable, too large or malformed.

    >>> try:
    ...     read_input("/dev/null", "map")
    ... except InputError as exc:
    ...     print(exc)
    /dev/null: is a character device, not a map
    """


def special_kind(mode: int, kind: str) -> str | None:
    """What a non-regular file is, in words (None for a regular file).

    >>> special_kind(stat.S_IFIFO, "run log")
    'is a FIFO (named pipe), not a run log'
    """
    for test, what in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return f"is {what}, not a {kind}"
    return None if stat.S_ISREG(mode) else f"is not a regular file, not a {kind}"


def _open_fd(path: Path, kind: str, error: type[ValueError]) -> tuple[int, int]:
    """(descriptor, size) of the regular file ``path``, opened without blocking and checked
    on the open descriptor (a FIFO would block an ordinary open until a writer appears)."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except PermissionError:
        raise error(f"{path}: cannot read: permission denied") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        raise error(f"{path}: cannot open: {getattr(exc, 'strerror', None) or exc}") from None
    try:
        info = os.fstat(fd)
        what = special_kind(info.st_mode, kind)
        if what:
            raise error(f"{path}: {what}")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd, info.st_size


def read_input(path: str | os.PathLike[str], kind: str, max_bytes: int = MAX_JSON_BYTES,
               error: type[ValueError] = InputError) -> bytes:
    """The bytes of the regular file ``path`` of at most ``max_bytes``, or ``error`` saying why.

    The read stops after the limit (``/proc`` files report size 0).

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "a.json"
    >>> _ = p.write_text("{}")
    >>> read_input(p, "map")
    b'{}'
    """
    path = Path(path)
    fd, size = _open_fd(path, kind, error)
    limit = f"{max_bytes // 2**20} MiB" if max_bytes >= 2**20 else f"{max_bytes:,} bytes"
    try:
        if size > max_bytes:
            raise error(f"{path}: {size:,} bytes, larger than the {limit} limit for a {kind}")
        chunks: list[bytes] = []
        total = 0
        while total <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > max_bytes:
            raise error(f"{path}: larger than the {limit} limit for a {kind}")
        return b"".join(chunks)
    except OSError as exc:
        raise error(f"{path}: cannot read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


def read_text(path: str | os.PathLike[str], kind: str, max_bytes: int = MAX_JSON_BYTES,
              error: type[ValueError] = InputError) -> str:
    """:func:`read_input` decoded as UTF-8 (binary content is ``error``)."""
    data = read_input(path, kind, max_bytes, error)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not a text {kind} (binary content at byte {exc.start:,})") from None


def open_input(path: str | os.PathLike[str], kind: str, error: type[ValueError] = InputError) -> IO[bytes]:
    """The regular file ``path`` open for reading in binary, to stream; special files refused.

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "run.jsonl"
    >>> _ = p.write_text('{"event": "stop"}\\n')
    >>> with open_input(p, "run log") as fh:
    ...     fh.readline()
    b'{"event": "stop"}\\n'
    """
    fd, _ = _open_fd(Path(path), kind, error)
    return os.fdopen(fd, "rb")


_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)


def _depth(text: str) -> int:
    """The deepest nesting of arrays and objects in a JSON text (strings left out), no recursion."""
    data = _STRING.sub(b"", text.encode("utf-8", "replace"))
    step = np.zeros(256, dtype=np.int64)
    step[[ord("["), ord("{")]] = 1
    step[[ord("]"), ord("}")]] = -1
    if not data:
        return 0
    return int(np.cumsum(step[np.frombuffer(data, dtype=np.uint8)]).max(initial=0))


def _parse_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise ValueError(f"an integer of {len(text):,} digits (the limit is {MAX_INT_DIGITS})")
    return int(text)


def _parse_constant(text: str) -> float:
    raise ValueError(f"{text} is not a number JSON allows")


def _decode(text: str, name: str, error: type[ValueError], max_depth: int) -> Any:
    """json.loads with the limits; a JSONDecodeError passes through (callers word it)."""
    depth = _depth(text)
    if depth > max_depth:
        raise error(f"{name}: nested {depth:,} deep, more than the limit of {max_depth}")
    try:
        return json.loads(text, parse_int=_parse_int, parse_constant=_parse_constant)
    except json.JSONDecodeError:
        raise
    except (ValueError, RecursionError) as exc:
        raise error(f"{name}: not valid JSON ({exc})") from None


def load_json(text: str, name: str, error: type[ValueError] = InputError, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """The JSON document ``text`` (named ``name`` in errors), nested at most ``max_depth``
    deep, integers of at most :data:`MAX_INT_DIGITS` digits, no NaN or Infinity.

    >>> load_json('{"a": [1, 2.5]}', "x.json")
    {'a': [1, 2.5]}
    >>> load_json("[" * 100 + "]" * 100, "x.json")
    Traceback (most recent call last):
    clomp.planner.inputs.InputError: x.json: nested 100 deep, more than the limit of 64
    """
    try:
        return _decode(text, name, error, max_depth)
    except json.JSONDecodeError as exc:
        raise error(f"{name}: not valid JSON ({exc})") from None


def json_lines(path: str | os.PathLike[str], kind: str = "run log", error: type[ValueError] = InputError,
               max_line: int = MAX_LINE_BYTES) -> Iterator[tuple[int, Any]]:
    """(line number, decoded value) of every non-blank line of a JSON-lines file, streamed.

    A malformed *last* line (a run cut short mid-write) is skipped; any other is ``error``
    naming the line. Lines longer than ``max_line`` bytes are refused.
    """
    path = Path(path)
    with open_input(path, kind, error) as fh:
        n = 0
        pending: tuple[int, bytes] | None = None
        try:
            while True:
                line = fh.readline(max_line + 1)
                if len(line) > max_line:
                    raise error(f"{path}:{n + 1}: a line longer than the {max_line // 2**20} MiB limit for a {kind} record")
                if not line:
                    break
                n += 1
                if not line.strip():
                    continue
                if pending is not None:
                    yield pending[0], _line_value(path, pending, error, last=False)
                pending = (n, line)
        except OSError as exc:
            raise error(f"{path}: cannot read: {exc.strerror or exc}") from None
        if pending is not None:
            try:
                yield pending[0], _line_value(path, pending, error, last=True)
            except _Truncated:
                return


class _Truncated(Exception):
    """The last line of a JSON-lines file is cut short."""


def _line_value(path: Path, item: tuple[int, bytes], error: type[ValueError], last: bool) -> Any:
    n, raw = item
    try:
        return _decode(raw.decode("utf-8"), f"{path}:{n}", error, MAX_JSON_DEPTH)
    except (UnicodeDecodeError, json.JSONDecodeError):
        if last:
            raise _Truncated from None
        raise error(f"{path}:{n}: not a JSON record") from None


def check_output(path: str | os.PathLike[str], what: str, error: type[ValueError] = InputError) -> Path:
    """``path`` if a file can be written there: its folder exists and is writable, and
    it is no folder, device, FIFO or socket and not read-only; else ``error``.

    >>> check_output("/dev/full", "-o")
    Traceback (most recent call last):
    clomp.planner.inputs.InputError: -o: /dev/full is a character device, not a file to write
    """
    p = Path(path)
    if "\x00" in str(p):
        raise error(f"{what}: the path holds a NUL byte")
    try:
        info = os.stat(p)
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise error(f"{what}: {p}: {exc.strerror or exc}") from None
    if info is not None:
        kind = special_kind(info.st_mode, "file to write")
        if kind:
            raise error(f"{what}: {p} {kind}")
        if not os.access(p, os.W_OK):
            raise error(f"{what}: {p} is read-only")
        return p
    parent = p.parent
    if not parent.is_dir():
        raise error(f"{what}: folder {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise error(f"{what}: folder {parent} is not writable")
    return p


_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")


def safe_name(name: str, default: str = "scenario") -> str:
    """``name`` (taken from an input) as one plain file name: no folder parts, no control
    characters, no leading dot, at most 80 characters.

    >>> safe_name("../escaped"), safe_name("a\\x00b"), safe_name("..")
    ('escaped', 'a_b', 'scenario')
    """
    cleaned = _UNSAFE.sub("_", name).strip("._-")[:80]
    return cleaned or default
