"""The supervisor's machine, described once as data, and the supervisory-control checks.

:data:`SUPERVISOR` is the one description of the machine Ψ runs on the robot: its states,
its events (each *controllable* — the supervisor decides it: starting a task, stopping
the wheels — or *uncontrollable* — the world does: a scan, a collision, a fault, a task
ending), the transitions with their guards (named conditions, described in
:attr:`Machine.guards`), and in which states the wheels may turn. The runtime's
supervisor executes this table (``clomp.runtime.supervision.states`` reads it), and the
renderers draw it through :func:`machine_model`, an :class:`~clomp.formal.export.ExportModel`
like a cognitive map's, so PRISM, DRN, explicit files and DOT all come from one place.

Ramadge & Wonham: the robot is the *plant* :data:`PLANT` (what can physically happen,
over the same events), the machine is the *supervisor*. :func:`controllability` checks
that in every reachable state of the closed loop the supervisor never disables an
uncontrollable event the plant can produce; :func:`nonblocking` that from every
reachable state a terminal (marked) state stays reachable. Both return counterexamples
(event paths from the start) instead of a bare verdict. Both, and the exported model,
ask networkx about one graph of the closed loop, :func:`closed_loop_graph`.

:func:`machine_model` exports the closed loop (supervisor × plant, with the last event
in the state) as an MDP whose choices are the events, with labels ``motors`` (the
machine lets the wheels turn), ``driving`` (the plant runs a task), ``after_fault``,
``terminal`` and one per machine state; ``specs/properties/supervisor/machine.pctl``
states what must hold, e.g. the wheels turn only while a task runs.

>>> SUPERVISOR.target("IDLE", "start")
'PLANNING'
>>> controllability(SUPERVISOR, PLANT).ok, nonblocking(SUPERVISOR, PLANT).ok
(True, True)
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any

import networkx as nx

__all__ = [
    "MachineEvent",
    "MachineTransition",
    "Machine",
    "MachineNode",
    "SUPERVISOR",
    "PLANT",
    "SupervisoryResult",
    "closed_loop_graph",
    "closed_loop",
    "controllability",
    "nonblocking",
    "machine_model",
    "machine_property_file",
    "check_machine",
]


@dataclass(frozen=True, slots=True)
class MachineEvent:
    """An event of the machine: its name, whether the supervisor controls it, what it is."""

    name: str
    controllable: bool
    description: str = ""


@dataclass(frozen=True, slots=True)
class MachineTransition:
    """``source --event--> target``, taken when the named ``guard`` holds (None: always)."""

    source: str
    event: str
    target: str
    guard: str | None = None


@dataclass(frozen=True)
class Machine:
    """A finite automaton over named events: states, the initial and the terminal
    (marked) states, the states where the wheels may turn, events, guards, transitions.

    Deterministic: at most one transition per (state, event). :meth:`with_transition`
    and :meth:`with_wheels` return mutated copies (to show that the checks catch them).
    """

    name: str
    states: tuple[str, ...]
    initial: str
    terminal: frozenset[str]
    wheels: frozenset[str]
    events: tuple[MachineEvent, ...]
    transitions: tuple[MachineTransition, ...]
    guards: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        names = set(self.states)
        if len(names) != len(self.states):
            raise ValueError(f"{self.name}: duplicate state names")
        if self.initial not in names or not self.terminal <= names or not self.wheels <= names:
            raise ValueError(f"{self.name}: initial, terminal and wheel states must be states of the machine")
        events = {e.name for e in self.events}
        seen: set[tuple[str, str]] = set()
        for t in self.transitions:
            if t.source not in names or t.target not in names:
                raise ValueError(f"{self.name}: transition {t} names an unknown state")
            if t.event not in events:
                raise ValueError(f"{self.name}: transition {t} names an unknown event")
            if t.guard is not None and t.guard not in self.guards:
                raise ValueError(f"{self.name}: transition {t} names an undescribed guard {t.guard!r}")
            if (t.source, t.event) in seen:
                raise ValueError(f"{self.name}: two transitions from {t.source} on {t.event}")
            seen.add((t.source, t.event))

    def event(self, name: str) -> MachineEvent:
        """The event called ``name``."""
        for e in self.events:
            if e.name == name:
                return e
        raise KeyError(name)

    @property
    def controllable(self) -> frozenset[str]:
        """The names of the controllable events."""
        return frozenset(e.name for e in self.events if e.controllable)

    @property
    def uncontrollable(self) -> frozenset[str]:
        """The names of the uncontrollable events."""
        return frozenset(e.name for e in self.events if not e.controllable)

    def table(self) -> dict[tuple[str, str], str]:
        """(state, event) → target."""
        return {(t.source, t.event): t.target for t in self.transitions}

    def target(self, state: str, event: str) -> str | None:
        """Where ``event`` leads from ``state`` (None: the event is disabled there)."""
        return self.table().get((state, event))

    def enabled(self, state: str) -> list[str]:
        """The events enabled in ``state``, in the machine's event order."""
        on = {t.event for t in self.transitions if t.source == state}
        return [e.name for e in self.events if e.name in on]

    def with_transition(self, source: str, event: str, target: str | None) -> "Machine":
        """A copy where ``source --event-->`` goes to ``target`` (None removes it)."""
        kept = [t for t in self.transitions if (t.source, t.event) != (source, event)]
        old = next((t for t in self.transitions if (t.source, t.event) == (source, event)), None)
        if target is not None:
            kept.append(MachineTransition(source, event, target, old.guard if old else None))
        return replace(self, transitions=tuple(kept))

    def with_wheels(self, states: Iterable[str]) -> "Machine":
        """A copy where the wheels may turn exactly in ``states``."""
        return replace(self, wheels=frozenset(states))


