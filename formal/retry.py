"""An interruption modelled as what the supervisor does with it: a retry from the stop.

In the cognitive map an interrupted state is absorbing (R is undefined after a hit),
and the exported models label it ``collision``, so ``!"collision" U "goal"`` counts
every interruption as a failure. The runtime does not: when the supervisor's scan test
stops a task (a *stop*, not a contact), it replans from where the robot stands, and
most such stops under range noise are false alarms that the next plan gets through.

:func:`retry_model` turns an :class:`~clomp.formal.export_model.ExportModel` into the model
the runtime executes: a product of the model with a retry counter ``r = 0 … retries``.
A stop state reached with ``r < retries`` left is not final: its one choice ``retry``
goes back into the map, to the state the interrupted task started from (the stop pose
lies on that task's path; in an MDP every task is again available there, as in the
supervisor's fresh plan), in layer ``r + 1``. A stop reached with no retry left, and
every contact, stays labelled ``collision``. Labels gain ``stop`` (every stop state,
retried or not). Layer 0 keeps the model's own indices and idents, so its states are
the map's; a copy in layer ``r`` has ident ``ident + r * span`` (``span`` = largest
ident + 1). Only states reachable from q0 are kept.

Re-entering the task's start treats a retry as a fresh draw of that task's outcomes:
optimistic for a stop that repeats (a real obstacle), which is why the retries are
bounded. With ``retries=0`` the model is the input itself, and the value of
``!"collision" U "goal"`` never decreases with more retries (a retried stop can only
lead on to the goal, where the stop alone was a failure).

>>> from clomp.formal.lts import CognitiveMap
>>> from clomp.formal.model import Disturbance, DisturbanceKind, Pose, State, TaskKind
>>> from clomp.formal.export_model import export_model
>>> g = Disturbance.goal(1.0, 0.0)
>>> box = Disturbance(DisturbanceKind.OBSTACLE, 0.5, 0.0)
>>> m = CognitiveMap(goal=g)
>>> _ = m.add_state(State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)))
>>> _ = m.add_state(State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True))
>>> _ = m.add_state(State(2, TaskKind.STRAIGHT, g, box, Pose(0, 0), Pose(0.3, 0)))
>>> from fractions import Fraction
>>> _ = m.add_transition(0, 1, TaskKind.STRAIGHT, Fraction(1, 2))
>>> _ = m.add_transition(0, 2, TaskKind.STRAIGHT, Fraction(1, 2))
>>> r = retry_model(export_model(m, "mdp"), {2: 0}, retries=1)
>>> [s.ident for s in r.states], [c.action for c in r.choices[2]]
([0, 1, 2, 3, 4, 5], ['retry'])
>>> sorted(r.states[k].ident for k in r.labels["collision"])
[5]
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from fractions import Fraction

import networkx as nx

from clomp.formal.export_model import STAY, Choice, ExportError, ExportModel

__all__ = ["RETRY", "STOP_LABEL", "STOPS_KEY", "OFF_LABEL", "OFFS_KEY", "INTERRUPTED", "GAVE_UP", "LOST_KEY", "LOST_LABEL",
           "retry_model", "loop_model", "map_stops", "map_offs", "map_lost"]

RETRY = "retry"
"""The action of a stop state's retry (the supervisor's replan from the stop)."""

STOP_LABEL = "stop"
"""The label of the stop states (interruptions by the scan test, not contacts)."""

INTERRUPTED = "interrupted"
"""The closed-loop model's label of a stop: the supervisor's check interrupted the task
(it is not a collision; it is replanned from while a replan is left)."""

GAVE_UP = "gave_up"
"""The closed-loop model's label of a stop with no replan left (the run ends there: not
the goal, and not a collision either)."""

OFF_LABEL = "off_map"
"""The label of the free leaves where a task ended off the map's prediction (given ``offs``)."""

OFFS_KEY = "offs"
"""The key of a closed-loop map's ``metadata`` naming its free leaves off the map's
prediction: ident -> the state the task aimed at (:func:`map_offs` reads it)."""

LOST_KEY = "lost"
"""The key of a map's ``metadata`` naming its lost states (a push left the estimate off
the truth: the run ends off the goal, :func:`clomp.planner.pushes.push_lost`): ident ->
the state the pushed task started from."""

LOST_LABEL = "estimate_lost"
"""The closed-loop model's label of the lost states (:data:`LOST_KEY`): not the goal, not
a collision, not replanned from."""

STOPS_KEY = "stops"
"""The key of a map's ``metadata`` naming its stop states: ident -> the state its task
started from (JSON-ready: string keys), as :func:`map_stops` reads it."""


def map_stops(metadata: Mapping[str, object]) -> dict[int, int]:
    """The stops a map's ``metadata`` names (see :data:`STOPS_KEY`), or ``{}``.

    >>> map_stops({"stops": {"4": 1}}), map_stops({})
    ({4: 1}, {})
    """
    return _idents(metadata, STOPS_KEY)


