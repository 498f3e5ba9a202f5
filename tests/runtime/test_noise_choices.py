"""Every runner that takes ``--noise`` offers exactly the presets of ``specs/noise_presets.json``:
one list, read there, so a preset added or renamed (as ``harsh-modelled`` was) reaches every
command at once."""

from __future__ import annotations

import argparse

from clomp.planner.noise import preset_names
from clomp.runtime.cli import build_parser
from clomp.runtime.experiment.groundtruth import NOISE_PRESETS


def _noise_choices(parser: argparse.ArgumentParser, path: str = "clomp") -> dict[str, list[str]]:
    found: dict[str, list[str]] = {}
    for action in parser._actions:
        if "--noise" in action.option_strings and action.choices is not None:
            found[path] = sorted(action.choices)
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.update(_noise_choices(sub, f"{path} {name}"))
    return found


def test_every_noise_option_offers_every_preset_and_no_other() -> None:
    found = _noise_choices(build_parser())
    assert {"clomp experiment", "clomp simulate", "clomp ros sim"} <= set(found), sorted(found)
    for command, choices in found.items():
        assert choices == preset_names(), command
    assert sorted(NOISE_PRESETS) == preset_names()
