"""CognitiveMap: not hashable (it is mutable), the JSON format version is checked, and the
invariant checker walks the map once, not once per state."""

from __future__ import annotations

import pytest

from clomp.formal import CognitiveMap, MapError, check_map
from clomp.formal.lts import FORMAT_VERSION
from clomp.formal.model import Disturbance, Pose, State, TaskKind

G = Disturbance.goal(1.0, 0.0)


def _chain(n: int) -> CognitiveMap:
    m = CognitiveMap(goal=G)
    for i in range(n):
        m.add_state(State(i, TaskKind.STRAIGHT, G, None, Pose(0.1 * max(i - 1, 0), 0), Pose(0.1 * i, 0), cost=1.0 - i / n))
        if i:
            m.add_transition(i - 1, i)
    return m


def test_a_map_is_explicitly_unhashable_and_equality_still_works() -> None:
    a, b = _chain(3), _chain(3)
    assert a == b
    with pytest.raises(TypeError, match="unhashable"):
        hash(a)
    assert CognitiveMap.__hash__ is None


@pytest.mark.parametrize("version", [FORMAT_VERSION + 1, 0, "1", None, True])
def test_from_dict_rejects_another_format_version(version: object) -> None:
    data = _chain(2).to_dict()
    data["version"] = version
    with pytest.raises(MapError, match="format version"):
        CognitiveMap.from_dict(data)


def test_from_dict_reads_its_own_version() -> None:
    m = _chain(4)
    assert CognitiveMap.from_dict(m.to_dict()) == m


def test_check_map_computes_reachability_once(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = 0
    real = CognitiveMap.reachable

    def counting(self: CognitiveMap, source: int | None = None) -> set[int]:
        nonlocal calls
        calls += 1
        return real(self, source)

    monkeypatch.setattr(CognitiveMap, "reachable", counting)
    check_map(_chain(5))
    small, calls = calls, 0
    check_map(_chain(60))
    assert calls == small <= 3  # a few walks per check (invariant 1, the plan), not one per state
