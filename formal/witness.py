"""Witness paths of violated properties as data a user can load: states, actions, labels.

:func:`witness_trace` turns a path of Storm states (what
:func:`clomp.formal.checking.check_properties` finds for a failed requirement) into one
record per state: the map state (``q<ident>``), its labels, and the action taken from
it to the next state of the path, read from Storm's choice labels (a PRISM-language
model), from the DRN file's ``action`` lines (Storm does not keep them) or, for a
cognitive map, from its transitions. ``clomp check --witness FILE`` writes them as JSON.

>>> drn_actions("@model\\nstate 0 [0, 0] init\\n\\taction LEFT [0, 0]\\n\\t\\t1 : 1\\nstate 1 goal\\n\\taction stay [0, 0]\\n\\t\\t1 : 1")
[['LEFT'], ['stay']]
"""

from __future__ import annotations

import re
from typing import Any

__all__ = ["drn_actions", "witness_trace"]


def drn_actions(text: str) -> list[list[str]]:
    """The action names of each ``state`` of a DRN text, in the file's order (Storm keeps
    the file's state and choice order, but not the names)."""
    out: list[list[str]] = []
    for line in text.splitlines():
        word = line.split()
        if line.startswith("state "):
            out.append([])
        elif word and word[0] == "action" and out:
            out[-1].append(word[1])
    return out


def _action(sm: Any, state: int, following: int) -> str | None:
    """The name of the action of ``state`` that can lead to ``following`` (None: unnamed)."""
    model = sm.model
    row0 = int(model.transition_matrix.get_row_group_start(state))
    for k, action in enumerate(model.states[state].actions):
        if not any(int(t.column) == following for t in action.transitions):
            continue
        if model.has_choice_labeling():
            names = sorted(model.choice_labeling.get_labels_of_choice(row0 + k))
            return names[0] if names else None
        named = sm.actions[state] if sm.actions is not None and state < len(sm.actions) else []
        return named[k] if k < len(named) and sm.kind == "mdp" else None
    return None


def witness_trace(sm: Any, states: list[int], tasks: dict[tuple[int, int], str] | None = None) -> list[dict[str, Any]]:
    """One record per state of the path ``states`` (Storm states of the
    :class:`~clomp.formal.checking.StormModel` ``sm``): ``state`` (``q<ident>``), ``ident``,
    ``labels`` (without the ``q<ident>`` ones) and ``action`` to the next state (None on
    the last, or where no name is known); ``tasks`` maps (ident, next ident) to the task of
    a cognitive map's transition, for models whose choices carry no name (a DTMC's DRN)."""
    out = []
    for i, s in enumerate(states):
        ident = int(sm.idents[s])
        action = None
        if i + 1 < len(states):
            action = _action(sm, s, states[i + 1])
            if action is None and tasks is not None:
                action = tasks.get((ident, int(sm.idents[states[i + 1]])))
        labels = sorted(lab for lab in sm.labels_of(s) if not re.fullmatch(r"q\d+", lab))
        out.append({"state": f"q{ident}", "ident": ident, "labels": labels, "action": action})
    return out
