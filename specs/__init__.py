"""clomp.specs — what is checked: scenario files, PCTL property files, noise presets, protocol notes.

Data only; located at run time through this package so that an installed clomp finds them.
The noise presets (``noise_presets.json``) are read here so that every layer (the
execution world in runtime, sampled rollouts in planner) takes the same numbers.

>>> sorted(noise_presets())
['harsh', 'ideal', 'paper']
>>> noise_preset("harsh")["latency"], noise_preset("paper", scale=2.0)["range_sd"]
(0.1, 0.01)
"""

from __future__ import annotations

if __name__ != "clomp.specs":  # the repository keeps specs/ at the top; it is installed only as clomp.specs
    raise ImportError(f"{__name__} is part of clomp: import clomp.specs, not {__name__}")

import json
import math
from pathlib import Path

__all__ = ["SPECS_DIR", "NOISE_FIELDS", "noise_presets", "noise_preset"]

SPECS_DIR = Path(__file__).resolve().parent

NOISE_FIELDS = ("range_sd", "angle_sd", "dropout", "wheel_sd", "wheel_bias", "drift", "slip", "latency",
                "rate_sd", "rate_bias", "rate_scale")


def noise_presets() -> dict[str, dict[str, float]]:
    """Every preset of ``specs/noise_presets.json``: name → {field: value} (SI units).

    Raises ValueError naming the preset and field when the file is malformed.
    """
    data = json.loads((SPECS_DIR / "noise_presets.json").read_text(encoding="utf-8"))
    out: dict[str, dict[str, float]] = {}
    for name, preset in data["presets"].items():
        values: dict[str, float] = {}
        for f in NOISE_FIELDS:
            v = preset.get(f)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"noise_presets.json: {name}.{f}: expected a finite number >= 0, got {v!r}")
            values[f] = float(v)
        if values["dropout"] >= 1:
            raise ValueError(f"noise_presets.json: {name}.dropout: must be below 1")
        out[name] = values
    return out


def noise_preset(name: str, scale: float = 1.0) -> dict[str, float]:
    """One preset with every term multiplied by ``scale`` (``dropout`` capped below 1).

    ValueError for an unknown name or a scale that is not a finite number >= 0.
    """
    presets = noise_presets()
    if name not in presets:
        raise ValueError(f"unknown noise preset {name!r} (known: {', '.join(sorted(presets))})")
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale) or scale < 0:
        raise ValueError(f"noise scale must be a finite number >= 0, got {scale!r}")
    values = {k: v * float(scale) for k, v in presets[name].items()}
    values["dropout"] = min(values["dropout"], 0.95)
    return values