def _idents(metadata: Mapping[str, object], key: str) -> dict[int, int]:
    raw = metadata.get(key)
    if not isinstance(raw, Mapping):
        return {}
    return {int(k): int(v) for k, v in raw.items()}


def map_offs(metadata: Mapping[str, object]) -> dict[int, int]:
    """The outcomes off the map's prediction a map's ``metadata`` names (:data:`OFFS_KEY`), or ``{}``.

    >>> map_offs({"offs": {"7": 3}}), map_offs({})
    ({7: 3}, {})
    """
    return _idents(metadata, OFFS_KEY)


def map_lost(metadata: Mapping[str, object]) -> dict[int, int]:
    """The lost states a map's ``metadata`` names (:data:`LOST_KEY`), or ``{}``.

    >>> map_lost({"lost": {"9": 0}}), map_lost({})
    ({9: 0}, {})
    """
    return _idents(metadata, LOST_KEY)


def retry_model(m: ExportModel, stops: Mapping[int, int], retries: int = 1,
                offs: Mapping[int, int] | None = None) -> ExportModel:
    """The product of ``m`` with ``retries`` retries: ``stops`` maps each stop state's
    ident to the ident of the state its retry re-enters (see the module docstring).
    Stops that ``m`` does not hold are ignored (e.g. off the plan of a DTMC); a re-entry
    state an MDP does not hold is an :class:`ExportError`, while a DTMC's stop whose
    re-entry lies off its plan (e.g. an outcome aimed at a nominal state the rollouts of
    a carried plan never reached) is not retried: the plan has no task there, the run
    ends at the stop (before, an ExportError: a robust run HALTED on it, clutter 18).
    ``offs``: free leaves where a
    task ended off the map's prediction (:data:`OFFS_KEY`), each with the state the
    task aimed at; their retry (the supervisor's replan from near there) re-enters that
    state, and they are labelled :data:`OFF_LABEL` (given ``offs`` only)."""
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise ExportError(f"retries must be a whole number >= 0, got {retries!r}")
    index = {s.ident: k for k, s in enumerate(m.states)}
    held = m.kind == "dtmc"  # a DTMC holds only its plan's states: a re-entry off it is no retry
    back, stopped = _reentries(index, stops, lambda k: m.states[k].interrupted, "a stop but was not interrupted", held)
    ends, ended = _reentries(index, offs or {}, lambda k: not m.states[k].interrupted and [c.action for c in m.choices[k]] == [STAY],
                             "an outcome off the map's prediction but is not a free leaf", held)
    back.update(ends)
    stop_set, off_set = (set(back) - set(ends)) | stopped, set(ends) | ended
    off_label = {} if offs is None else {OFF_LABEL: frozenset(off_set)}
    if retries == 0 or not back:
        return replace(m, labels={**m.labels, STOP_LABEL: frozenset(stop_set), **off_label})
    span = max(s.ident for s in m.states) + 1
    # product states (index in m, layer): layer 0 first, in m's order, then the copies
    # reachable from it, breadth-first (the product's root leads to layer 0, in order)
    order: list[tuple[int, int]] = [key for _, key in nx.bfs_edges(_product(m, back, retries), _ROOT)]
    where = {key: i for i, key in enumerate(order)}
    choices: list[tuple[Choice, ...]] = []
    for k, r in order:
        if k in back and r < retries:
            row: tuple[Choice, ...] = (Choice(RETRY, ((where[(back[k], r + 1)], Fraction(1)),), 0.0, 0.0, True),)
        else:
            row = tuple(replace(ch, branches=tuple((where[(j, r)], p) for j, p in ch.branches)) for ch in m.choices[k])
        choices.append(row)
    states = tuple(m.states[k] if r == 0 else replace(m.states[k], ident=m.states[k].ident + r * span) for k, r in order)
    labels: dict[str, frozenset[int]] = {}
    for name, members in m.labels.items():
        if name in ("init", "goal_in_map"):
            labels[name] = members
        else:
            labels[name] = frozenset(p for p, (k, _) in enumerate(order) if k in members)
    labels["collision"] = frozenset(p for p in labels.get("collision", frozenset())
                                    if not (order[p][0] in back and order[p][1] < retries))
    labels[STOP_LABEL] = frozenset(p for p, (k, _) in enumerate(order) if k in stop_set)
    if offs is not None:
        labels[OFF_LABEL] = frozenset(p for p, (k, _) in enumerate(order) if k in off_set)
    loops = tuple(p for p, row in enumerate(choices) if len(row) == 1 and row[0].action == STAY)
    return replace(m, states=states, choices=tuple(choices), labels=labels, self_loops=loops)


