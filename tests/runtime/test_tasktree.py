"""The paper's Fig. 3C (``clomp plan --figure``, ``clomp demo``'s task_tree.png): checked on the
drawn artists — the scan's points, the boxes, one label per state as in the map, the plan
thicker than the rest, collisions starred, the legend outside the data — not on pixels."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import clomp  # noqa: E402
from clomp.runtime.cli import main  # noqa: E402
from clomp.runtime.experiment.tasktree import draw_task_tree, plot_task_tree  # noqa: E402


@pytest.fixture(scope="module")
def overtaking():
    scene = clomp.load_scenario("overtaking")
    scan = scene.scan()
    return clomp.plan(scan, goal=scene.goal_in_robot_frame()), scan


@pytest.fixture
def axes():
    fig, ax = plt.subplots()
    yield ax
    plt.close(fig)


def test_every_scan_point_is_drawn(overtaking, axes):
    r, scan = overtaking
    art = draw_task_tree(axes, r, scan)
    assert np.array_equal(np.asarray(art.scan.get_offsets()), scan)
    assert len(art.boxes) == len(r.obstacles) > 0


def test_one_label_per_state_named_as_in_the_map(overtaking, axes):
    r, scan = overtaking
    draw_task_tree(axes, r, scan)
    labels = sorted(t.get_text() for t in axes.texts if re.fullmatch(r"q\d+", t.get_text()))
    assert labels == sorted(f"q{q.ident}" for q in r.map)


def test_the_plan_is_thicker_than_every_other_task(overtaking, axes):
    r, scan = overtaking
    art = draw_task_tree(axes, r, scan)
    planned = set(r.plan.states[1:])
    assert planned and len(r.map) > len(planned) + 1
    plan_widths = {art.tasks[i].get_linewidth() for i in planned}
    other_widths = {art.tasks[q.ident].get_linewidth() for q in r.map if q.ident not in r.plan.states}
    assert min(plan_widths) > max(other_widths)


def test_collisions_are_starred_one_per_interrupted_state(overtaking, axes):
    r, scan = overtaking
    art = draw_task_tree(axes, r, scan)
    interrupted = [q for q in r.map if q.interrupted]
    assert interrupted, "the overtaking map has interrupted states (the box in front)"
    assert art.collisions.get_marker() == "*" and len(art.collisions.get_xdata()) == len(interrupted)


def test_cli_figure_has_its_legend_outside_the_data(tmp_path: Path, monkeypatch):
    """``clomp plan --figure``: the file is written, and the legend it saved sits right of the axes."""
    seen = {}
    real_savefig = matplotlib.figure.Figure.savefig

    def spy(fig, *args, **kw):
        ax = fig.axes[0]
        fig.canvas.draw()
        seen["legend"] = ax.get_legend().get_window_extent()
        seen["axes"] = ax.get_window_extent()
        return real_savefig(fig, *args, **kw)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    out = tmp_path / "f.png"
    assert main(["plan", "--scenario", "overtaking", "--figure", str(out)]) == 1  # partial: the goal is in a shadow
    assert out.stat().st_size > 0
    assert seen["legend"].x0 >= seen["axes"].x1


def test_cli_figure_refuses_what_it_cannot_draw(tmp_path: Path, capsys):
    assert main(["plan", "--scenario", "overtaking", "--figure", str(tmp_path / "f.jpg")]) == 2
    assert "--figure" in capsys.readouterr().err
    scans = tmp_path / "scans"
    scans.mkdir()
    np.savetxt(scans / "a.dat", np.array([[0.5, 0.0]]))
    assert main(["plan", "--scan", str(scans), "--figure", str(tmp_path / "f.png")]) == 2
    assert "one plan" in capsys.readouterr().err
    assert not (tmp_path / "f.png").exists()


def test_plot_task_tree_writes_svg(overtaking, tmp_path: Path):
    r, scan = overtaking
    plot_task_tree(r, tmp_path / "t.svg", scan)
    assert (tmp_path / "t.svg").read_text(encoding="utf-8").count("<svg") == 1


def test_labels_do_not_overlap_where_states_crowd(overtaking):
    """Several states end at one pivot (turns in place): their labels are spread, none covers another."""
    r, scan = overtaking
    fig, ax = plt.subplots(figsize=(8, 6))
    try:
        art = draw_task_tree(ax, r, scan)
        fig.canvas.draw()
        boxes = [(i, t.get_window_extent()) for i, t in art.labels.items()]
        overlapping = [(a, b) for k, (a, ba) in enumerate(boxes) for b, bb in boxes[k + 1:] if ba.overlaps(bb)]
        assert overlapping == []
    finally:
        plt.close(fig)
