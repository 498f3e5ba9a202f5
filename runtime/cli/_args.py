"""Argument types that validate numbers where they enter: one rule per kind of number for
every command (seeds, counts, lengths).

A bad value does not stop argparse (which would print its usage and more lines): the
type returns an :class:`Invalid` holding the message, and :func:`check_args` (called by
the dispatcher before any command runs) turns the first one into the usual one line
``clomp: error: …`` with exit 2.

>>> seed_arg("7"), seed_arg("-1")
(7, Invalid('--seed: expected a whole number from 0 to 4294967295, got -1'))
>>> length_arg(0.0, 100.0, "--step-length")("1e300")
Invalid('--step-length: expected metres from 0 to 100, got 1e300')
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from clomp.runtime.cli import CliError

__all__ = ["MAX_SEED", "Invalid", "check_args", "count_arg", "length_arg", "seed_arg"]

#: the largest seed (the seeds of numpy's generators, and the scenario files' ``seed``)
MAX_SEED = 2**32 - 1


class Invalid:
    """An argument value that was refused, with the message saying why."""

    def __init__(self, message: str) -> None:
        self.message = message

    def __repr__(self) -> str:
        return f"Invalid({self.message!r})"


def _whole(text: str) -> int | None:
    try:
        return int(text.strip(), 10)
    except ValueError:
        return None


def seed_arg(text: str, name: str = "--seed") -> int | Invalid:
    """A seed: a whole number from 0 to :data:`MAX_SEED` (every command, and scenario files)."""
    n = _whole(text) if len(text) <= 20 else None
    if n is None or not 0 <= n <= MAX_SEED:
        return Invalid(f"{name}: expected a whole number from 0 to {MAX_SEED}, got {text[:40]}")
    return n


def count_arg(low: int, high: int, name: str = "count") -> Callable[[str], int | Invalid]:
    """A whole number from ``low`` to ``high``."""

    def parse(text: str) -> int | Invalid:
        n = _whole(text) if len(text) <= 20 else None
        if n is None or not low <= n <= high:
            return Invalid(f"{name}: expected a whole number from {low:,} to {high:,}, got {text[:40]}")
        return n

    return parse


def length_arg(low: float, high: float, name: str = "length") -> Callable[[str], float | Invalid]:
    """A finite number of metres from ``low`` to ``high``."""

    def parse(text: str) -> float | Invalid:
        try:
            v = float(text)
        except ValueError:
            v = math.nan
        if not (math.isfinite(v) and low <= v <= high):
            return Invalid(f"{name}: expected metres from {low:g} to {high:g}, got {text[:40]}")
        return v

    return parse


def check_args(args: argparse.Namespace) -> None:
    """Raise :class:`CliError` for the first argument an argument type refused."""
    for value in vars(args).values():
        if isinstance(value, Invalid):
            raise CliError(value.message)