def _reentries(index: Mapping[int, int], named: Mapping[int, int], fits: Callable[[int], bool], what: str,
               partial: bool = False) -> tuple[dict[int, int], set[int]]:
    """``named`` (ident -> the ident its retry re-enters) as indices (``index``), and the
    indices of those whose re-entry the model does not hold when it may not (``partial``:
    a DTMC, which holds its plan's states only); those the model does not hold are
    ignored; a re-entry it does not hold (not ``partial``), or one that does not ``fits``
    (``what`` it is named), is an :class:`ExportError`."""
    out: dict[int, int] = {}
    unheld: set[int] = set()
    for q, back in named.items():
        if q not in index:
            continue
        if not fits(index[q]):
            raise ExportError(f"q{q} is named {what}")
        if back in index:
            out[index[q]] = index[back]
        elif partial:
            unheld.add(index[q])
        else:
            raise ExportError(f"the retry of q{q} re-enters q{back}, which the model does not hold")
    return out, unheld


def loop_model(m: ExportModel, stops: Mapping[int, int], replans: int = 1,
               offs: Mapping[int, int] | None = None, lost: Mapping[int, int] | None = None) -> ExportModel:
    """The model of the closed loop: :func:`retry_model` with ``replans`` retries, labelled
    by what happened rather than by the map's ``interrupted`` flag. ``collision`` is a
    contact only (a stop is never one, retried or not); ``interrupted`` marks every stop
    (the check fired: the supervisor stops and replans, the ``retry`` action back to the
    task's start); ``gave_up`` the stops with no replan left. The ``stop`` label of
    :func:`retry_model` is renamed ``interrupted``; the outcomes ``offs`` off the map's
    prediction (the plan check fails a task that would end there: the supervisor
    replans from near the state the task aimed at) are ``interrupted`` too, and
    ``off_map``. With ``P=? [F "goal"]`` on it, Storm
    and PRISM give the chance of reaching the goal with replans, ``P=? [F "collision"]``
    the chance of a contact the check could not prevent
    (``specs/properties/closed_loop/``). ``lost``: the map's lost states
    (:data:`LOST_KEY`), labelled :data:`LOST_LABEL` in every layer (empty without them):
    dead ends, where a push left the estimate off the truth.

    A stop (q1, started from q0) whose one replan is left in layer 0 and gone in layer 1
    (q1 + 2 = q3): interrupted in both, never a collision, given up in layer 1:

    >>> from clomp.formal.lts import CognitiveMap
    >>> from clomp.formal.model import Disturbance, DisturbanceKind, Pose, State, TaskKind as K
    >>> from clomp.formal.export_model import export_model
    >>> g, o = Disturbance.goal(1.0, 0.0), Pose(0, 0)
    >>> hit = State(1, K.LEFT, g, Disturbance(DisturbanceKind.OBSTACLE, 0.2, 0.1), o, Pose(0, 0, 0.4))
    >>> m = CognitiveMap.from_parts([State(0, K.STRAIGHT, g, None, o, o), hit], [(0, 1)], goal=g)
    >>> r = loop_model(export_model(m, "mdp"), {1: 0}, replans=1)
    >>> [sorted(r.states[k].ident for k in r.labels[name]) for name in ("collision", "interrupted", "gave_up")]
    [[], [1, 3], [3]]
    """
    r = retry_model(m, stops, replans, offs if offs is not None else {})
    stop = r.labels[STOP_LABEL]
    off = r.labels[OFF_LABEL]
    final = frozenset(p for p in stop | off if not any(c.action == RETRY for c in r.choices[p]))
    labels = {name: members for name, members in r.labels.items() if name != STOP_LABEL}
    labels["collision"] = labels.get("collision", frozenset()) - stop
    labels[INTERRUPTED] = stop | off
    labels[GAVE_UP] = final
    span = max(s.ident for s in m.states) + 1
    dead = set(lost or {})
    labels[LOST_LABEL] = frozenset(p for p, s in enumerate(r.states) if s.ident % span in dead)
    return replace(r, labels=labels)


_ROOT = (-1, -1)


def _product(m: ExportModel, back: Mapping[int, int], retries: int) -> nx.DiGraph:
    """The graph of ``m`` × {0 … retries}: node (index in m, retries used); a stop with
    retries left goes to its re-entry state one layer up, every other state keeps its
    choices' branches in its layer (added in choice and branch order). A root node
    :data:`_ROOT` leads to every state of layer 0, in m's order."""
    g = nx.DiGraph()
    g.add_edges_from((_ROOT, (k, 0)) for k in range(m.n_states))
    for r in range(retries + 1):
        for k in range(m.n_states):
            g.add_node((k, r))
            if k in back and r < retries:
                g.add_edge((k, r), (back[k], r + 1))
            else:
                g.add_edges_from(((k, r), (j, r)) for ch in m.choices[k] for j, _ in ch.branches)
    return g
