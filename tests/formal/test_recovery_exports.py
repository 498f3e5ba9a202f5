"""Maps with WAIT and REVERSE (issue #42), with free turns and with the authors' quarter turns
(``free_turns=False``), exported and model-checked: PRISM and Storm load the same model and
agree on every property of specs/properties/ (the PRISM language and the explicit files in
PRISM, the PRISM language and the DRN in Storm)."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from clomp.formal.crosscheck import cross_check
from clomp.formal.export import write_dot, write_drn, write_prism
from clomp.formal.model import TaskKind
from clomp.formal.prism import find_prism
from clomp.planner import Configurator
from clomp.planner.robot_model import RobotModel

pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")
pytestmark = pytest.mark.skipif(
    find_prism() is None, reason="PRISM not found: set CLOMP_PRISM or keep shared/tools/prism-*/ beside the repo"
)


def _seg(a, b, n=30):
    return np.c_[np.linspace(a[0], b[0], n), np.linspace(a[1], b[1], n)]


def _reverse_map(free_turns: bool):
    nook = np.vstack([_seg((0.14, -0.08), (0.14, 0.08), 9), _seg((0.0, 0.17), (0.3, 0.17)), _seg((0.0, -0.17), (0.3, -0.17))])
    return Configurator(RobotModel(free_turns=free_turns), recovery=True).plan(nook, (1.0, 0.0))


def _wait_map(free_turns: bool):
    person = np.array([[0.4 + 0.12 * math.cos(a), 0.12 * math.sin(a)] for a in np.linspace(2.0, 4.3, 15)])
    walls = np.vstack([_seg((-0.5, 0.7), (0.8, 0.7), 40), _seg((-0.5, -0.7), (0.8, -0.7), 40)])
    c = Configurator(RobotModel(free_turns=free_turns), recovery=True)
    c.transient = np.r_[np.ones(15, bool), np.zeros(80, bool)]
    return c.plan(np.vstack([person, walls]), (0.9, 0.0))


@pytest.mark.parametrize("free_turns", [True, False], ids=["free-turns", "quarter-turns"])
@pytest.mark.parametrize("make,label", [(_reverse_map, TaskKind.REVERSE), (_wait_map, TaskKind.WAIT)], ids=["reverse", "wait"])
def test_prism_and_storm_agree_on_maps_with_wait_and_reverse(make, label, free_turns):
    r = make(free_turns)
    assert label in {t.label for t in r.map.transitions()}
    assert r.steps[0].task is label
    for out in (write_prism, write_drn, write_dot):
        buf = io.StringIO()
        out(r.map, buf)
        assert label.value in buf.getvalue()
    for kind in ("mdp", "dtmc"):
        cc = cross_check(r.map, kind, title=f"{label.value} free_turns={free_turns}")
        assert cc.sizes_agree, {k: v[:2] for k, v in cc.loads.items()}
        assert not cc.disagreements(), cc.disagreements()
        assert len(cc.loads) == 4 and all(len(v[2]) == len(cc.names) > 0 for v in cc.loads.values())
