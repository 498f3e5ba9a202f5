"""The DOT pictures (``clomp export -f dot|svg``, ``clomp demo``'s cognitive_map.svg and supervisor.dot):
a legend, one node per state with its pose, a layout that fits a page, and a state's many
self-loops folded into one labelled loop."""

from __future__ import annotations

import io
import re
import shutil
import subprocess

import pytest

import clomp
from clomp.formal.export import write_dot
from clomp.formal.dot_picture import PAGE
from clomp.runtime.supervision.states import TERMINAL, state_machine_dot


@pytest.fixture(scope="module")
def overtaking_dot() -> tuple[object, str]:
    scene = clomp.load_scenario("overtaking")
    r = clomp.plan(scene.scan(), goal=(0.8, -0.3))  # a goal beside the box, seen: a map with goal states
    buf = io.StringIO()
    write_dot(r.map, buf)
    return r, buf.getvalue()


def test_one_node_per_state_with_its_pose(overtaking_dot):
    r, dot = overtaking_dot
    nodes = re.findall(r'^\s*(\d+) \[label="q(\d+) \w+\\n[^"]*\\n\(([-\d.]+), ([-\d.]+)\) m  (-?\d+)°"', dot, re.M)
    assert sorted(int(q) for _, q, *_ in nodes) == sorted(s.ident for s in r.map)
    for _, q, x, y, _deg in nodes:
        end = r.map[int(q)].end
        assert (float(x), float(y)) == (round(end.x, 2) + 0.0, round(end.y, 2) + 0.0)


def test_the_map_has_a_legend_naming_its_marks(overtaking_dot):
    _, dot = overtaking_dot
    legend = [line for line in dot.splitlines() if line.strip().startswith("legend [")]
    assert len(legend) == 1
    for mark in ("bold arrow", "double border", "red octagon", "green fill", "φ", "stay"):
        assert mark in legend[0], mark


def test_the_drawing_is_scaled_to_a_page(overtaking_dot):
    _, dot = overtaking_dot
    assert f'size="{PAGE[0]:g},{PAGE[1]:g}"' in dot


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz is not installed")
def test_the_rendered_map_fits_the_page(overtaking_dot):
    _, dot = overtaking_dot
    svg = subprocess.run(["dot", "-Tsvg"], input=dot, capture_output=True, text=True, timeout=60, check=True).stdout
    w, h = (float(v) for v in re.search(r'<svg width="([\d.]+)pt" height="([\d.]+)pt"', svg).groups())
    assert w <= PAGE[0] * 72 + 1 and h <= PAGE[1] * 72 + 1


def test_supervisor_terminal_states_have_one_labelled_loop_each():
    dot = state_machine_dot()
    names = dict(re.findall(r'^\s*(\d+) \[label="(\w+)"', dot, re.M))
    loops: dict[str, list[str]] = {}
    for k, label in re.findall(r"^\s*(\d+) -> \1 \[label=\"([^\"]*)\"", dot, re.M):
        loops.setdefault(names[k], []).append(label)
    for s in TERMINAL:
        assert loops.get(s.value) == ["ignores 7 events"], (s, loops.get(s.value))
    assert loops["EXECUTING"] == ["next_task"]
    legend = next(line for line in dot.splitlines() if line.strip().startswith("legend ["))
    for ev in ("no_plan", "at_goal", "goal_unconfirmed", "plan_short", "disagree", "fault"):
        assert ev in legend
