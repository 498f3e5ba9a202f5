"""Noise: the one validated type for the terms of a noise preset, the presets, the one validator.

The presets live in ``specs/noise_presets.json`` and are read once, here
(:func:`noise_presets`, :func:`noise_preset`). Every noise number of clomp is checked by
:func:`check_noise` (finite, >= 0 unless it is a mean, ``dropout`` below 1; the error names
the field), whichever class holds it:

- :class:`NoiseTerms`: every term of a preset; the execution world drives with these
  (``clomp.runtime.backends.world.WorldNoise`` is this type), among them the error
  sources the estimator does not model (:data:`UNMODELLED_FIELDS`, on in ``harsh`` (and its
  old name ``unmodelled``), off in ``harsh-modelled``, the ``harsh`` of before session 5);
- :class:`RolloutNoise`: the terms a rollout of :mod:`clomp.planner.probabilistic` applies
  (ranges, beam angles, dropout, wheel error, bias, drift, slip, a turn's angle), not
  ``latency`` nor the gyro's;
- ``clomp.runtime.backends.sim.NoiseConfig``: the five terms the older simulator knows.

>>> RolloutNoise.preset("harsh").range_sd, NoiseTerms.preset("harsh").latency
(0.025, 0.1)
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Collection, Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, TypeVar

from clomp.specs import SPECS_DIR

__all__ = ["ALARM_DEVIATIONS", "NOISE_FIELDS", "UNMODELLED_FIELDS", "NoiseError", "NoiseTerms", "RolloutNoise", "check_noise",
           "noise_from_scene", "noise_preset", "noise_presets", "preset_names"]

ALARM_DEVIATIONS = 3.0
"""The supervisor's noise allowance in range-noise standard deviations (less the planner's
clearance): one figure for the runtime's ``Alarms`` and the rollouts' ``HazardRule.supervisor``."""

_SIGNED = frozenset({"turn_mean", "straight_mean"})
"""The terms that are means (may be negative), not spreads."""

_PRESETS_FILE = SPECS_DIR / "noise_presets.json"

_N = TypeVar("_N")


class NoiseError(ValueError):
    """An unknown noise preset or a bad noise number.

    >>> issubclass(NoiseError, ValueError)
    True
    """


def check_noise(values: Mapping[str, Any], where: str = "noise", *, signed: Collection[str] = (),
                optional: Collection[str] = ()) -> None:
    """The one check of noise numbers: each a finite number >= 0 (a name in ``signed`` is a
    mean relative error: any sign, within (-0.5, 0.5); one in ``optional`` may be None) and
    ``dropout`` below 1. NoiseError ``"{where}.{field}: ..."`` naming the first bad field.

    >>> check_noise({"range_sd": 0.01, "dropout": 0.5})
    >>> check_noise({"wheel_sd": -1})
    Traceback (most recent call last):
    ...
    clomp.planner.noise.NoiseError: noise.wheel_sd: expected a finite number >= 0, got -1
    """
    for name, v in values.items():
        if v is None and name in optional:
            continue
        mean = name in signed
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (v < 0 and not mean):
            raise NoiseError(f"{where}.{name}: expected a finite number{'' if mean else ' >= 0'}, got {v!r}")
        if mean and abs(v) >= 0.5:
            raise NoiseError(f"{where}.{name}: a mean relative error must lie within (-0.5, 0.5), got {v!r}")
    if values.get("dropout", 0.0) >= 1:
        raise NoiseError(f"{where}.dropout: must be below 1, got {values['dropout']!r}")


def noise_from_scene(cls: type[_N], raw: Any, where: str, base: Mapping[str, Any] | None = None) -> _N:
    """``cls`` (a noise dataclass) from ``base`` with a scene file's ``noise`` object ``raw``
    laid over it (each key replaces that term; the class's defaults where neither says);
    ScenarioError naming the field when a value is bad or unknown.

    >>> noise_from_scene(RolloutNoise, {"range_sd": 0.0}, "s.noise").range_sd
    0.0
    >>> noise_from_scene(RolloutNoise, {"wobble": 1}, "s.noise")
    Traceback (most recent call last):
    ...
    clomp.planner.scenarios.ScenarioError: s.noise.wobble: unknown noise setting (known: angle_sd, ...)
    """
    from clomp.planner.scenarios import ScenarioError

    if not isinstance(raw, Mapping):
        raise ScenarioError(f"{where}: expected an object, got {raw!r}")
    known = sorted(f.name for f in fields(cls))  # type: ignore[arg-type]
    for key in raw:
        if key not in known:
            raise ScenarioError(f"{where}.{key}: unknown noise setting (known: {', '.join(known)})")
    try:
        return cls(**{**(base or {}), **raw})
    except NoiseError as exc:
        name, _, why = str(exc).partition(":")
        raise ScenarioError(f"{where}.{name.removeprefix('noise.')}:{why}") from None


@dataclass(frozen=True)
class NoiseTerms:
    """Every term of a noise preset (SI units; ``specs/noise_presets.json`` says what each
    means), validated; all 0 by default (the ``ideal`` preset). The execution world drives
    with these.

    >>> NoiseTerms.preset("harsh").latency
    0.1
    >>> NoiseTerms.preset("paper", scale=0.0) == NoiseTerms.preset("ideal")
    True
    """

    range_sd: float = 0.0
    angle_sd: float = 0.0
    dropout: float = 0.0
    wheel_sd: float = 0.0
    wheel_bias: float = 0.0
    drift: float = 0.0
    slip: float = 0.0
    latency: float = 0.0
    rate_sd: float = 0.0
    rate_bias: float = 0.0
    rate_scale: float = 0.0
    # the terms the estimator does not model (issue #36): 0 in ``ideal``, ``paper`` and ``harsh-modelled``, on in ``harsh``
    bias_walk: float = 0.0
    """Random walk of each wheel's speed bias (relative, per √s; a bias that changes during a
    run: battery sag, tyre temperature, another floor)."""
    slip_rate: float = 0.0
    """Slip events per second of driving (1/s): the wheels spin without moving the body."""
    slip_duration: float = 0.0
    """How long a slip event lasts (s): a wheel over a cable, a wet patch, a ridge."""
    lidar_x: float = 0.0
    """The LiDAR's mount ahead of the rotation centre (m): its rays start there."""
    far_range: float = 0.0
    """How far beyond the planning horizon the LiDAR returns (m): an A1 sees 12 m."""
    rate_asymmetry: float = 0.0
    """Relative sd of the gyro's scale difference between turning counter-clockwise and
    clockwise, drawn once per run (a MEMS gyro's scale asymmetry: one gain fits neither)."""
    push_rate: float = 0.0
    """External pushes per second (1/s), at random (seeded) times: a kick, a bump, a person."""
    push_size: float = 0.0
    """How far a push slides the body (m): uniform in 0.5–1.5 times this, in a random direction."""

    def __post_init__(self) -> None:
        check_noise(asdict(self))

    @classmethod
    def preset(cls, name: str, scale: float = 1.0) -> "NoiseTerms":
        """A named preset (``ideal``, ``paper``, ``harsh``, ``harsh-modelled``) with every term × ``scale``."""
        return cls(**noise_preset(name, scale))

    def to_dict(self) -> dict[str, float]:
        """JSON-ready form."""
        return asdict(self)

    @classmethod
    def for_scene(cls, scene: Any, preset: str = "paper", scale: float = 1.0) -> "NoiseTerms":
        """A preset with the scene file's ``noise`` object laid over it (each key replaces
        that term); ScenarioError naming the field when a value is bad or unknown."""
        base = cls.preset(preset, scale).to_dict()
        raw = scene.raw.get("noise")
        return cls(**base) if raw is None else noise_from_scene(cls, raw, f"{scene.name}.noise", base)