_EVENTS = (
    MachineEvent("start", True, "the operator starts the run: plan from the first scan"),
    MachineEvent("planned", True, "the supervisor starts the first task of a new plan"),
    MachineEvent("next_task", True, "the supervisor starts the plan's next task"),
    MachineEvent("abort", True, "the supervisor stops the wheels on request (Ctrl-C, a time limit)"),
    MachineEvent("no_plan", False, "planning on a scan finds no safe task closer to the goal"),
    MachineEvent("at_goal", False, "a scan or a task's end puts the robot within the goal tolerance"),
    MachineEvent("goal_unconfirmed", False, "the estimate puts the robot within the goal tolerance, but its "
                                            "uncertainty cannot vouch for it"),
    MachineEvent("approach", True, "confirming, the settled estimate put the robot off the goal: the supervisor "
                                   "plans to it again"),
    MachineEvent("plan_short", False, "the plan's last task ended short of the goal"),
    MachineEvent("disagree", False, "a scan or a task's end disagrees with the map (hazard, off prediction, overrun), "
                                    "or the estimate the task was set from jumped"),
    MachineEvent("move_away", True, "a push felt (an IMU kick, or a revolution seeing through the map as the estimate "
                                    "jumped) left the robot "
                                    "touching or within a margin of an obstacle: the supervisor backs or drives a short "
                                    "way clear of it before it plans"),
    MachineEvent("moved_away", False, "the move away ended (its distance driven, or its time spent)"),
    MachineEvent("fault", False, "a device fails (motor controller, LiDAR, a robot fault)"),
)

_GUARDS = {
    "plan_found": "the Configurator returned a plan with at least one safe task",
    "within_goal_tolerance": "the estimated pose, with its 95 % position bound, is within the goal tolerance of D_G",
    "goal_not_vouched": "the estimated pose is within the goal tolerance of D_G, its 95 % position bound is not",
    "confirm_spent": "confirming, the revolutions seen standing (and the approaches) are spent and the bound still "
                     "cannot vouch for the goal",
    "estimate_left_goal": "confirming, the settled (or re-localised) estimate is farther than the goal tolerance, "
                          "and an approach is left",
    "no_safe_task": "the plan is empty, the goal is unreachable, or plans stopped bringing it closer",
    "task_done_as_predicted": "the task's error reached zero near the map's predicted end, and the plan has another task",
    "plan_done_short": "the plan's last task is done and the goal is farther than the tolerance",
    "map_disagrees": "a hazard is ahead, the task ended far from its prediction, it overran its duration, or a "
                     "revolution moved the estimate farther than replan_jump while it ran",
    "device_failed": "a robot call raised a fault",
    "pushed_against_obstacle": "a push was felt since the last judgement, the newest revolution after it has points "
                               "within the margin of the body, and a short straight or reverse clears some of them "
                               "without meeting another",
    "move_done": "the move away has driven its distance, or spent twice its expected time",
}

_T = MachineTransition
_NON_TERMINAL = ("IDLE", "PLANNING", "EXECUTING", "REPLANNING", "CONFIRMING", "MOVING_AWAY")
_TERMINAL = ("GOAL_REACHED", "GOAL_UNCONFIRMED", "UNREACHABLE", "HALTED")

