"""Layout families: worlds that really vary, each one reproducible from (family, seed, index).

:func:`make_layout` draws one world of a family from ``numpy.random.default_rng([seed,
index])``: the same arguments give the same world on any machine, in any process.
Every family starts the robot at the origin looking along +x (the paper's set-up) and
keeps the goal where the robot's body fits (at least :data:`GOAL_CLEARANCE` from every
obstacle) and the start free. What each family varies (metres, radians; uniform draws):

============  ===========================================================================
family        variation
============  ===========================================================================
overtaking    the paper's: goal 1 m ahead; one box whose centre is 0.35–0.7 m ahead and
              ±0.15 m to the side, width (across) and depth (along) 0.1–0.3 m each (the
              depth is cut so the box ends 0.2 m before the goal: the body must fit
              there); side walls in half the layouts, 0.45–0.6 m either side, moved out
              so that one side passage stays at least 0.3 m wide
corridor      two walls 0.44–0.8 m apart, goal 0.9–1.4 m ahead anywhere across the
              corridor but 0.2 m from the walls, start heading ±0.15 rad
doorway       a wall across the way 0.4–0.65 m ahead with a doorway 0.3–0.5 m wide whose
              centre is ±0.35 m to the side; goal 0.3–0.55 m behind the wall, ±0.2 m
slalom        2 or 3 boxes (0.1 deep, 0.2–0.3 wide), 0.4–0.55 m apart, alternately
              0.05–0.15 m left and right (first side random); goal 0.35–0.5 m past the last
clutter       3–8 round posts (radius 0.03–0.06 m) anywhere in x 0.3–1.3, y ±0.5, at
              least 0.32 m apart (centres), 0.3 m from the start, 0.25 m from the goal;
              goal 1.0–1.5 m ahead, ±0.2 m
u-trap        a U of three walls open towards the robot: back 0.55–0.75 m ahead, inside
              0.4–0.6 m wide, arms 0.25–0.4 m long (never round the start), centre
              ±0.1 m to the side; the goal behind it, 0.3–0.45 m past the back
cul-de-sac    a dead-end corridor 0.5–0.8 m wide ending 0.6–0.9 m ahead; beyond its end a
              closed room 0.5–0.8 m deep, 0.8–1.2 m across holding the goal. Unreachable:
              success is stopping safely and saying so (``expect == "unreachable"``)
crossing      a room (side walls 0.7 m either side, from 0.5 m behind the start to 0.45 m
              past the goal, closed at both ends), goal 1.2–1.4 m ahead, ±0.1 m; one or
              two people (discs of 0.12 m) cross the lane through side doors (0.4 m wide)
              ahead of the robot, 0.2–1.0 m/s, either way, the lane's centre at 1–6 s, from
              1.3 m on one side to 1.3 m on the other, then leave; a crossing at t s lies
              0.36–0.66 m (centre) beyond where a robot that set off at 2 s at 0.1 m/s
              would be then, and at least 0.45 m ahead of the start
stopper       the same room without doors, goal 1.2–1.4 m ahead, ±0.1 m; at 2–6 s a person
              appears 0.55 m to one side of the lane and walks at 0.3–0.8 m/s into the
              lane, where it stops 0.03–0.25 m ahead of the robot's front edge (reckoned
              with the robot driving on at 0.1 m/s meanwhile), and stays
appearing     the same room without doors, goal 1.2–1.4 m ahead, ±0.1 m; a box (0.16 m)
              appears in the lane 0.05–0.25 m ahead of the robot's front edge, wherever
              the robot then is, at 2.5–6 s (after the first plan), and stays
closing       a room as ``appearing``'s but 2 m wide, crossed 0.55–0.75 m ahead by a wall
              with two doorways 0.36 m wide: one ahead (centre ±0.08 m), one 0.55 m to
              the side; goal 0.35–0.5 m past the wall, ±0.1 m. At 1.5–4 s the doorway
              ahead starts to close: a sliding door (a panel 0.4 m long, as thick as the
              wall) comes out of the wall at 0.2–0.4 m/s and stays shut; the way round
              is through the other doorway
shut          as ``closing`` without the side doorway: when the door has closed no way is
              left. Unreachable: success is stopping safely and saying so
============  ===========================================================================

The last five families move (issue #42): their :attr:`Layout.movers` are the people and
boxes of :mod:`clomp.runtime.backends._movers` (the scene holds the static obstacles only).

>>> a = make_layout("overtaking", seed=0, index=3)
>>> a.scene == make_layout("overtaking", seed=0, index=3).scene
True
>>> a.expect, a.scene.goal
('reach', (1.0, 0.0))
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clomp.planner.scenarios import Scene, Shape, parse_scenario
from clomp.runtime.backends.world import Mover, parse_movers

__all__ = ["ALL_FAMILIES", "FAMILIES", "GOAL_CLEARANCE", "MOVING_FAMILIES", "Layout", "make_layout", "shape_distance"]

GOAL_CLEARANCE = 0.2
"""Every obstacle stays at least this far (m) from the goal, so the robot's body fits there."""

