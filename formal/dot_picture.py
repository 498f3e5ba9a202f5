"""How :func:`clomp.formal.export.write_dot` draws a model so that a reader can read it: a legend,
a layout that fits a page, poses in the states' labels and a state's many self-loops folded into one.

- :func:`layout` — the graph's attributes: depth down the page (``TB``) or across it (``LR``),
  whichever lets the drawing fit a portrait page at the larger scale, and ``size`` so that
  Graphviz scales a larger drawing down to the page;
- :func:`legend` — one node (an HTML-like table) naming each mark the picture uses: for a
  cognitive map the bold plan, q0's double border, collision octagons, goal states, φ, the
  pose and the grey ``stay`` loops; for a machine the filled states (wheels may turn),
  the double borders (terminal) and the folded self-loops;
- :func:`pose_line` — a state's end pose as a label line (planner frame, metres and degrees);
- :func:`folded_loops` — a state's self-loops on several events as one edge labelled with
  all of them (a terminal state of the supervisor ignores seven events: one loop, not seven).

Nothing here changes a model: only how its DOT text looks.

>>> from clomp.formal.control import SUPERVISOR, machine_model
>>> m = machine_model(SUPERVISOR, None)
>>> len(folded_loops(m)), folded_loops(m)[0].split(", color")[0].strip()
(4, '2 -> 2 [label="ignores 7 events"')
"""

from __future__ import annotations

import math
import textwrap
from collections import defaultdict

from clomp.formal.export_model import STAY, ExportModel
from clomp.formal.model import State

__all__ = ["PAGE", "folded", "folded_loops", "layout", "legend", "loop_events", "pose_line"]

#: the page a drawing is scaled to fit (inches: US letter / A4 less margins), Graphviz's ``size``
PAGE = (7.5, 10.0)


def pose_line(s: State) -> str:
    """The state's end pose, planner frame: ``(x, y) m, θ°``.

    >>> import clomp
    >>> scene = clomp.load_scenario("open")
    >>> pose_line(clomp.plan(scene.scan(), goal=scene.goal_in_robot_frame()).map[1])
    '(1.00, 0.00) m  0°'
    """
    return f"({s.end.x:.2f}, {s.end.y:.2f}) m  {math.degrees(s.end.theta):.0f}°"


def _depths(m: ExportModel) -> dict[int, int]:
    """Each state's depth from the initial state along the model's edges (breadth first)."""
    depth = {m.initial: 0}
    todo = [m.initial]
    for k in todo:
        for ch in m.choices[k]:
            for j, _ in ch.branches:
                if j not in depth:
                    depth[j] = depth[k] + 1
                    todo.append(j)
    return depth


def layout(m: ExportModel) -> list[str]:
    """The DOT graph attribute line: ``rankdir`` chosen so the drawing fits a portrait page at
    the larger scale (ranks down the page when there are more ranks than states in a rank),
    and ``size`` (:data:`PAGE`) so that a larger drawing is scaled down to it.

    >>> from clomp.formal.control import SUPERVISOR, machine_model
    >>> layout(machine_model(SUPERVISOR, None))[0].strip()
    'graph [rankdir=TB, size="7.5,10", fontname="Helvetica"];'
    """
    per_rank: dict[int, int] = defaultdict(int)
    for d in _depths(m).values():
        per_rank[d] += 1
    ranks, widest = len(per_rank) or 1, max(per_rank.values(), default=1)
    box_w, box_h, gap_w, gap_h = 1.3, 0.65, 1.0, 0.5  # inches a state and the space beside it take
    across = min(PAGE[0] / (ranks * (box_w + gap_w)), PAGE[1] / (widest * (box_h + gap_h)))  # LR
    down = min(PAGE[0] / (widest * (box_w + 0.3)), PAGE[1] / (ranks * (box_h + gap_h + 0.3)))  # TB
    rankdir = "TB" if down > across else "LR"
    return [f'  graph [rankdir={rankdir}, size="{PAGE[0]:g},{PAGE[1]:g}", fontname="Helvetica"];']


