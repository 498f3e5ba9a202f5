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

A collision the world caused is counted apart (:func:`mark_pushed`): a *pushed contact*
is a collision episode that begins while an external push of the world (``push_rate``,
:meth:`~clomp.runtime.backends.world.WorldRobot.push`) still slides the body — after the
push and no later than its slide time on open floor plus :data:`PUSH_MARGIN_S` — and
touches ahead of the body in the push's direction (the push moved it into the obstacle).
What the robot drove into stays a collision, also when a push came just before: a
contact that begins after the slide, or away from the push's direction, is the robot's.

>>> trace = [(t / 10, 0.02) for t in range(30)]          # 3 s grinding, 2 cm deep
>>> trace += [(5.0, 0.002), (7.0, 0.003)]                # two light touches 2 s apart
>>> c = count_contacts(trace)
>>> c.collisions, c.brushes
(1, 2)
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace

__all__ = [
    "BRUSH_DEPTH_M",
    "BRUSH_DURATION_S",
    "MERGE_GAP_S",
    "PUSH_MARGIN_S",
    "ContactCount",
    "Episode",
    "Push",
    "contact_episodes",
    "count_contacts",
    "mark_pushed",
]

MERGE_GAP_S = 1.0
"""Contacts less than this far apart (s) are one episode."""
BRUSH_DEPTH_M = 0.01
"""An episode whose deepest penetration stays below this (m) may be a brush ..."""
BRUSH_DURATION_S = 0.5
"""... if it also lasted less than this (s)."""
PUSH_MARGIN_S = 0.1
"""A contact that begins up to this long (s) after a push's slide on open floor would have
ended is still the push's (ten physics steps: the body slows against the obstacle's friction)."""


@dataclass(frozen=True, slots=True)
class Episode:
    """One contact episode: first and last sample time (s), deepest penetration (m), samples."""

    start_s: float
    end_s: float
    max_penetration_m: float
    samples: int
    brush: bool
    pushed: bool = False  # a collision an external push slid the body into (:func:`mark_pushed`)

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
        """Episodes that are not brushes and not pushed contacts: the robot's own collisions."""
        return sum(not e.brush and not e.pushed for e in self.episodes)

    @property
    def pushed(self) -> int:
        """Collision episodes an external push slid the body into (:func:`mark_pushed`)."""
        return sum(not e.brush and e.pushed for e in self.episodes)

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


@dataclass(frozen=True, slots=True)
class Push:
    """An external push as the world applied it: when (s), how long it slides the body on
    open floor before the wheels' grip stops it (s), which way (rad, world frame) and where
    the body's rotation centre was then (world frame)."""

    time: float
    slide_s: float
    direction: float
    x: float
    y: float


def mark_pushed(episodes: Iterable[Episode], pushes: Iterable[Push], touched: Iterable[tuple[float, float]]) -> list[Episode]:
    """``episodes`` with :attr:`Episode.pushed` set on each collision episode a push slid the
    body into: it begins after a push (``push.time < start``) and no later than
    ``push.time + push.slide_s +`` :data:`PUSH_MARGIN_S`, and where it first touched
    (``touched``, one world point per episode) lies ahead of the body's position at the push
    along the push's direction. Brushes stay brushes; nothing else changes.

    >>> eps = [Episode(10.10, 12.0, 0.02, 190, False), Episode(30.0, 31.0, 0.02, 100, False)]
    >>> push = Push(10.0, 0.23, 0.0, 0.0, 0.0)                # pushed along +x at 10 s
    >>> [e.pushed for e in mark_pushed(eps, [push], [(0.2, 0.0), (0.2, 0.0)])]
    [True, False]
    >>> [e.pushed for e in mark_pushed(eps, [push], [(-0.2, 0.0), (0.2, 0.0)])]  # touched behind: its own
    [False, False]
    """
    kicks = list(pushes)
    out = []
    for e, (px, py) in zip(episodes, touched, strict=True):
        hit = not e.brush and any(
            k.time < e.start_s <= k.time + k.slide_s + PUSH_MARGIN_S
            and (px - k.x) * math.cos(k.direction) + (py - k.y) * math.sin(k.direction) > 0.0
            for k in kicks)
        out.append(replace(e, pushed=hit) if hit != e.pushed else e)
    return out


def count_contacts(trace: Iterable[tuple[float, float]], **kw: float) -> ContactCount:
    """Collisions and brushes of a trace (keywords as :func:`contact_episodes`)."""
    return ContactCount(tuple(contact_episodes(trace, **kw)))
