"""What :meth:`Doubt.seen` judged over a whole run, for the slow tests of known pushes.

:func:`spy_seen` wraps the method for the test's duration and returns the list it fills with
``(time, moved)``: each revolution judged and whether it said the robot stands elsewhere.
"""

from __future__ import annotations

import pytest

from clomp.runtime.estimation.doubt import Doubt

__all__ = ["spy_seen"]


def spy_seen(monkeypatch: pytest.MonkeyPatch) -> list[tuple[float, bool]]:
    """Record every verdict of :meth:`Doubt.seen` until the test ends (``monkeypatch`` undoes it)."""
    judged: list[tuple[float, bool]] = []
    seen = Doubt.seen

    def spy(self: Doubt, through: int, both: int, t: float, along: tuple[tuple[int, int], ...] = (),
            nearer: tuple[float, float] = (0.0, 0.0)) -> tuple[bool, bool]:
        out = seen(self, through, both, t, along, nearer)
        judged.append((t, out[1]))
        return out

    monkeypatch.setattr(Doubt, "seen", spy)
    return judged
