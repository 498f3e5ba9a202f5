"""The ``clomp`` command line.

Each subcommand lives in its own module of this package (``runtime/cli/<command>.py``)
that defines ``register(subparsers)`` (adding its parser with ``set_defaults(func=...)``)
so that commands can grow independently. A handled error (:class:`CliError`) prints one
line and exits with status 2.

Every command follows one exit-status convention (:data:`EXIT_STATUS`, shown at the end
of each command's ``--help``): 0 goal reached or job done, 1 ran but the goal was not
reached (partial plan, unreachable, halted safely), 2 bad input or usage, 3 device
fault, 130 interrupted. A run over many scans exits 0 once every scan was processed,
whatever each outcome (each has its line; the summary counts them).
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
import warnings
from collections.abc import Sequence
from typing import TextIO

from clomp.planner.perception import ScanWarning

__all__ = [
    "EXIT_DEVICE_FAULT",
    "EXIT_INTERRUPTED",
    "EXIT_NOT_REACHED",
    "EXIT_OK",
    "EXIT_STATUS",
    "EXIT_USAGE",
    "CliError",
    "build_parser",
    "main",
    "plural",
]

EXIT_OK = 0
EXIT_NOT_REACHED = 1
EXIT_USAGE = 2
EXIT_DEVICE_FAULT = 3
EXIT_INTERRUPTED = 130

#: what each exit status means, per command (the end of every command's --help)
EXIT_STATUS: dict[str, dict[int, str]] = {
    "demo": {0: "the plan reached the goal without a collision",
             1: "it did not, or the estimate could not vouch for the goal (GOAL_UNCONFIRMED)"},
    "plan": {0: "the plan reaches the goal (for a folder or bag: every scan was processed)",
             1: "a partial plan: the goal is not reached (blocked, unseen, budget)"},
    "replay": {0: "every scan was processed (each has its line; the summary counts the outcomes)"},
    "simulate": {0: "the robot reached the goal without a collision",
                 1: "it did not (or it collided, or the estimate could not vouch for the goal: GOAL_UNCONFIRMED)"},
    "experiment": {0: "every run done"},
    "sweep": {0: "every run done", 1: "some runs raised (kept apart in errors.jsonl)"},
    "export": {0: "the file was written"},
    "convert": {0: "the MCAP was written (records it does not know are counted and passed over)"},
    "check": {0: "every required property holds", 1: "a required property fails (or Storm disagrees)"},
    "emulate": {0: "stopped by Ctrl-C or SIGTERM (how an emulator ends)"},
    "run": {0: "goal reached (--dry-run: time limit)",
            1: "halted safely: goal unreachable or unconfirmed (the estimate cannot vouch for it), --max-time, an error",
            3: "a device fault (LiDAR silent or corrupt, a port vanished, a device that does not answer)"},
    "ros": {0: "node: goal reached (--dry-run: time limit); sim: stopped (--max-time, Ctrl-C)",
            1: "node: halted safely: goal unreachable, --max-time, no goal, an error",
            3: "node: a sensor fault (/scan or /odom silent or garbage)"},
}
_COMMON_STATUS = {2: "bad input or usage", 130: "interrupted (Ctrl-C, SIGTERM)"}


def plural(n: int, word: str, many: str | None = None) -> str:
    """``plural(1, "task")`` → ``'1 task'``, ``plural(3, "box", "boxes")`` → ``'3 boxes'``.

    >>> plural(1, "obstacle box", "obstacle boxes"), plural(2, "scan")
    ('1 obstacle box', '2 scans')
    """
    return f"{n} {word if n == 1 else (many or word + 's')}"


def _exit_epilog(command: str) -> str:
    table = {**EXIT_STATUS.get(command, {0: "done"}), **_COMMON_STATUS}
    if command in ("run", "emulate", "ros"):
        table.setdefault(EXIT_DEVICE_FAULT, "a device fault")
    return "exit status:\n" + "\n".join(f"  {code:<4} {what}" for code, what in sorted(table.items()))


def _plain(text: str | None) -> str | None:
    """A docstring as help text: reStructuredText literals (````x````) shown as plain x."""
    return None if text is None else text.replace("``", "")

# subcommand modules, in the order they appear in --help
_COMMAND_MODULES: list[str] = [
    "clomp.runtime.cli.demo",
    "clomp.runtime.cli.plan",
    "clomp.runtime.cli.replay",
    "clomp.runtime.cli.simulate",
    "clomp.runtime.cli.experiment",
    "clomp.runtime.cli.sweep",
    "clomp.runtime.cli.export",
    "clomp.runtime.cli.convert",
    "clomp.runtime.cli.check",
    "clomp.runtime.cli.emulate",
    "clomp.runtime.cli.run",
    "clomp.runtime.cli.ros",
]


class CliError(Exception):
    """A user error: printed as one line ``clomp: error: …``, exit status 2."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="clomp",
        description="Closed-loop multi-step planning with innate physics knowledge.",
        epilog="exit status (every command): 0 goal reached or job done, 1 ran but the goal was not reached, "
        "2 bad input or usage, 3 device fault, 130 interrupted. 'clomp COMMAND --help' says what each means there.",
    )
    parser.add_argument("--version", action="version", version=f"clomp {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    for command, p in sub.choices.items():
        p.formatter_class = argparse.RawDescriptionHelpFormatter
        p.description = _plain(p.description)
        p.epilog = "\n\n".join(e for e in (_plain(p.epilog), _exit_epilog(command)) if e)
    parser.set_defaults(_subparsers=sub)
    return parser


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("clomp")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown (not installed)"


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
    args, extra = parser.parse_known_args(_join_negative_values(sys.argv[1:] if argv is None else argv))
    if extra:
        # argparse would show the top-level usage: show the command's own
        command = getattr(args, "command", None)
        sub = getattr(args, "_subparsers", None)
        target = sub.choices.get(command, parser) if sub is not None and command else parser
        target.error(f"unrecognized arguments: {' '.join(extra)}")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    with warnings.catch_warnings():
        warnings.simplefilter("always", ScanWarning)
        warnings.showwarning = _show_warning
        return _dispatch(args)


def _dispatch(args: argparse.Namespace) -> int:
    from clomp.runtime.cli._args import check_args

    try:
        check_args(args)  # numbers refused where they entered: one line, exit 2
        return int(args.func(args) or 0)
    except CliError as exc:
        print(f"clomp: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("clomp: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return EXIT_OK

