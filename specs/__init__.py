"""clomp.specs — what is checked: scenario files, PCTL property files, noise presets, protocol notes.

Data only; located at run time through this package so that an installed clomp finds them.
The noise presets (``noise_presets.json``) are read and checked once, by
:mod:`clomp.planner.noise` (``noise_presets()``, ``noise_preset(name, scale)``), so that every
layer (the execution world in runtime, sampled rollouts in planner) takes the same numbers.

>>> (SPECS_DIR / "noise_presets.json").is_file()
True
"""

from __future__ import annotations

if __name__ != "clomp.specs":  # the repository keeps specs/ at the top; it is installed only as clomp.specs
    raise ImportError(f"{__name__} is part of clomp: import clomp.specs, not {__name__}")

from pathlib import Path

__all__ = ["SPECS_DIR"]

SPECS_DIR = Path(__file__).resolve().parent