NOISE_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(NoiseTerms))
"""The terms every preset gives, in the file's order."""

UNMODELLED_FIELDS: tuple[str, ...] = ("bias_walk", "slip_rate", "slip_duration", "lidar_x", "far_range",
                                      "rate_asymmetry", "push_rate", "push_size")
"""The execution world's error sources the estimator does not model (issue #36): 0 in
``ideal``, ``paper`` and ``harsh-modelled``, on in ``harsh`` (and ``unmodelled``, its old name).

>>> set(UNMODELLED_FIELDS) <= set(NOISE_FIELDS), NoiseTerms.preset("paper").push_rate
(True, 0.0)
"""


def _load(path: Path) -> dict[str, dict[str, Any]]:
    """A presets file's presets, name → {field: value} as written (unchecked); NoiseError
    when it is missing or not an object of objects (``{"presets": …}`` or the presets alone)."""
    if not path.is_file():
        raise NoiseError(f"{path}: no such noise preset file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise NoiseError(f"{path}: cannot read noise presets: {exc}") from None
    if isinstance(data, dict) and isinstance(data.get("presets"), dict):
        data = data["presets"]
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise NoiseError(f"{path}: expected an object of presets, each an object of numbers")
    return {str(k): dict(v) for k, v in data.items()}


@functools.lru_cache(maxsize=1)
def _presets() -> dict[str, NoiseTerms]:
    """The presets of ``specs/noise_presets.json``, read and checked once (every term given)."""
    out: dict[str, NoiseTerms] = {}
    for name, preset in _load(_PRESETS_FILE).items():
        values: dict[str, Any] = {f: preset.get(f) for f in NOISE_FIELDS}
        check_noise(values, f"noise_presets.json: {name}")
        out[name] = NoiseTerms(**{k: float(v) for k, v in values.items()})
    return out


def noise_presets() -> dict[str, dict[str, float]]:
    """Every preset of ``specs/noise_presets.json``: name → {field: value} (SI units).

    Raises ValueError naming the preset and field when the file is malformed.

    >>> sorted(noise_presets())
    ['harsh', 'harsh-modelled', 'ideal', 'paper', 'unmodelled']
    """
    return {name: terms.to_dict() for name, terms in _presets().items()}


def noise_preset(name: str, scale: float = 1.0) -> dict[str, float]:
    """One preset with every term multiplied by ``scale`` (``dropout`` capped below 1).

    ValueError for an unknown name or a scale that is not a finite number >= 0.

    >>> noise_preset("harsh")["latency"], noise_preset("paper", scale=2.0)["range_sd"]
    (0.1, 0.01)
    """
    presets = _presets()
    if name not in presets:
        raise NoiseError(f"unknown noise preset {name!r} (known: {', '.join(sorted(presets))})")
    check_noise({"scale": scale})
    values = {k: v * float(scale) for k, v in presets[name].to_dict().items()}
    values["dropout"] = min(values["dropout"], 0.95)
    return values


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
        check_noise(asdict(self), signed=_SIGNED, optional=("turn_sd",))

    @property
    def turn_error_sd(self) -> float:
        """The relative sd of a turn's angle."""
        return self.wheel_bias + self.wheel_sd if self.turn_sd is None else self.turn_sd

    @classmethod
    def preset(cls, name: str, path: str | Path | None = None) -> "RolloutNoise":
        """The preset ``name`` from ``specs/noise_presets.json`` (or the file ``path``; a
        term it leaves out keeps its default). Keys the sampler does not use are ignored (a
        preset may describe more than rollouts need, e.g. ``latency``)."""
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
    return noise_presets() if path is None else _load(Path(path))


def preset_names() -> list[str]:
    """The noise presets of ``specs/noise_presets.json``.

    >>> preset_names()
    ['harsh', 'harsh-modelled', 'ideal', 'paper', 'unmodelled']
    """
    return sorted(_read_presets())
