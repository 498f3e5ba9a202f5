"""The ``clomp`` command line.

Each subcommand lives in its own module of this package (``runtime/cli/<command>.py``) that defines ``register(subparsers)`` (adding
its parser with ``set_defaults(func=...)``) so that commands can grow independently.
A handled error (:class:`CliError`) prints one line and exits with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
import warnings
from collections.abc import Sequence
from typing import TextIO

from planner.perception import ScanWarning

__all__ = ["main", "CliError"]

# subcommand modules, in the order they appear in --help
_COMMAND_MODULES: list[str] = [
    "runtime.cli.demo",
    "runtime.cli.plan",
    "runtime.cli.replay",
    "runtime.cli.simulate",
    "runtime.cli.experiment",
    "runtime.cli.export",
    "runtime.cli.convert",
    "runtime.cli.check",
    "runtime.cli.emulate",
    "runtime.cli.run",
]


class CliError(Exception):
    """A user error: printed as one line ``clomp: error: …``, exit status 2."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="clomp",
        description="Closed-loop multi-step planning with innate physics knowledge.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """Print a warning as one line ``clomp: warning: …`` (no source location: it is for a user)."""
    print(f"clomp: warning: {message}", file=sys.stderr if file is None else file)


# options whose value is a coordinate pair that may start with a minus sign
_COORDINATE_OPTIONS = frozenset({"--goal"})
_NEGATIVE_VALUE = re.compile(r"^-[0-9.]")


def _join_negative_values(argv: Sequence[str]) -> list[str]:
    """``--goal -0.8,0`` → ``--goal=-0.8,0``: argparse takes ``-0.8,0`` for an option.

    >>> _join_negative_values(["plan", "--goal", "-0.8,0", "--json"])
    ['plan', '--goal=-0.8,0', '--json']
    """
    out: list[str] = []
    items = list(argv)
    i = 0
    while i < len(items):
        tok = items[i]
        if tok == "--":
            out.extend(items[i:])
            break
        if tok in _COORDINATE_OPTIONS and i + 1 < len(items) and _NEGATIVE_VALUE.match(items[i + 1]):
            out.append(f"{tok}={items[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(_join_negative_values(sys.argv[1:] if argv is None else argv))
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    with warnings.catch_warnings():
        warnings.simplefilter("always", ScanWarning)
        warnings.showwarning = _show_warning
        return _dispatch(args)


def _dispatch(args: argparse.Namespace) -> int:
    try:
        return int(args.func(args) or 0)
    except CliError as exc:
        print(f"clomp: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("clomp: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0