def _html(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _legend_rows(m: ExportModel) -> list[tuple[str, str]]:
    """(mark, meaning) for each mark the picture of ``m`` uses."""
    if m.title is not None:  # a machine (the supervisor)
        rows = [("<b>state</b>", "a state of the machine; an arrow: the event that moves it")]
        if m.labels.get("motors"):
            rows.append(("green fill", "the wheels may turn here (everywhere else they are stopped)"))
        if m.labels.get("terminal"):
            rows.append(("double border", "terminal: the run ends here"))
        for evs, ks in _shared(m).items():
            why = "the run has ended: they change nothing" if set(ks) <= m.labels.get("terminal", frozenset()) else "the state stays"
            rows.append((f"loop: ignores {len(evs)} events", f"{', '.join(evs)} ({why})"))
        if m.labels.get("after_fault"):
            rows.append(("red border", "reached by a fault"))
        return rows
    states = [s for s in m.states if isinstance(s, State)]
    rows = [("<b>bold arrow</b>", "the plan (the tasks the supervisor executes)"),
            ("double border", "q0: the present task, where planning starts"),
            ("arrow label", "the task simulated from the state (STRAIGHT, LEFT, RIGHT)")]
    if any(s.interrupted for s in states):
        rows.append(('<font color="red">red octagon</font>', "collision: the task was cut short by an obstacle"))
    if any(s.reached_goal for s in states):
        rows.append(("green fill", "the goal is reached"))
    rows += [("φ", "the state's cost φ = χ + γ: χ in [0, 1) the share of the way to the goal still to go, γ in [1, 2] "
                   "for a collision, else 0; the plan ends at the least φ"),
             ("(x, y) m θ°", "the pose at the task's end, planner frame (robot at the origin, x ahead)")]
    if m.self_loops:
        rows.append(('<font color="grey">dashed loop "stay"</font>', "a leaf made absorbing for the model checker"))
    return rows


def legend(m: ExportModel) -> list[str]:
    """The DOT lines of the legend: one plain node (``legend``) holding a two-column table.

    >>> from clomp.formal.control import SUPERVISOR, machine_model
    >>> "double border" in "".join(legend(machine_model(SUPERVISOR, None)))
    True
    """
    br = '<br align="left"/>'
    cells = "".join(f'<tr><td align="left" valign="top">{mark}</td><td align="left">'
                    f"{br.join(_html(line) for line in textwrap.wrap(text, 64))}{br}</td></tr>"
                    for mark, text in _legend_rows(m))
    table = f'<table border="1" cellborder="0" cellspacing="2" color="grey"><tr><td colspan="2"><b>legend</b></td></tr>{cells}</table>'
    return [f'  legend [shape=plaintext, fontsize=9, label=<{table}>];', "  { rank=sink; legend; }"]


def loop_events(m: ExportModel) -> dict[int, list[str]]:
    """State → the events of its self-loops (not the model checker's added ``stay``), in order."""
    out: dict[int, list[str]] = defaultdict(list)
    for k, row in enumerate(m.choices):
        for ch in row:
            if ch.action != STAY and all(j == k for j, _ in ch.branches):
                out[k].append(ch.action)
    return dict(out)


def _shared(m: ExportModel) -> dict[tuple[str, ...], list[int]]:
    """Event sets that several states loop on (named once, in the legend), → those states."""
    by_set: dict[tuple[str, ...], list[int]] = defaultdict(list)
    for k, events in loop_events(m).items():
        if len(events) > 1:
            by_set[tuple(events)].append(k)
    return {evs: ks for evs, ks in by_set.items() if len(ks) > 1}


def folded_loops(m: ExportModel) -> list[str]:
    """One DOT edge per state that loops on several events instead of a stack of loops:
    labelled ``ignores N events`` when several states ignore the same ones (the legend lists
    them once), else with the events themselves (wrapped); a single self-loop is drawn as any edge."""
    shared = _shared(m)
    lines = []
    for k, events in loop_events(m).items():
        if len(events) > 1:
            if tuple(events) in shared:
                label = f"ignores {len(events)} events"
            else:
                label = "\n".join(textwrap.wrap(", ".join(events), 26))
            lines.append(f'  {k} -> {k} [label="{label}", color=grey40, fontcolor=grey25];')
    return lines


def folded(m: ExportModel) -> set[tuple[int, str]]:
    """The (state, event) self-loops :func:`folded_loops` draws together (the other edges skip them)."""
    return {(k, e) for k, evs in loop_events(m).items() if len(evs) > 1 for e in evs}
