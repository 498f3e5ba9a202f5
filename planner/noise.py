"""Rollout noise: the terms of a noise preset that concern one task's rollout.

The presets live in ``specs/noise_presets.json`` (``clomp.specs.noise_presets()``), the ones
the execution world uses; :class:`RolloutNoise` keeps the terms a rollout of
:mod:`clomp.planner.probabilistic` applies (ranges, beam angles, dropout, wheel error, bias,
drift, slip, a turn's angle), not ``latency``.

>>> RolloutNoise.preset("harsh").range_sd
0.025
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

__all__ = ["ALARM_DEVIATIONS", "NoiseError", "RolloutNoise", "preset_names"]

ALARM_DEVIATIONS = 3.0
"""The supervisor's noise allowance in range-noise standard deviations (less the planner's
clearance): one figure for the runtime's ``Alarms`` and the rollouts' ``HazardRule.supervisor``."""

_SIGNED = frozenset({"turn_mean", "straight_mean"})
"""The terms that are means (may be negative), not spreads."""

_PRESETS_FILE = Path(__file__).resolve().parents[1] / "specs" / "noise_presets.json"


class NoiseError(ValueError):
    """An unknown noise preset or a bad noise number."""


@dataclass(frozen=True)
class RolloutNoise:
    """The noise of one sampled rollout world (SI units; the runtime's noise fields).

    ``range_sd``: sd of the LiDAR range error (m); ``angle_sd``: sd of a beam's
    direction (rad); ``dropout``: probability that a return is lost; ``wheel_sd``:
    relative sd of each wheel's speed error per tick; ``wheel_bias``: relative sd of a
    per-run wheel bias; ``drift``: sd (rad/s) of a per-run heading drift while the
    wheels turn; ``slip``: scale of the speed each wheel loses per tick, |N(0, slip)|;
    ``turn_sd``: relative sd of the angle a turn actually makes (the robot ends a turn
    on its own heading estimate; default ``wheel_bias + wheel_sd``, the wheels' relative
    error); ``turn_mean``: the mean of that relative error (a closed loop that ends its
    turns late turns too far on average); ``straight_sd`` and ``straight_mean``: the
    same for the length a straight truly drives against the length it was told (the
    robot ends a straight on its estimate too). The last four describe a closed loop,
    not the world: the presets leave them at 0 (``turn_sd`` at its default), and
    :func:`clomp.planner.robust.closed_loop_noise` sets them as measured. Defaults: the
    ``paper`` preset of ``specs/noise_presets.json``.

    >>> RolloutNoise().turn_error_sd
    0.025
    """

    range_sd: float = 0.005
    dropout: float = 0.02
    wheel_sd: float = 0.02
    wheel_bias: float = 0.005
    drift: float = 0.002
    angle_sd: float = 0.002
    slip: float = 0.01
    turn_sd: float | None = None
    turn_mean: float = 0.0
    straight_sd: float = 0.0
    straight_mean: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None and f.name == "turn_sd":
                continue
            signed = f.name in _SIGNED
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (v < 0 and not signed):
                raise NoiseError(f"noise.{f.name}: expected a finite number{'' if signed else ' >= 0'}, got {v!r}")
            if signed and abs(v) >= 0.5:
                raise NoiseError(f"noise.{f.name}: a mean relative error must lie within (-0.5, 0.5), got {v!r}")
        if self.dropout >= 1:
            raise NoiseError(f"noise.dropout: must be below 1, got {self.dropout!r}")

    @property
    def turn_error_sd(self) -> float:
        """The relative sd of a turn's angle."""
        return self.wheel_bias + self.wheel_sd if self.turn_sd is None else self.turn_sd

    @classmethod
    def preset(cls, name: str, path: str | Path | None = None) -> "RolloutNoise":
        """The preset ``name`` from ``specs/noise_presets.json`` (or ``path``); without
        the file, ``paper`` and ``ideal`` are known. Keys the sampler does not use are
        ignored (a preset may describe more than rollouts need, e.g. ``latency``)."""
        presets = _read_presets(path)
        if name not in presets:
            where = str(path or _PRESETS_FILE)
            raise NoiseError(f"unknown noise preset {name!r} in {where}: expected one of {', '.join(sorted(presets))}")
        known = {f.name for f in fields(cls)}
        data = presets[name]
        try:
            return cls(**{k: v for k, v in data.items() if k in known})
        except TypeError as exc:
            raise NoiseError(f"noise preset {name!r}: {exc}") from None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return asdict(self)


def _read_presets(path: str | Path | None = None) -> dict[str, dict[str, Any]]:
    if path is None:
        from clomp import specs
        try:
            return {k: dict(v) for k, v in specs.noise_presets().items()}
        except (OSError, KeyError, ValueError, json.JSONDecodeError) as exc:
            raise NoiseError(f"{_PRESETS_FILE}: cannot read noise presets: {exc}") from None
    p = Path(path)
    if not p.is_file():
        raise NoiseError(f"{p}: no such noise preset file")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise NoiseError(f"{p}: cannot read noise presets: {exc}") from None
    if isinstance(data, dict) and isinstance(data.get("presets"), dict):
        data = data["presets"]
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise NoiseError(f"{p}: expected an object of presets, each an object of numbers")
    return {str(k): dict(v) for k, v in data.items()}


def preset_names() -> list[str]:
    """The noise presets known (from the file, or the built-in ones)."""
    return sorted(_read_presets())
