"""The physics step's reads of the body and its call of pymunk's step, without the Python
wrappers' overhead (issue #41).

The world takes about 10,000 physics steps a run; each read the body's pose and velocity
through pymunk's properties (a ``Vec2d`` built per read: about 7 µs of a position's 9)
and stepped the space through :meth:`pymunk.Space.step`, whose bookkeeping (bodies to
check, objects added or removed during a step, post-step callbacks) cost four times the
C step when there is none of it. These helpers ask chipmunk directly for the same
numbers: the same C functions the properties call, so the same floats, bit for bit. The
step takes the short way only when pymunk has nothing queued (a body just added, a
removal, a callback) and is not threaded; otherwise it is :meth:`pymunk.Space.step`
itself. Should a pymunk release rename what these reach into, they are the properties
and the method again (:data:`DIRECT` is then False).

>>> import pymunk
>>> b = pymunk.Body(1.0, 1.0); b.position = (0.5, -0.25); b.angle = 0.1
>>> position(b), angle(b)
((0.5, -0.25), 0.1)
"""

from __future__ import annotations

from typing import Any

import pymunk

__all__ = ["DIRECT", "angle", "position", "space_step", "velocity"]

try:
    from pymunk._chipmunk_cffi import lib as _lib

    _probe_space, _probe_body = pymunk.Space(), pymunk.Body(1.0, 1.0)
    DIRECT = all(hasattr(_probe_space, a) for a in ("_space", "_locked", "_bodies_to_check", "_add_later",
                                                    "_remove_later", "_post_step_callbacks", "_removed_shapes",
                                                    "threaded")) and hasattr(_probe_body, "_body")
    del _probe_space, _probe_body
except ImportError:  # pragma: no cover - a pymunk without its cffi module
    _lib, DIRECT = None, False


def position(body: pymunk.Body) -> tuple[float, float]:
    """``body.position`` as two floats (m)."""
    if DIRECT:
        v = _lib.cpBodyGetPosition(body._body)
        return v.x, v.y
    p = body.position  # pragma: no cover - the fallback
    return float(p.x), float(p.y)  # pragma: no cover


def angle(body: pymunk.Body) -> float:
    """``body.angle`` (rad)."""
    return float(_lib.cpBodyGetAngle(body._body)) if DIRECT else float(body.angle)


def velocity(body: pymunk.Body) -> tuple[float, float]:
    """``body.velocity`` as two floats (m/s)."""
    if DIRECT:
        v = _lib.cpBodyGetVelocity(body._body)
        return v.x, v.y
    vel = body.velocity  # pragma: no cover - the fallback
    return float(vel.x), float(vel.y)  # pragma: no cover


def space_step(space: pymunk.Space, dt: float) -> None:
    """``space.step(dt)``: chipmunk's step alone when pymunk has nothing queued around it."""
    s: Any = space
    if not DIRECT or s.threaded or s._bodies_to_check or s._add_later or s._remove_later or s._post_step_callbacks:
        space.step(dt)
        return
    try:
        s._locked = True
        _lib.cpSpaceStep(s._space, dt)
        s._removed_shapes.clear()
    finally:
        s._locked = False
    if s._add_later or s._remove_later or s._post_step_callbacks:  # pragma: no cover - queued by a callback
        _finish_step(s)


def _finish_step(s: Any) -> None:  # pragma: no cover - the world registers no collision callbacks
    """What :meth:`pymunk.Space.step` does after chipmunk's step: objects a callback queued."""
    s.add(*s._add_later)
    s._add_later.clear()
    removed = set()
    while s._remove_later:
        to_remove, _ = s._remove_later.popitem()
        if to_remove not in removed:
            removed.add(to_remove)
            s._remove(to_remove)
    for key in s._post_step_callbacks:
        s._post_step_callbacks[key](s)
    s._post_step_callbacks.clear()
