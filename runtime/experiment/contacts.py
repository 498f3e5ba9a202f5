"""Counting collisions as the paper would: one contact episode is one collision.

The execution world reports a *contact trace*: one ``(time_s, penetration_m)`` sample per
simulation tick in which the robot's body touches an obstacle (ground truth). This module
turns a trace into *episodes*: an episode begins with the first sample in contact and
ends with the last one; a new sample less than ``merge_gap`` (1 s) after the previous
one belongs to the same episode, so a robot grinding along a box, bouncing off it and
touching again a moment later has hit it once. An episode is a *brush* when it stayed
shallow (deepest penetration below ``brush_depth``, 1 cm) and short (``duration`` =
last sample − first sample below ``brush_duration``, 0.5 s); every other episode is a
*collision*. The paper reports "brushed the obstacle twice" for the planning condition
and "collided 8 times" for the reactive one: the two words are the two classes here.

The same counter runs on both conditions, on the ground truth of the world (never on
what the robot believed).

>>> trace = [(t / 10, 0.02) for t in range(30)]          # 3 s grinding, 2 cm deep
>>> trace += [(5.0, 0.002), (7.0, 0.003)]                # two light touches 2 s apart
>>> c = count_contacts(trace)
>>> c.collisions, c.brushes
(1, 2)
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

__all__ = [
    "BRUSH_DEPTH_M",
    "BRUSH_DURATION_S",
    "MERGE_GAP_S",
    "ContactCount",
    "Episode",
    "contact_episodes",
    "count_contacts",
]

MERGE_GAP_S = 1.0
"""Contacts less than this far apart (s) are one episode."""
BRUSH_DEPTH_M = 0.01
"""An episode whose deepest penetration stays below this (m) may be a brush ..."""
BRUSH_DURATION_S = 0.5
"""... if it also lasted less than this (s)."""


@dataclass(frozen=True, slots=True)
class Episode:
    """One contact episode: first and last sample time (s), deepest penetration (m), samples."""

    start_s: float
    end_s: float
    max_penetration_m: float
    samples: int
    brush: bool

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample in contact (0 for a single tick)."""
        return self.end_s - self.start_s

    @property
    def kind(self) -> str:
        """``"brush"`` or ``"collision"``."""
        return "brush" if self.brush else "collision"


@dataclass(frozen=True, slots=True)
class ContactCount:
    """The episodes of one run and how many of each kind."""

    episodes: tuple[Episode, ...]

    @property
    def collisions(self) -> int:
        """Episodes that are not brushes."""
        return sum(not e.brush for e in self.episodes)

    @property
    def brushes(self) -> int:
        """Short, shallow episodes."""
        return sum(e.brush for e in self.episodes)


def _check(trace: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for k, item in enumerate(trace):
        try:
            t, d = item
            t, d = float(t), float(d)
        except (TypeError, ValueError):
            raise ValueError(f"contact trace[{k}]: expected (time_s, penetration_m), got {item!r}") from None
        if not (math.isfinite(t) and math.isfinite(d)) or d < 0:
            raise ValueError(f"contact trace[{k}]: time and penetration must be finite, penetration >= 0, got {item!r}")
        if out and t < out[-1][0]:
            raise ValueError(f"contact trace[{k}]: time {t} goes back before {out[-1][0]}")
        out.append((t, d))
    return out


def contact_episodes(
    trace: Iterable[tuple[float, float]],
    *,
    merge_gap: float = MERGE_GAP_S,
    brush_depth: float = BRUSH_DEPTH_M,
    brush_duration: float = BRUSH_DURATION_S,
) -> list[Episode]:
    """The contact episodes of a trace (samples in time order); see the module docstring.

    >>> [e.kind for e in contact_episodes([(0.0, 0.001), (0.5, 0.001), (3.0, 0.05)])]
    ['collision', 'collision']
    """
    samples = _check(trace)
    episodes: list[Episode] = []
    group: list[tuple[float, float]] = []

    def close() -> None:
        t0, t1 = group[0][0], group[-1][0]
        deepest = max(d for _, d in group)
        brush = deepest < brush_depth and (t1 - t0) < brush_duration
        episodes.append(Episode(t0, t1, deepest, len(group), brush))

    for t, d in samples:
        if group and t - group[-1][0] >= merge_gap:
            close()
            group = []
        group.append((t, d))
    if group:
        close()
    return episodes


def count_contacts(trace: Iterable[tuple[float, float]], **kw: float) -> ContactCount:
    """Collisions and brushes of a trace (keywords as :func:`contact_episodes`)."""
    return ContactCount(tuple(contact_episodes(trace, **kw)))
