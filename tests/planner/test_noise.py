"""Noise and body, one of each (issue #37): every noise class checks its numbers with the one
validator, the presets are read once, and the world's body is the planner's Body type."""

from __future__ import annotations

import math
from dataclasses import fields

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.planner import noise as noise_module
from clomp.planner.noise import NoiseError, NoiseTerms, RolloutNoise, check_noise
from clomp.planner.robot_model import Body, RobotModel
from clomp.planner.scenarios import ScenarioError, load_scenario, parse_scenario
from clomp.runtime.backends.sim import NoiseConfig, scenario_noise
from clomp.runtime.backends.world import BodySpec, WorldNoise, make_world_robot

CLASSES = (NoiseTerms, RolloutNoise, NoiseConfig)
BAD = (-0.1, math.nan, math.inf, True, "0.1")


@pytest.mark.parametrize("cls", CLASSES)
@pytest.mark.parametrize("bad", BAD)
def test_every_noise_class_refuses_a_bad_number_naming_the_field(cls, bad):
    for f in fields(cls):
        if f.name in ("turn_mean", "straight_mean") and bad == -0.1:
            continue  # a mean may be negative
        with pytest.raises(NoiseError, match=rf"^noise\.{f.name}: "):
            cls(**{f.name: bad})


@settings(max_examples=60, deadline=None)
@given(st.dictionaries(st.sampled_from(noise_module.NOISE_FIELDS), st.floats(0.0, 0.99), min_size=1))
def test_the_classes_agree_on_what_is_a_good_number(values):
    check_noise(values)
    NoiseTerms(**values)
    RolloutNoise(**{k: v for k, v in values.items() if k in {f.name for f in fields(RolloutNoise)}})
    NoiseConfig(**{k: v for k, v in values.items() if k in {f.name for f in fields(NoiseConfig)}})


def test_dropout_must_stay_below_one_everywhere():
    for cls in CLASSES:
        with pytest.raises(NoiseError, match="dropout: must be below 1"):
            cls(dropout=1.0)


def test_a_scene_files_noise_is_laid_over_the_same_way_for_the_world_and_the_simulator():
    scene = parse_scenario({"goal": [1.0, 0.0], "noise": {"range_sd": 0.01, "dropout": 0.0}}, "n")
    assert WorldNoise.for_scene(scene).range_sd == 0.01 == scenario_noise(scene).range_sd
    assert WorldNoise.for_scene(scene).wheel_sd == NoiseTerms.preset("paper").wheel_sd
    bad = parse_scenario({"goal": [1.0, 0.0], "noise": {"slip": -1}}, "n")
    with pytest.raises(ScenarioError, match=r"^n\.noise\.slip: expected a finite number >= 0"):
        WorldNoise.for_scene(bad)


def test_the_presets_are_read_once(monkeypatch):
    noise_module._presets.cache_clear()
    reads = []
    real = type(noise_module._PRESETS_FILE).read_text

    def counting(path, *args, **kwargs):
        reads.append(path)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(type(noise_module._PRESETS_FILE), "read_text", counting)
    for _ in range(3):
        NoiseTerms.preset("harsh")
        RolloutNoise.preset("paper")
        noise_module.noise_presets()
    assert reads == [noise_module._PRESETS_FILE]
    harsh = noise_module.noise_presets()["harsh"]
    harsh["latency"] = 99.0  # a caller's copy: the presets stay as read
    assert NoiseTerms.preset("harsh").latency == 0.1


def test_body_dimensions_are_declared_once_and_checked_alike():
    assert [f.name for f in fields(Body)] == [f.name for f in fields(RobotModel)][:4] == [f.name for f in fields(BodySpec)][:4]
    for cls in (Body, RobotModel, BodySpec):
        with pytest.raises(ValueError, match=rf"{cls.__name__}\.width must be a positive finite number"):
            cls(width=-0.1)
        with pytest.raises(ValueError, match="front_offset must be smaller"):
            cls(front_offset=0.3)
    with pytest.raises(ValueError, match=r"BodySpec\.mass"):
        BodySpec(mass=0.0)
    assert RobotModel(clearance=0.0).clearance == 0.0 and RobotModel(step_length=None).step_length is None


def test_the_world_takes_its_body_from_the_model_unless_told_otherwise():
    model = RobotModel(width=0.2, max_speed=0.25, straight_speed=0.1)
    w = make_world_robot(load_scenario("open"), "ideal", robot=model)
    assert w.body.body == model.body and w.body.max_wheel_speed == 0.25
    # a world body that differs from the planner's belief (model mismatch): another Body
    other = make_world_robot(load_scenario("open"), "ideal", robot=model, body=BodySpec(width=0.16))
    assert other.body.width == 0.16 and isinstance(other.body, Body)


def test_the_unmodelled_terms_are_named_validated_and_on_in_their_own_preset_only():
    """The execution world's error sources the estimator does not model (issue #36) are
    preset terms like any other: checked by the one validator, documented in the presets
    file, 0 in ``ideal``, ``paper`` and ``harsh-modelled``, on in ``harsh`` (and
    ``unmodelled``, its old name), scaled with the rest."""
    import json

    from clomp.specs import SPECS_DIR

    doc = json.loads((SPECS_DIR / "noise_presets.json").read_text())["fields"]
    for name in noise_module.UNMODELLED_FIELDS:
        assert name in noise_module.NOISE_FIELDS and doc[name]["unit"] and doc[name]["meaning"]
        with pytest.raises(NoiseError, match=rf"^noise\.{name}: "):
            NoiseTerms(**{name: -1.0})
        assert getattr(NoiseTerms.preset("paper"), name) == 0.0 == getattr(NoiseTerms.preset("ideal"), name)
        assert getattr(NoiseTerms.preset("harsh-modelled"), name) == 0.0
        assert getattr(NoiseTerms.preset("harsh"), name) > 0.0
        assert getattr(NoiseTerms.preset("unmodelled"), name) == getattr(NoiseTerms.preset("harsh"), name)
        assert getattr(NoiseTerms.preset("harsh", 2.0), name) == pytest.approx(2 * getattr(NoiseTerms.preset("harsh"), name))
