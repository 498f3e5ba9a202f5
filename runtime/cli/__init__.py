"""The ``clomp`` command line.

Each subcommand lives in its own module of this package (``runtime/cli/<command>.py``) that defines ``register(subparsers)`` (adding
its parser with ``set_defaults(func=...)``) so that commands can grow independently.
A handled error (:class:`CliError`) prints one line and exits with status 2.
"""

from __future__ import annotations

import argparse
import importlib
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


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
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