SUPERVISOR = Machine(
    name="supervisor",
    states=(*_NON_TERMINAL, *_TERMINAL),
    initial="IDLE",
    terminal=frozenset(_TERMINAL),
    wheels=frozenset({"EXECUTING", "MOVING_AWAY"}),
    events=_EVENTS,
    guards=_GUARDS,
    transitions=(
        _T("IDLE", "start", "PLANNING"),
        _T("PLANNING", "planned", "EXECUTING", "plan_found"),
        _T("PLANNING", "at_goal", "GOAL_REACHED", "within_goal_tolerance"),
        _T("PLANNING", "goal_unconfirmed", "CONFIRMING", "goal_not_vouched"),
        _T("PLANNING", "no_plan", "UNREACHABLE", "no_safe_task"),
        _T("REPLANNING", "planned", "EXECUTING", "plan_found"),
        _T("REPLANNING", "at_goal", "GOAL_REACHED", "within_goal_tolerance"),
        _T("REPLANNING", "goal_unconfirmed", "CONFIRMING", "goal_not_vouched"),
        _T("REPLANNING", "no_plan", "UNREACHABLE", "no_safe_task"),
        _T("EXECUTING", "next_task", "EXECUTING", "task_done_as_predicted"),
        _T("EXECUTING", "at_goal", "GOAL_REACHED", "within_goal_tolerance"),
        _T("EXECUTING", "goal_unconfirmed", "CONFIRMING", "goal_not_vouched"),
        _T("EXECUTING", "plan_short", "REPLANNING", "plan_done_short"),
        _T("EXECUTING", "disagree", "REPLANNING", "map_disagrees"),
        # at the goal by the estimate, not vouched: stand and look (and approach again) first
        _T("CONFIRMING", "at_goal", "GOAL_REACHED", "within_goal_tolerance"),
        _T("CONFIRMING", "goal_unconfirmed", "GOAL_UNCONFIRMED", "confirm_spent"),
        _T("CONFIRMING", "approach", "REPLANNING", "estimate_left_goal"),
        _T("CONFIRMING", "no_plan", "UNREACHABLE", "no_safe_task"),
        # pushed against an obstacle: a short move clear of it first, then a plan made afresh
        _T("EXECUTING", "move_away", "MOVING_AWAY", "pushed_against_obstacle"),
        _T("REPLANNING", "move_away", "MOVING_AWAY", "pushed_against_obstacle"),
        _T("MOVING_AWAY", "moved_away", "REPLANNING", "move_done"),
        _T("MOVING_AWAY", "disagree", "REPLANNING", "map_disagrees"),
        *(_T(s, "fault", "HALTED", "device_failed") for s in _NON_TERMINAL),
        *(_T(s, "abort", "HALTED") for s in _NON_TERMINAL),
        # a terminal state ignores what the world still does (the wheels stay stopped)
        *(_T(s, e.name, s) for s in _TERMINAL for e in _EVENTS if not e.controllable),
    ),
)
"""The supervisor's machine: the table ``clomp.runtime.supervision`` executes."""

PLANT = Machine(
    name="robot",
    states=("OFF", "STOPPED", "DRIVING", "BACKING_OFF", "FAILED"),
    initial="OFF",
    terminal=frozenset({"STOPPED", "FAILED"}),
    wheels=frozenset({"DRIVING", "BACKING_OFF"}),
    events=_EVENTS,
    transitions=(
        _T("OFF", "start", "STOPPED"),
        _T("OFF", "fault", "FAILED"),
        _T("STOPPED", "planned", "DRIVING"),
        _T("STOPPED", "no_plan", "STOPPED"),
        _T("STOPPED", "at_goal", "STOPPED"),
        _T("STOPPED", "goal_unconfirmed", "STOPPED"),
        _T("STOPPED", "approach", "STOPPED"),
        _T("STOPPED", "abort", "STOPPED"),
        _T("STOPPED", "fault", "FAILED"),
        _T("DRIVING", "next_task", "DRIVING"),
        _T("DRIVING", "at_goal", "STOPPED"),
        _T("DRIVING", "goal_unconfirmed", "STOPPED"),
        _T("DRIVING", "plan_short", "STOPPED"),
        _T("DRIVING", "disagree", "STOPPED"),
        _T("DRIVING", "abort", "STOPPED"),
        _T("DRIVING", "fault", "FAILED"),
        _T("STOPPED", "move_away", "BACKING_OFF"),
        _T("DRIVING", "move_away", "BACKING_OFF"),
        _T("BACKING_OFF", "moved_away", "STOPPED"),
        _T("BACKING_OFF", "disagree", "STOPPED"),
        _T("BACKING_OFF", "abort", "STOPPED"),
        _T("BACKING_OFF", "fault", "FAILED"),
        _T("FAILED", "fault", "FAILED"),
        _T("FAILED", "abort", "FAILED"),
    ),
)
"""The plant: the robot over the same events. Stopped, it plans (a plan, none, or the goal
already reached: uncontrollable outcomes) or starts a task; driving, a task ends (as
predicted: the next task; at the goal, short of it, or off the map) or the wheels are
stopped; a fault can happen at any time. Confirming a doubtful goal it stands (``approach``:
the supervisor's choice to plan again, the robot still stopped). Pushed against an obstacle
(``move_away``, the supervisor's choice, stopped or driving) it backs off: the move ends
(``moved_away``), the way turns out blocked (``disagree``), or it is stopped."""