_Raw = dict[str, Any]


@dataclass(frozen=True)
class Layout:
    """One drawn world: the scene, the parameters drawn, and what success means.

    ``expect`` is ``"reach"`` (success: truly at the goal) or ``"unreachable"`` (success:
    the robot stops by itself and says the goal cannot be reached).
    """

    family: str
    seed: int
    index: int
    scene: Scene
    params: dict[str, Any] = field(default_factory=dict, compare=False)
    expect: str = "reach"
    movers: tuple[Mover, ...] = ()


def _wall(a: tuple[float, float], b: tuple[float, float], t: float = 0.02) -> _Raw:
    return {"type": "wall", "from": [round(a[0], 4), round(a[1], 4)], "to": [round(b[0], 4), round(b[1], 4)], "thickness": t}


def _box(cx: float, cy: float, depth: float, width: float) -> _Raw:
    return {"type": "box", "center": [round(cx, 4), round(cy, 4)], "size": [round(depth, 4), round(width, 4)]}


def _overtaking(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    cx, cy = rng.uniform(0.35, 0.7), rng.uniform(-0.15, 0.15)
    width, depth = rng.uniform(0.1, 0.3), rng.uniform(0.1, 0.3)
    depth = min(depth, 2 * (0.8 - cx) - 0.001)
    obstacles = [_box(cx, cy, depth, width)]
    walls = bool(rng.random() < 0.5)
    half = rng.uniform(0.45, 0.6)
    if walls:
        # one passage beside the box at least 0.3 m wide
        widest = max(half - (cy + width / 2), half + (cy - width / 2))
        half += max(0.0, 0.3 - widest)
        obstacles += [_wall((-0.4, half), (1.5, half)), _wall((-0.4, -half), (1.5, -half))]
    p = {"x": cx, "y": cy, "width": width, "depth": depth, "walls": walls, "wall_half_width": half if walls else None}
    return {"goal": [1.0, 0.0], "obstacles": obstacles}, p


def _corridor(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    h = rng.uniform(0.22, 0.4)
    gx, gy = rng.uniform(0.9, 1.4), rng.uniform(-(h - 0.01 - GOAL_CLEARANCE), h - 0.01 - GOAL_CLEARANCE)
    th = rng.uniform(-0.15, 0.15)
    end = gx + 0.6
    obstacles = [_wall((-0.4, h), (end, h)), _wall((-0.4, -h), (end, -h))]
    p = {"width": 2 * h, "goal_x": gx, "goal_y": gy, "heading": th}
    return {"goal": [round(gx, 4), round(gy, 4)], "start": [0.0, 0.0, round(th, 4)], "obstacles": obstacles}, p


def _doorway(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    xw, dw, yd = rng.uniform(0.4, 0.65), rng.uniform(0.3, 0.5), rng.uniform(-0.35, 0.35)
    gx, gy = xw + rng.uniform(0.3, 0.55), rng.uniform(-0.2, 0.2)
    obstacles = [_wall((xw, -1.0), (xw, yd - dw / 2), 0.04), _wall((xw, yd + dw / 2), (xw, 1.0), 0.04)]
    p = {"wall_x": xw, "door_width": dw, "door_y": yd, "goal_x": gx, "goal_y": gy}
    return {"goal": [round(gx, 4), round(gy, 4)], "obstacles": obstacles}, p


def _slalom(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    n = int(rng.integers(2, 4))
    side = 1.0 if rng.random() < 0.5 else -1.0
    x = rng.uniform(0.35, 0.45)
    boxes = []
    for k in range(n):
        if k:
            x += rng.uniform(0.4, 0.55)
        boxes.append((x, side * rng.uniform(0.05, 0.15), 0.1, rng.uniform(0.2, 0.3)))
        side = -side
    gx = x + rng.uniform(0.35, 0.5)
    p = {"boxes": [list(b) for b in boxes], "goal_x": gx}
    return {"goal": [round(gx, 4), 0.0], "obstacles": [_box(*b) for b in boxes]}, p


def _clutter(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    n = int(rng.integers(3, 9))
    gx, gy = rng.uniform(1.0, 1.5), rng.uniform(-0.2, 0.2)
    posts: list[tuple[float, float, float]] = []
    tries = 0
    while len(posts) < n and tries < 2000:
        tries += 1
        x, y, r = rng.uniform(0.3, 1.3), rng.uniform(-0.5, 0.5), rng.uniform(0.03, 0.06)
        if math.hypot(x, y) < 0.3 or math.hypot(x - gx, y - gy) < 0.25 + r:
            continue
        if any(math.hypot(x - a, y - b) < 0.32 for a, b, _ in posts):
            continue
        posts.append((x, y, r))
    obstacles = [{"type": "circle", "center": [round(x, 4), round(y, 4)], "radius": round(r, 4)} for x, y, r in posts]
    p = {"posts": len(posts), "goal_x": gx, "goal_y": gy}
    return {"goal": [round(gx, 4), round(gy, 4)], "obstacles": obstacles}, p


def _u_trap(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    xb, a, yc = rng.uniform(0.55, 0.75), rng.uniform(0.2, 0.3), rng.uniform(-0.1, 0.1)
    arm = min(rng.uniform(0.25, 0.4), xb - 0.25)
    gx, gy = xb + rng.uniform(0.3, 0.45), yc + rng.uniform(-0.1, 0.1)
    obstacles = [
        _wall((xb, yc - a), (xb, yc + a)),
        _wall((xb - arm, yc + a), (xb, yc + a)),
        _wall((xb - arm, yc - a), (xb, yc - a)),
    ]
    p = {"back_x": xb, "inner_width": 2 * a, "arm": arm, "y": yc, "goal_x": gx, "goal_y": gy}
    return {"goal": [round(gx, 4), round(gy, 4)], "obstacles": obstacles}, p


def _cul_de_sac(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    h, xe = rng.uniform(0.25, 0.4), rng.uniform(0.6, 0.9)
    depth, half = rng.uniform(0.5, 0.8), rng.uniform(0.4, 0.6)
    gx, gy = xe + depth / 2, rng.uniform(-0.15, 0.15)
    far = xe + depth
    obstacles = [
        _wall((-0.4, h), (xe, h)),
        _wall((-0.4, -h), (xe, -h)),
        _wall((xe, -half), (xe, half)),
        _wall((far, -half), (far, half)),
        _wall((xe, half), (far, half)),
        _wall((xe, -half), (far, -half)),
    ]
    p = {"width": 2 * h, "end_x": xe, "room_depth": depth, "room_width": 2 * half, "goal_y": gy}
    return {"goal": [round(gx, 4), round(gy, 4)], "obstacles": obstacles}, p


def _room(gx: float, doors: list[float], half: float = 0.7, door: float = 0.4) -> list[_Raw]:
    """A closed room round the lane (the scan matcher needs walls), with side doors (gaps of
    ``door`` m in both side walls) centred at the x of ``doors``."""
    x0, x1 = -0.5, gx + 0.45
    cuts = sorted((max(x0, d - door / 2), min(x1, d + door / 2)) for d in doors)
    spans, a = [], x0
    for lo, hi in cuts:
        if lo > a:
            spans.append((a, lo))
        a = max(a, hi)
    if a < x1:
        spans.append((a, x1))
    walls = [_wall((lo, s * half), (hi, s * half)) for lo, hi in spans for s in (1.0, -1.0)]
    return walls + [_wall((x0, -half), (x0, half)), _wall((x1, -half), (x1, half))]


def _crossing(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    gx, gy = rng.uniform(1.2, 1.4), rng.uniform(-0.1, 0.1)
    people = []
    for _ in range(int(rng.integers(1, 3))):
        v, tc, gap = rng.uniform(0.2, 1.0), rng.uniform(1.0, 6.0), rng.uniform(0.15, 0.45)
        x = max(0.45, 0.09 + 0.1 * max(tc - 2.0, 0.0) + 0.12 + gap)
        side = 1.0 if rng.random() < 0.5 else -1.0
        half = 1.3 / v
        people.append({"kind": "person", "stays": False,
                       "path": [[round(tc - half, 4), round(x, 4), -1.3 * side], [round(tc + half, 4), round(x, 4), 1.3 * side]]})
    room = _room(gx, [p["path"][0][1] for p in people])  # type: ignore[index]
    return {"goal": [round(gx, 4), round(gy, 4)], "obstacles": room, "movers": people}, {"people": len(people), "goal_x": gx}


def _stopper(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    gx, gy = rng.uniform(1.2, 1.4), rng.uniform(-0.1, 0.1)
    ahead, v, ts = rng.uniform(0.03, 0.25), rng.uniform(0.3, 0.8), rng.uniform(2.0, 6.0)
    side = 1.0 if rng.random() < 0.5 else -1.0
    person = {"kind": "person", "appear": round(ts, 4), "ahead": round(ahead, 4), "lateral": 0.55 * side,
              "speed": round(v, 4)}
    p = {"ahead": ahead, "appear": ts, "speed": v, "side": side, "goal_x": gx}
    return {"goal": [round(gx, 4), round(gy, 4)], "obstacles": _room(gx, []), "movers": [person]}, p


def _appearing(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    gx, gy = rng.uniform(1.2, 1.4), rng.uniform(-0.1, 0.1)
    ahead, t = rng.uniform(0.05, 0.25), rng.uniform(2.5, 6.0)
    box = {"kind": "box", "appear": round(t, 4), "ahead": round(ahead, 4)}
    return ({"goal": [round(gx, 4), round(gy, 4)], "obstacles": _room(gx, []), "movers": [box]},
            {"ahead": ahead, "time": t, "goal_x": gx})


def _door_room(rng: np.random.Generator, side_door: bool) -> tuple[_Raw, dict[str, Any]]:
    """``closing`` (``side_door``) and ``shut``: a room crossed by a wall whose doorway ahead closes."""
    xw, ya, t0, v = rng.uniform(0.55, 0.75), rng.uniform(-0.08, 0.08), rng.uniform(1.5, 4.0), rng.uniform(0.2, 0.4)
    gx, gy = xw + rng.uniform(0.35, 0.5), rng.uniform(-0.1, 0.1)
    side = 1.0 if rng.random() < 0.5 else -1.0  # the door slides in from this side; the side doorway is on the other
    w, half = 0.36, 1.0  # wide enough to turn past the side doorway (a body turning sweeps 0.2 m round its axle)
    gaps = [(ya - w / 2, ya + w / 2)] + ([(-side * 0.55 - w / 2, -side * 0.55 + w / 2)] if side_door else [])
    cuts = sorted(gaps)
    spans, a = [], -half
    for lo, hi in cuts:
        spans.append((a, lo))
        a = hi
    spans.append((a, half))
    walls = _room(gx, [], half) + [_wall((xw, lo), (xw, hi)) for lo, hi in spans]
    hidden = ya + side * (w / 2 + 0.2)
    door = {"kind": "door", "size": [w + 0.04, 0.02],
            "path": [[round(t0, 4), round(xw, 4), round(hidden, 4)], [round(t0 + (w / 2 + 0.2) / v, 4), round(xw, 4), round(ya, 4)]]}
    p = {"wall_x": xw, "door_y": ya, "closes": t0, "speed": v, "side": side, "side_door": side_door, "goal_x": gx}
    return {"goal": [round(gx, 4), round(gy, 4)], "obstacles": walls, "movers": [door]}, p


def _closing(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    return _door_room(rng, True)


def _shut(rng: np.random.Generator) -> tuple[_Raw, dict[str, Any]]:
    return _door_room(rng, False)


_FAMILIES: dict[str, tuple[Callable[[np.random.Generator], tuple[_Raw, dict[str, Any]]], str, str]] = {
    "overtaking": (_overtaking, "reach", "one box between the robot and a goal 1 m ahead (the paper's scenario)"),
    "corridor": (_corridor, "reach", "a corridor of varying width, goal anywhere along it"),
    "doorway": (_doorway, "reach", "a wall across the way with a doorway somewhere in it"),
    "slalom": (_slalom, "reach", "two or three staggered boxes"),
    "clutter": (_clutter, "reach", "scattered round posts"),
    "u-trap": (_u_trap, "reach", "a U open towards the robot, the goal behind it"),
    "cul-de-sac": (_cul_de_sac, "unreachable", "a dead end; the goal is in a closed room beyond it"),
    "crossing": (_crossing, "reach", "people crossing the lane ahead"),
    "stopper": (_stopper, "reach", "a person walks in and stops ahead"),
    "appearing": (_appearing, "reach", "a box appears in the lane after the first plan"),
    "closing": (_closing, "reach", "the doorway ahead closes; another doorway is open"),
    "shut": (_shut, "unreachable", "the only doorway closes: no way is left"),
}

MOVING_FAMILIES: tuple[str, ...] = ("crossing", "stopper", "appearing", "closing", "shut")
"""The families whose worlds move (issue #42): their robots plan with WAIT and REVERSE."""
FAMILIES: tuple[str, ...] = tuple(f for f in _FAMILIES if f not in MOVING_FAMILIES)
"""The static families' names, in the order tables list them (what the gallery and the
behaviour digest iterate)."""
ALL_FAMILIES: tuple[str, ...] = FAMILIES + MOVING_FAMILIES
"""Every family :func:`make_layout` draws and ``clomp experiment`` runs: the static, then the moving."""


def shape_distance(shape: Shape, x: float, y: float) -> float:
    """Distance (m) from the point (x, y) to a shape (0 inside it).

    >>> shape_distance(Shape("circle", center=(1.0, 0.0), radius=0.5), 0.0, 0.0)
    0.5
    """
    if shape.contains(x, y):
        return 0.0
    if shape.kind == "circle":
        return math.hypot(x - shape.center[0], y - shape.center[1]) - shape.radius
    best = math.inf
    v = shape.vertices
    for k in range(len(v)):
        ax, ay = v[k]
        bx, by = v[(k + 1) % len(v)]
        ex, ey = bx - ax, by - ay
        u = max(0.0, min(1.0, ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey)))
        best = min(best, math.hypot(x - ax - u * ex, y - ay - u * ey))
    return best


def make_layout(family: str, seed: int, index: int = 0) -> Layout:
    """World number ``index`` of ``family`` for ``seed``; see the module docstring.

    >>> make_layout("cul-de-sac", 1).expect
    'unreachable'
    >>> make_layout("maze", 0)
    Traceback (most recent call last):
    ...
    ValueError: unknown layout family 'maze' (known: overtaking, corridor, doorway, slalom, clutter, u-trap, cul-de-sac, crossing, stopper, appearing, closing, shut)
    """
    if family not in _FAMILIES:
        raise ValueError(f"unknown layout family {family!r} (known: {', '.join(ALL_FAMILIES)})")
    for what, v in (("seed", seed), ("index", index)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
            raise ValueError(f"layout {what} must be a non-negative integer, got {v!r}")
    draw, expect, description = _FAMILIES[family]
    raw, params = draw(np.random.default_rng([int(seed), int(index)]))
    movers = parse_movers(raw.pop("movers", ()))
    raw = {"name": f"{family}-{seed}-{index}", "description": description, **raw}
    scene = parse_scenario(raw, raw["name"])
    return Layout(family, int(seed), int(index), scene, params, expect, movers)
