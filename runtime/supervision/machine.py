"""The supervisor's state machine, as data: states, events, the transition table, renderers.

::

    IDLE ─start→ PLANNING ─planned→ EXECUTING ─next_task→ EXECUTING
                 PLANNING ─at_goal→ GOAL_REACHED      EXECUTING ─at_goal→ GOAL_REACHED
                 PLANNING ─no_plan→ UNREACHABLE       EXECUTING ─plan_short / disagree→ REPLANNING
                 REPLANNING ─planned / at_goal / no_plan→ (as from PLANNING)
    any non-terminal state ─fault / abort→ HALTED

The wheels may turn only in :data:`MOTOR_STATES`. :func:`state_machine_dot` and
:func:`state_machine_prism` export the machine itself.

>>> TRANSITIONS[(SupervisorState.IDLE, Event.START)].value
'PLANNING'
>>> sorted(s.value for s in TERMINAL)
['GOAL_REACHED', 'HALTED', 'UNREACHABLE']
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = [
    "Event",
    "MOTOR_STATES",
    "SupervisorState",
    "TERMINAL",
    "TRANSITIONS",
    "TransitionRecord",
    "state_machine_dot",
    "state_machine_prism",
]


class SupervisorState(str, enum.Enum):
    """The supervisor's states."""

    IDLE = "IDLE"
    PLANNING = "PLANNING"
    EXECUTING = "EXECUTING"
    REPLANNING = "REPLANNING"
    GOAL_REACHED = "GOAL_REACHED"
    UNREACHABLE = "UNREACHABLE"
    HALTED = "HALTED"


class Event(str, enum.Enum):
    """What moves the supervisor from one state to the next."""

    START = "start"
    PLANNED = "planned"
    AT_GOAL = "at_goal"
    NO_PLAN = "no_plan"
    NEXT_TASK = "next_task"
    PLAN_SHORT = "plan_short"
    DISAGREE = "disagree"
    FAULT = "fault"
    ABORT = "abort"


S, E = SupervisorState, Event
TERMINAL: frozenset[SupervisorState] = frozenset({S.GOAL_REACHED, S.UNREACHABLE, S.HALTED})
MOTOR_STATES: frozenset[SupervisorState] = frozenset({S.EXECUTING})

TRANSITIONS: dict[tuple[SupervisorState, Event], SupervisorState] = {
    (S.IDLE, E.START): S.PLANNING,
    (S.PLANNING, E.PLANNED): S.EXECUTING,
    (S.PLANNING, E.AT_GOAL): S.GOAL_REACHED,
    (S.PLANNING, E.NO_PLAN): S.UNREACHABLE,
    (S.REPLANNING, E.PLANNED): S.EXECUTING,
    (S.REPLANNING, E.AT_GOAL): S.GOAL_REACHED,
    (S.REPLANNING, E.NO_PLAN): S.UNREACHABLE,
    (S.EXECUTING, E.NEXT_TASK): S.EXECUTING,
    (S.EXECUTING, E.AT_GOAL): S.GOAL_REACHED,
    (S.EXECUTING, E.PLAN_SHORT): S.REPLANNING,
    (S.EXECUTING, E.DISAGREE): S.REPLANNING,
    **{(s, ev): S.HALTED for s in SupervisorState if s not in TERMINAL for ev in (E.FAULT, E.ABORT)},
}


@dataclass(frozen=True)
class TransitionRecord:
    """One transition the supervisor took, with the reason."""

    time: float
    source: SupervisorState
    event: Event
    target: SupervisorState
    reason: str


def state_machine_dot() -> str:
    """The supervisor's state machine as Graphviz DOT (integer node ids, quoted labels).

    States where the wheels may turn are filled; terminal states are double circles.
    """
    ids = {s: i for i, s in enumerate(SupervisorState)}
    lines = ["digraph supervisor {", "  rankdir=LR;", '  node [shape=circle, fontname="Helvetica"];', "  init [shape=point];"]
    for s, i in ids.items():
        attrs = [f'label="{s.value}"']
        if s in TERMINAL:
            attrs.append("shape=doublecircle")
        if s in MOTOR_STATES:
            attrs.append('style=filled, fillcolor="#c6e5c6"')
        if s is S.HALTED:
            attrs.append('color="#b22222"')
        lines.append(f"  {i} [{', '.join(attrs)}];")
    lines.append(f"  init -> {ids[S.IDLE]};")
    grouped: dict[tuple[int, int], list[str]] = {}
    for (src, ev), dst in TRANSITIONS.items():
        grouped.setdefault((ids[src], ids[dst]), []).append(ev.value)
    for (a, b), evs in sorted(grouped.items()):
        lines.append(f'  {a} -> {b} [label="{" | ".join(evs)}"];')
    lines.append("}")
    return "\n".join(lines) + "\n"


def state_machine_prism() -> str:
    """The supervisor's state machine as a PRISM MDP (events are nondeterministic choices).

    ``s`` is the state (numbered in :class:`SupervisorState` order), ``m`` is 1 while the
    wheels may turn. Terminal states loop on ``done``. Properties to check, e.g. with
    Storm: ``Pmax=? [F (m=1 & s!=EXECUTING)]`` = 0 (the wheels turn only in EXECUTING),
    ``Pmax=? [F (s=HALTED & m=1)]`` = 0, ``Pmax=? [F s=GOAL_REACHED]`` = 1.
    """
    ids = {s: i for i, s in enumerate(SupervisorState)}
    out = ["// clomp supervisor state machine (runtime.supervision.machine.state_machine_prism)", "mdp", ""]
    for s, i in ids.items():
        out.append(f"const int {s.value} = {i};")
    out += ["", "module supervisor", f"  s : [0..{len(ids) - 1}] init IDLE;", "  m : [0..1] init 0;"]
    for (src, ev), dst in TRANSITIONS.items():
        m = 1 if dst in MOTOR_STATES else 0
        out.append(f"  [{ev.value}] s={src.value} -> (s'={dst.value}) & (m'={m});")
    term = "|".join(f"s={s.value}" for s in SupervisorState if s in TERMINAL)
    out.append(f"  [done] {term} -> true;")
    out += ["endmodule", ""]
    out.append('label "motors" = m=1;')
    out.append('label "executing" = s=EXECUTING;')
    out.append('label "halted" = s=HALTED;')
    out.append('label "goal" = s=GOAL_REACHED;')
    out.append(f'label "terminal" = {term};')
    return "\n".join(out) + "\n"
