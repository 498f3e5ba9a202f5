"""The plan check's contact tests, compiled (:func:`clomp.runtime.jit.compiled`).

:mod:`clomp.runtime.supervision.checkgeometry` states the rules (the planner's: the inflated
footprint translated along a straight or turned through every tick heading of a turn,
with the start-touching rule); these loops apply them point by point with the same
floating-point operations, in the same order, as the array expressions they replace —
the tests hold both to the reference check bit for bit. Compiled, a check of a few
legs against a revolution takes microseconds instead of the dozens of array calls the
expressions cost.

>>> import numpy as np
>>> out = np.zeros(1)
>>> straight_gaps(np.array([0.5]), np.array([0.0]), np.zeros(1), np.zeros(1), np.ones(1), np.zeros(1),
...               0.1, 0.1, 0.2, 0.0, 0.2, 0.1, out)
>>> round(float(out[0]), 9)   # the point 0.5 m ahead, the inflated front 0.2 m ahead
0.3
"""

from __future__ import annotations

import math

import numpy as np

from clomp.runtime.jit import compiled, interruptible

__all__ = ["straight_gaps", "sweep_hits", "turn_first_ticks", "warm_up"]


@compiled
def straight_gaps(zr: np.ndarray, zi: np.ndarray, sx: np.ndarray, sy: np.ndarray, cth: np.ndarray, sth: np.ndarray,
                  rear: float, half: float, front: float, allowance: float, rfront: float, rhalf: float,
                  out: np.ndarray) -> None:
    """Per straight leg (start ``sx, sy``, heading cos ``cth``, sin ``sth``): how far its
    inflated front (``front``, ``rear``, ``half``: the inflated body less the allowance)
    drives before it meets one of the points ``zr + i zi``, into ``out`` (inf: never). A
    point already within the allowance at the start is held to the real body (``rfront``,
    ``rhalf``); strictly inside that, it is the robot's own return and never counts."""
    for g in range(sx.shape[0]):
        er, ei = cth[g], -sth[g]
        best = math.inf
        for j in range(zr.shape[0]):
            dr, di = zr[j] - sx[g], zi[j] - sy[g]
            u, v = dr * er - di * ei, abs(dr * ei + di * er)
            if v <= half and u >= -rear and u < best:
                best = u
        d = best - front
        if d <= allowance:  # inside the inflated footprint at the start: the start-touching rule
            d = math.inf
            for j in range(zr.shape[0]):
                dr, di = zr[j] - sx[g], zi[j] - sy[g]
                u, v = dr * er - di * ei, abs(dr * ei + di * er)
                if not (v <= half and u >= -rear):
                    continue
                gap = u - front
                if gap <= allowance:
                    gap = u - rfront if v < rhalf else math.inf
                    if not gap >= allowance:
                        gap = math.inf
                if gap < d:
                    d = gap
        out[g] = d


@compiled
def turn_first_ticks(zr: np.ndarray, zi: np.ndarray, sx: np.ndarray, sy: np.ndarray, start: np.ndarray, sign: np.ndarray,
                     amount: np.ndarray, ticks: np.ndarray, per_tick: float, reach: float, mid: float, lu: float, lv: float,
                     ru: float, rv: float, length: float, half: float, k_out: np.ndarray, anyw: np.ndarray,
                     waived: np.ndarray) -> None:
    """Per turn leg: the first tick (1 … ``ticks``; ``ticks + 1``: none) at whose heading
    the inflated body (half-extents about its centre ``lu``, ``lv``; the centre ``mid``
    ahead of the wheels) holds one of the points, into ``k_out``. A point inside it at
    the start (``waived``; ``anyw``: the leg has one) is held to the real body (``ru``,
    ``rv``); strictly inside that (``length``, ``half``) at the start it is the robot's own
    return and never counts. Points beyond ``reach`` of a leg's centre cannot meet it at
    any heading and are skipped."""
    for g in range(sx.shape[0]):
        k_out[g] = ticks[g] + 1
        anyw[g] = False
        ang0 = min(0.0 * per_tick, amount[g]) * sign[g] + start[g]
        c0, s0 = math.cos(ang0), -math.sin(ang0)
        for j in range(zr.shape[0]):
            dr, di = zr[j] - sx[g], zi[j] - sy[g]
            u, v = abs((dr * c0 - di * s0) - mid), abs(dr * s0 + di * c0)
            waived[g, j] = u <= lu and v <= lv
            if waived[g, j]:
                anyw[g] = True
        for t in range(1, ticks[g] + 1):
            ang = min(t * per_tick, amount[g]) * sign[g] + start[g]
            c, s = math.cos(ang), -math.sin(ang)
            hit = False
            for j in range(zr.shape[0]):
                dr, di = zr[j] - sx[g], zi[j] - sy[g]
                if dr * dr + di * di > reach * reach:
                    continue
                u0, v0 = abs((dr * c0 - di * s0) - mid), abs(dr * s0 + di * c0)
                if u0 < length and v0 < half:
                    continue  # the robot's own return
                u, v = abs((dr * c - di * s) - mid), abs(dr * s + di * c)
                if waived[g, j]:
                    hit = u <= ru and v <= rv
                else:
                    hit = u <= lu and v <= lv
                if hit:
                    break
            if hit:
                k_out[g] = t
                break


@compiled
def sweep_hits(px: np.ndarray, py: np.ndarray, xs: np.ndarray, ys: np.ndarray, cs: np.ndarray, ss: np.ndarray,
               rear: float, front: float, half: float) -> int:
    """How many of the points ``px, py`` lie inside the box (``rear``, ``front``, ``half``;
    on its outline counts) at any of the poses ``xs, ys`` with heading cos ``cs``, sin
    ``ss``: the hazard test's count (:func:`clomp.runtime.supervision.records.hits`), each
    point moved into each pose's frame by the operations
    :func:`clomp.formal.geometry.points_to_frame` does, in its order."""
    count = 0
    for j in range(px.shape[0]):
        for g in range(xs.shape[0]):
            r0, r1 = px[j] - xs[g], py[j] - ys[g]
            u, v = r0 * cs[g] + r1 * ss[g], -r0 * ss[g] + r1 * cs[g]
            if u >= -rear and u <= front and abs(v) <= half:
                count += 1
                break
    return count


def warm_up() -> None:
    """Compile (or load from the cache) the loops now, with the argument types a check
    uses: the supervisor calls this before the robot moves, so that the first plan check
    — seconds of compiling on a fresh install — never stalls a driving control loop."""
    one, flag = np.zeros(1), np.zeros(1, dtype=bool)
    interruptible(straight_gaps, one, one, one, one, one, one, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, np.zeros(1))
    interruptible(turn_first_ticks, one, one, one, one, one, one, one, np.zeros(1, dtype=np.int64), 0.1, 0.0, 0.0, 0.0,
                  0.0, 0.0, 0.0, 0.0, 0.0, np.zeros(1, dtype=np.int64), flag, np.zeros((1, 1), dtype=bool))
    interruptible(sweep_hits, one, one, one, one, one, one, 0.0, 0.0, 0.0)
