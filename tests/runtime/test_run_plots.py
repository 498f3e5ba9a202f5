"""Trajectory figures (``clomp simulate``, ``clomp demo``, ``clomp experiment``): checked on the drawn
artists — the scan points, direction/time marks, the legend outside the data, the outcome in
words that match the run (an honest stop is never "failed") — not on pixels."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from clomp.planner import load_scenario  # noqa: E402
from clomp.runtime.cli import main  # noqa: E402
from clomp.runtime.experiment.plots import RunTrace, draw_run, outcome_words, run_figure  # noqa: E402
from clomp.runtime.experiment.report import record_trace  # noqa: E402
from clomp.runtime.supervision.states import TERMINAL  # noqa: E402

#: the words each end state must say (TIMEOUT: the baselines' time limit)
WORDS = {
    "GOAL_REACHED": "goal reached",
    "GOAL_UNCONFIRMED": "goal unconfirmed",
    "UNREACHABLE": "stopped at the frontier",
    "HALTED": "halted",
    "TIMEOUT": "time limit",
}


def test_every_end_state_has_its_own_words_and_none_says_failed():
    states = {s.value for s in TERMINAL} | {"TIMEOUT"}
    assert states == set(WORDS), "a new end state needs its words here and in outcome_words"
    for state in states:
        for reached in (True, False):
            words, tone = outcome_words(state, reached, 0.3 if not reached else 0.05)
            assert "fail" not in words, (state, words)
            if not (state == "GOAL_REACHED" and not reached):
                assert WORDS[state] in words, (state, words)
    assert outcome_words("GOAL_REACHED", False, 0.3) == ("false success: claimed the goal, truly 0.30 m from it", "bad")
    assert outcome_words("UNREACHABLE", False, 0.6, expect="unreachable")[1] == "ok"
    assert outcome_words("UNREACHABLE", False, 0.6)[1] == "stop"


def test_simulate_cul_de_sac_writes_an_honest_figure(tmp_path: Path, monkeypatch):
    """``clomp simulate --scenario cul-de-sac``: the figure it saves says "unreachable: stopped at the
    frontier" (not "failed"), draws the planner's scan points and direction marks, and keeps its legend
    right of the data."""
    seen: dict[str, object] = {}
    real_savefig = matplotlib.figure.Figure.savefig

    def spy(fig, *args, **kw):
        ax = fig.axes[0]
        fig.canvas.draw()
        seen.update(title=ax.get_title(), legend=ax.get_legend().get_window_extent(), axes=ax.get_window_extent(),
                    points=sum(len(c.get_offsets()) for c in ax.collections if type(c).__name__ == "PathCollection"),
                    arrows=[c for c in ax.collections if type(c).__name__ == "Quiver"],
                    labels=[t.get_text() for t in ax.texts])
        return real_savefig(fig, *args, **kw)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    assert main(["simulate", "--scenario", "cul-de-sac", "--out", str(tmp_path)]) == 1
    assert (tmp_path / "cul-de-sac_planning.png").stat().st_size > 0
    assert "unreachable: stopped at the frontier" in seen["title"] and "fail" not in seen["title"]
    assert seen["points"] > 100, "the scan points the planner saw are drawn"
    assert len(seen["arrows"]) == 1 and any(lab.endswith(" s") for lab in seen["labels"])
    assert seen["legend"].x0 >= seen["axes"].x1


def test_time_marks_point_the_way_the_robot_went():
    fig, ax = plt.subplots()
    try:
        path = [(0.1 * k, 0.0) for k in range(11)] + [(1.0, 0.1 * k) for k in range(1, 11)]
        times = [float(k) for k in range(len(path))]
        art = draw_run(ax, RunTrace(load_scenario("open"), "t", path, times=times), None)
        u, v = np.asarray(art.marks.U), np.asarray(art.marks.V)
        labels = [t.get_text() for t in art.mark_labels]
        assert labels == [f"{k} s" for k in range(2, 20, 2)]  # none at the end
        assert np.allclose(u[:4], 1.0) and np.allclose(v[5:], 1.0)  # along x, then along y
    finally:
        plt.close(fig)


def test_an_experiment_record_of_a_correct_stop_reads_as_one():
    scene = load_scenario("cul-de-sac")
    rec = {"layout": "cul-de-sac", "goal": list(scene.goal), "start": [0.0, 0.0, 0.0], "obstacles": scene.raw["obstacles"],
           "run": 3, "end_state": "UNREACHABLE", "reached_goal": 0, "final_error_m": 0.59, "collisions": 0, "brushes": 0,
           "expect": "unreachable", "success": 1, "path": [[0.0, 0.0], [0.3, 0.0], [0.5, 0.1]], "contacts": [],
           "planned": [], "estimate": [], "final_pose": [0.5, 0.1, 1.0], "time_s": 20.0}
    tr = record_trace(rec)
    assert tr.title.startswith("run 3: unreachable, as it is: stopped at the frontier") and tr.tone == "ok"
    assert tr.scan and tr.times == [0.0, 10.0, 20.0]
    fig = run_figure(tr)
    try:
        fig.canvas.draw()
        ax = fig.axes[0]
        assert ax.get_legend().get_window_extent().x0 >= ax.get_window_extent().x1
        assert ax.title.get_color() == "black"
    finally:
        plt.close(fig)


@pytest.mark.parametrize("state", ["GOAL_UNCONFIRMED", "UNREACHABLE"])
def test_an_honest_stop_is_not_coloured_as_a_failure(state):
    words, tone = outcome_words(state, False, 0.4)
    assert tone == "stop"


def test_animate_writes_a_small_gif_of_the_run(tmp_path: Path, capsys):
    """``clomp simulate --animate``: a GIF under 2 MB, the moving frames at most MAX_FRAMES plus the held end."""
    from PIL import Image

    from clomp.runtime.experiment.animation import MAX_FRAMES

    gif = tmp_path / "run.gif"
    assert main(["simulate", "--scenario", "open", "--no-noise", "--out", str(tmp_path), "--animate", str(gif)]) in (0, 1)
    assert f"animation: {gif}" in capsys.readouterr().out
    with Image.open(gif) as im:
        assert im.format == "GIF" and 20 < im.n_frames <= MAX_FRAMES + 20
    assert gif.stat().st_size < 2_000_000


def test_animate_refuses_what_it_cannot_write(tmp_path: Path, capsys):
    assert main(["simulate", "--scenario", "open", "--out", str(tmp_path), "--animate", str(tmp_path / "run.mp4")]) == 2
    assert "--animate" in capsys.readouterr().err and not list(tmp_path.glob("*.png"))