@dataclass(frozen=True)
class SupervisoryResult:
    """A verdict with counterexamples: each an event path from the start and what fails."""

    ok: bool
    counterexamples: tuple[tuple[tuple[str, ...], str], ...] = ()

    def __str__(self) -> str:
        if self.ok:
            return "holds"
        lines = [f"{why} (after {' '.join(path) or 'nothing'})" for path, why in self.counterexamples]
        return "fails: " + "; ".join(lines)


def _anything(sup: Machine) -> Machine:
    """The plant that allows every event of ``sup`` (one unnamed state): ``sup`` alone."""
    return Machine("", ("",), "", frozenset(), frozenset(), sup.events,
                   tuple(MachineTransition("", e.name, "") for e in sup.events))


def closed_loop_graph(sup: Machine, plant: Machine | None = None, remember_last: bool = False) -> Any:
    """The synchronous product sup × plant as a :class:`networkx.MultiDiGraph`: an event
    is taken when both machines enable it. Nodes are ``(supervisor state, plant state,
    last event)`` for every combination (``last`` is None unless ``remember_last``; the
    plant state is ``""`` for ``plant=None``, the supervisor alone); edges are keyed by
    their event and added in the machine's event order, so a breadth-first search meets
    successors in that order. Attributes: ``start`` (the initial node), ``events`` (the
    event names in order). Ask networkx what is reachable from ``start``.

    >>> g = closed_loop_graph(SUPERVISOR, PLANT)
    >>> sorted(g[("IDLE", "OFF", None)][("PLANNING", "STOPPED", None)])
    ['start']
    """
    other = _anything(sup) if plant is None else plant
    ts, tp = sup.table(), other.table()
    events = [e.name for e in sup.events]
    lasts: tuple[str | None, ...] = (None, *events) if remember_last else (None,)
    g = nx.MultiDiGraph(start=(sup.initial, other.initial, None), events=events)
    for s in sup.states:
        for p in other.states:
            for last in lasts:
                g.add_node((s, p, last))
                for e in events:
                    a, b = ts.get((s, e)), tp.get((p, e))
                    if a is not None and b is not None:
                        g.add_edge((s, p, last), (a, b, e if remember_last else None), key=e)
    return g


def _event_paths(g: Any) -> dict[Any, tuple[str, ...]]:
    """The nodes of ``g`` reachable from its start, in breadth-first order, each with a
    shortest event path (the first event in the machine's order at each step)."""
    start = g.graph["start"]
    paths: dict[Any, tuple[str, ...]] = {start: ()}
    for u, v in nx.bfs_edges(g, start):
        paths[v] = paths[u] + (next(iter(g[u][v])),)
    return paths


def closed_loop(sup: Machine, plant: Machine) -> dict[tuple[str, str], tuple[str, ...]]:
    """The reachable states of sup × plant (both must enable an event to take it), each
    with a shortest event path from the start."""
    return {(s, p): path for (s, p, _), path in _event_paths(closed_loop_graph(sup, plant)).items()}


def controllability(sup: Machine, plant: Machine) -> SupervisoryResult:
    """The supervisor never disables an uncontrollable event the plant can produce, in
    any reachable state of the closed loop (Ramadge & Wonham)."""
    ts, tp = sup.table(), plant.table()
    bad = []
    for (s, p), path in closed_loop(sup, plant).items():
        for e in sorted(plant.uncontrollable):
            if (p, e) in tp and (s, e) not in ts:
                bad.append((path, f"{sup.name} in {s} disables uncontrollable '{e}' that the {plant.name} in {p} can produce"))
    return SupervisoryResult(not bad, tuple(bad))


