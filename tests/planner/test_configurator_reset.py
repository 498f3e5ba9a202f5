"""The Configurator injects D_I through formal's one reset R (clomp.formal.supervisory.Reset.after)."""

from __future__ import annotations

import numpy as np
import pytest

from clomp.formal.supervisory import Reset, ResetUndefined
from clomp.planner import Configurator, load_scenario


def test_every_child_state_gets_its_d_i_from_formal_reset(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[int] = []
    real = Reset.after

    def spy(self, source):  # type: ignore[no-untyped-def]
        calls.append(source.ident)
        return real(self, source)

    monkeypatch.setattr(Reset, "after", spy)
    scene = load_scenario("overtaking")
    result = Configurator().plan(scene.scan(), scene.goal_in_robot_frame())
    assert len(calls) == len(result.map) - 1  # once per state grown, none for q0
    r = Reset(result.map)
    for t in result.map.transitions():
        assert result.map[t.target].d_i == r(t)


def test_the_configurator_stops_when_r_is_undefined(monkeypatch: pytest.MonkeyPatch) -> None:
    # R refusing is an error the Configurator does not paper over (and no assert does R's job)
    def refuse(self, source):  # type: ignore[no-untyped-def]
        raise ResetUndefined(f"R(q{source.ident}, ·) is undefined")

    monkeypatch.setattr(Reset, "after", refuse)
    with pytest.raises(ResetUndefined):
        Configurator().plan(np.zeros((0, 2)), (1.0, 0.0))
