"""One progress bar for every long job of the command line (tqdm, on standard error).

A bar is drawn only when standard error is a terminal: piped or redirected, a command
prints exactly what it printed before, so scripts and logs see no carriage returns.
Result lines go to standard output through :meth:`Progress.write` (or :func:`echo`) so
that they appear above the bar instead of tearing it.

Wrap an iterable:

>>> for n in progress(range(3), desc="scans", unit="scan", enabled=False):
...     pass

or count results that arrive in their own order (a process pool, Dask):

>>> with progress(total=4, desc="runs", unit="run", enabled=False) as bar:
...     for _ in range(4):
...         bar.update()
>>> bar.n
4
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Iterator
from types import TracebackType
from typing import IO, Any, Generic, TypeVar

__all__ = ["Progress", "progress", "echo", "enabled_for"]

T = TypeVar("T")

# the bar that is drawn now, so that echo() can print above it
_active: list["Progress[Any]"] = []


def enabled_for(stream: IO[str] | None = None) -> bool:
    """True when ``stream`` (default: standard error) is a terminal, the one case where a
    bar is drawn."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # closed or not a real stream
        return False


def _size(stream: IO[str]) -> tuple[int, int]:
    try:
        size = os.get_terminal_size(stream.fileno())
    except (AttributeError, ValueError, OSError):
        return 0, 0
    return size.columns, size.lines


class Progress(Generic[T]):
    """A tqdm bar on standard error when it is a terminal; otherwise a silent counter.

    ``iterable`` is wrapped (iterate the Progress); without one, call :meth:`update` per
    finished item. ``enabled`` forces the bar on or off (default: :func:`enabled_for`).
    The bar disappears when the job ends (the command prints its own summary).
    """

    def __init__(
        self,
        iterable: Iterable[T] | None = None,
        *,
        total: int | None = None,
        desc: str | None = None,
        unit: str = "it",
        file: IO[str] | None = None,
        enabled: bool | None = None,
    ) -> None:
        self._iterable = iterable
        self._file = sys.stderr if file is None else file
        self.enabled = enabled_for(self._file) if enabled is None else bool(enabled)
        if total is None and iterable is not None:
            try:
                total = len(iterable)  # type: ignore[arg-type]
            except TypeError:
                total = None
        self.total = total
        self.n = 0
        self._bar: Any = None
        if self.enabled:
            from tqdm import tqdm

            # a terminal that reports no width (a fresh pseudo-terminal) would get an empty bar
            sized = min(_size(self._file)) > 0
            self._bar = tqdm(total=total, desc=desc, unit=unit, file=self._file, leave=False, mininterval=0.1,
                             dynamic_ncols=sized, ncols=None if sized else 80, nrows=None if sized else 24)
            _active.append(self)

    def __iter__(self) -> Iterator[T]:
        if self._iterable is None:
            raise TypeError("this Progress wraps no iterable: call update() instead")
        try:
            for item in self._iterable:
                yield item
                self.update()
        finally:
            self.close()

    def update(self, n: int = 1) -> None:
        """Count ``n`` more finished items."""
        self.n += n
        if self._bar is not None:
            self._bar.update(n)

    def note(self, text: str) -> None:
        """Show ``text`` beside the bar (e.g. the item being worked on)."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=False)

    def write(self, line: str, file: IO[str] | None = None) -> None:
        """Print one line (default to standard output) above the bar."""
        out = sys.stdout if file is None else file
        if self._bar is not None:
            self._bar.write(line, file=out)
            out.flush()
        else:
            print(line, file=out, flush=True)

    def close(self) -> None:
        """Remove the bar (idempotent)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        if self in _active:
            _active.remove(self)

    def __enter__(self) -> "Progress[T]":
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


progress = Progress
"""A :class:`Progress` over an iterable (or a counter of ``total`` items): the name the commands call, as tqdm's."""


def echo(line: str, file: IO[str] | None = None) -> None:
    """Print one line (default to standard output) above the bar drawn now, if any."""
    if _active:
        _active[-1].write(line, file)
    else:
        print(line, file=sys.stdout if file is None else file, flush=True)