def nonblocking(sup: Machine, plant: Machine) -> SupervisoryResult:
    """From every reachable state of the closed loop a marked state — terminal for the
    supervisor and for the plant — stays reachable."""
    g = closed_loop_graph(sup, plant)
    reach = _event_paths(g)
    marked = [x for x in g if x[0] in sup.terminal and x[1] in plant.terminal]
    good = {x for layer in nx.bfs_layers(g.reverse(copy=False), marked) for x in layer} if marked else set()
    bad = [(path, f"from {x[0]} with the {plant.name} {x[1]} no terminal state can be reached")
           for x, path in reach.items() if x not in good]
    return SupervisoryResult(not bad, tuple(sorted(bad)))


@dataclass(frozen=True, slots=True)
class MachineNode:
    """A state of the closed loop as an exported model's state (the renderers' ``State``)."""

    ident: int
    supervisor: str
    plant: str
    last: str | None

    @property
    def name(self) -> str:
        """``EXECUTING/DRIVING`` (and the event that led here)."""
        return self.supervisor + (f"/{self.plant}" if self.plant else "") + (f" after {self.last}" if self.last else "")

    # what the renderers read from a map's states
    interrupted = False
    reached_goal = False
    distance = 0.0
    duration = 0.0
    cost = 0.0


def machine_model(sup: Machine = SUPERVISOR, plant: Machine | None = PLANT, remember_last: bool | None = None) -> Any:
    """The closed loop sup × plant (``plant=None``: the supervisor alone) as an
    :class:`~clomp.formal.export.ExportModel`, an MDP whose actions are the events. With
    ``remember_last`` (default: when a plant is given) each state also remembers the
    event that led to it, so that properties can speak of what follows an event.
    Labels: ``init``, ``motors`` (the machine lets the wheels turn), ``driving`` (the
    plant runs a task), ``after_fault``, ``terminal``, and the machine's states in lower
    case. The renderers of :mod:`clomp.formal.export` draw it like a cognitive map.

    >>> m = machine_model(SUPERVISOR, None)
    >>> m.n_states, sorted(m.states[k].name for k in m.labels["motors"])
    (10, ['EXECUTING', 'MOVING_AWAY'])
    """
    from clomp.formal.export import STAY, Choice, ExportModel
    from clomp.formal.supervisory import Plan

    last_too = plant is not None if remember_last is None else remember_last
    g = closed_loop_graph(sup, plant, last_too)
    order = list(_event_paths(g))  # breadth-first from the start: state k is the k-th met
    index = {node: k for k, node in enumerate(order)}
    rank = {e: i for i, e in enumerate(g.graph["events"])}
    states = tuple(MachineNode(k, s, p, last) for k, (s, p, last) in enumerate(order))
    choices = []
    loops = []
    for k, node in enumerate(order):
        out = sorted(g.out_edges(node, keys=True), key=lambda edge: rank[edge[2]])  # the events in order
        row = tuple(Choice(ev, ((index[v], Fraction(1)),)) for _, v, ev in out)
        if not row:
            row = (Choice(STAY, ((k, Fraction(1)),)),)
            loops.append(k)
        choices.append(row)
    driving = plant.wheels if plant is not None else frozenset()
    labels: dict[str, frozenset[int]] = {
        "init": frozenset({0}),
        "motors": frozenset(k for k, n in enumerate(states) if n.supervisor in sup.wheels),
        "driving": frozenset(k for k, n in enumerate(states) if n.plant in driving),
        "after_fault": frozenset(k for k, n in enumerate(states) if n.last == "fault"),
        "terminal": frozenset(k for k, n in enumerate(states) if n.supervisor in sup.terminal),
    }
    for name in sup.states:
        labels[name.lower()] = frozenset(k for k, n in enumerate(states) if n.supervisor == name)
    title = sup.name if plant is None else f"{sup.name} x {plant.name} closed loop"
    return ExportModel("mdp", states, 0, tuple(choices), labels, tuple(loops), Plan((0,)), None, title=title)  # type: ignore[arg-type]


def machine_property_file() -> Any:
    """``specs/properties/supervisor/machine.pctl``: what the closed loop must satisfy."""
    from clomp import specs
    from pathlib import Path

    return Path(specs.__file__).resolve().parent / "properties" / "supervisor" / "machine.pctl"


def check_machine(sup: Machine = SUPERVISOR, plant: Machine = PLANT, via: str = "drn") -> list[Any]:
    """Storm's verdict on every property of :func:`machine_property_file` for the closed
    loop of ``sup`` and ``plant`` (a list of :class:`~clomp.formal.checking.CheckResult`)."""
    from clomp.formal.checking import build_storm_model, check_properties, read_properties

    pf = read_properties(machine_property_file())
    return check_properties(build_storm_model(machine_model(sup, plant), via=via), pf)
