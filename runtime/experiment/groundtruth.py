"""The execution world the experiment runs in, and the ground truth it measures.

:func:`make_robot` gives a robot for one run: it implements :class:`~clomp.runtime.interface.Robot`,
keeps simulated time (``now``/``sleep``) and exposes the ground truth the experiment
measures — ``ground_truth_pose()`` (world frame) and ``contact_trace()``, one
``(time_s, penetration_m)`` sample per simulation tick in which the body touches an
obstacle. It uses the independent execution world's factory
(``clomp.runtime.backends.make_world_robot``, issue #8) when it is there — it is on main — and
otherwise the older simulated robot :class:`~clomp.runtime.backends.sim.SimRobot`, wrapped to report the same trace (its
penetration is how far the commanded motion of a tick would have pushed the body into
the obstacle before it was pushed back out).

Noise presets (``ideal``, ``paper``, ``harsh``) come from ``specs/noise_presets.json``
when the world reads them; for the fallback world ``paper`` is :class:`~clomp.runtime.backends.sim.
NoiseConfig`'s defaults (the scenario README's table), ``harsh`` every term ×5 and
``ideal`` none; ``noise_scale`` multiplies every term.

>>> from clomp.runtime.experiment.layouts import make_layout
>>> r = make_robot(make_layout("overtaking", 0).scene, noise="ideal", seed=0)
>>> r.set_wheel_speeds(0.1, 0.1); r.sleep(1.0); round(r.ground_truth_pose().x, 1), r.contact_trace()
(0.1, [])
"""

from __future__ import annotations

import importlib
import math
from dataclasses import fields
from typing import Any, Protocol

from clomp.formal.model import Pose
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene
from clomp.runtime.interface import Robot
from clomp.planner.noise import preset_names
from clomp.runtime.backends.sim import NoiseConfig, SimRobot

__all__ = ["NOISE_PRESETS", "WorldRobot", "make_robot", "sim_noise", "world_name"]

NOISE_PRESETS: tuple[str, ...] = tuple(preset_names())  # the presets of specs/noise_presets.json, read there (one list)


class WorldRobot(Robot, Protocol):
    """A robot in a simulated world with a clock and ground truth."""

    def now(self) -> float:
        """Simulated seconds since the start."""
        ...

    def sleep(self, seconds: float) -> None:
        """Let simulated time pass."""
        ...

    def ground_truth_pose(self) -> Pose:
        """The true pose, world frame."""
        ...

    def contact_trace(self) -> list[tuple[float, float]]:
        """(time_s, penetration_m) per tick in contact."""
        ...


def sim_noise(preset: str, scale: float = 1.0) -> NoiseConfig:
    """The fallback world's noise for a preset, every term × ``scale``.

    >>> sim_noise("harsh").wheel_sd
    0.1
    """
    if preset not in NOISE_PRESETS:
        raise ValueError(f"unknown noise preset {preset!r} (known: {', '.join(NOISE_PRESETS)})")
    if not (math.isfinite(scale) and scale >= 0):
        raise ValueError(f"noise scale must be a finite number >= 0, got {scale!r}")
    base = NoiseConfig.ideal() if preset == "ideal" else NoiseConfig()
    factor = scale * (5.0 if preset in ("harsh", "harsh-modelled", "unmodelled") else 1.0)
    values = {f.name: getattr(base, f.name) * factor for f in fields(NoiseConfig)}
    values["dropout"] = min(values["dropout"], 0.9)
    return NoiseConfig(**values)


class _TracedSimRobot(SimRobot):
    """:class:`SimRobot` reporting a contact trace and the ground-truth pose."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._trace: list[tuple[float, float]] = []
        super().__init__(*args, **kwargs)

    def _move_to(self, x: float, y: float, th: float) -> None:
        hits = self._overlap(x, y, th)
        if hits:
            depth = 0.0
            for h in hits:
                pts = h.contact_point_set.points
                if pts:
                    depth = max(depth, max(-p.distance for p in pts))
            self._trace.append((round(self._t + self.substep, 9), max(0.0, float(depth))))
        super()._move_to(x, y, th)

    def ground_truth_pose(self) -> Pose:
        return self.pose

    def contact_trace(self) -> list[tuple[float, float]]:
        return list(self._trace)


def _factory() -> Any:
    try:
        mod = importlib.import_module("clomp.runtime.backends")
    except ImportError:
        return None
    return getattr(mod, "make_world_robot", None)


def world_name() -> str:
    """Which world :func:`make_robot` builds: ``"world"`` (#8's execution world) or ``"sim"``."""
    return "world" if _factory() is not None else "sim"


def make_robot(scene: Scene, *, noise: str = "paper", noise_scale: float = 1.0, seed: int = 0,
               model: RobotModel | None = None, gyro: bool = True, movers: tuple[Any, ...] = ()) -> WorldRobot:
    """A fresh robot at the scene's start; see the module docstring. ``gyro`` False takes the
    execution world's rate gyro off (the paper's robot; the fallback world has none). ``movers``:
    bodies that move or appear (:mod:`clomp.runtime.backends._movers`; the execution world only)."""
    if noise not in NOISE_PRESETS:
        raise ValueError(f"unknown noise preset {noise!r} (known: {', '.join(NOISE_PRESETS)})")
    factory = _factory()
    if factory is not None:
        extra = {"movers": movers} if movers else {}
        robot: WorldRobot = factory(scene, noise=noise, noise_scale=noise_scale, seed=seed, robot=model, gyro=gyro, **extra)
        return robot
    if movers:
        raise ValueError("moving bodies need the execution world (clomp.runtime.backends.make_world_robot)")
    return _TracedSimRobot(scene, model, noise=sim_noise(noise, noise_scale), seed=seed)
