"""The cognitive map G = (Q, ↪): an explicit labelled transition system.

States are :class:`~clomp.formal.model.State` records keyed by their ident; transitions are
labelled with the task kind of their target (the task the Configurator starts when it
takes the transition). The map holds the goal D_G it was built for and exactly one
initial state q0. Iteration is always in a stable order (states by ident, transitions
by (source, target, label)), so that the same map renders to the same bytes.

Graph questions (from where a set of states can be reached, and any other a caller
asks) are answered by networkx on the map's one graph view, :meth:`CognitiveMap.to_networkx`,
which the map builds once and keeps until it changes; the two every plan asks (what is
reachable, a shortest path) by a breadth-first search over the map's own adjacency, with
the same answers (building the view cost more than the rest of a small plan's extraction).
"""

from __future__ import annotations

import json
import operator
import os
from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, fields
from fractions import Fraction
from typing import IO, Any

import networkx as nx
import numpy as np

from clomp.formal.model import Disturbance, State, TaskKind

__all__ = ["Transition", "CognitiveMap", "MapError", "FORMAT_VERSION", "MAX_MAP_BYTES"]

#: the version of the cognitive map's JSON format, written into every map and checked on load
FORMAT_VERSION = 1
#: a map file holds at most this many bytes (a 50-state map is about 100 kB)
MAX_MAP_BYTES = 64 * 1024 * 1024


class MapError(ValueError):
    """A map is malformed (unknown state, duplicate ident, unreadable JSON ...).

    >>> try:
    ...     CognitiveMap.from_dict({"format": "something else"})
    ... except MapError as exc:
    ...     print(exc)
    not a clomp cognitive map (missing 'format': 'clomp-cognitive-map')
    """


@dataclass(frozen=True, slots=True, order=True)
class Transition:
    """A transition q1 ↪ q2 labelled with the task of q2.

    ``probability`` is exact (a :class:`fractions.Fraction`); the Configurator's maps
    are deterministic (probability 1), a probabilistic map splits a (state, task)
    choice among several targets whose probabilities sum to 1.

    >>> t = Transition(0, 1, TaskKind.LEFT, Fraction(1, 2))
    >>> Transition.from_dict(t.to_dict()) == t, t.to_dict()["probability"]
    (True, '1/2')
    """

    source: int
    target: int
    label: TaskKind
    probability: Fraction = Fraction(1)

    def __hash__(self) -> int:
        # (source, target) only: equal transitions have equal ends, so this is a valid hash,
        # and it spares the two Python-level hashes of the dataclass's own (TaskKind's enum
        # hash and Fraction's), which Ψ's table pays for every transition of every plan
        return hash((self.source, self.target))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form; the probability as an exact ``"p/q"`` string."""
        return {
            "source": self.source,
            "target": self.target,
            "label": self.label.value,
            "probability": str(self.probability),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "Transition":
        """Inverse of :meth:`to_dict`."""
        return cls(
            int(data["source"]),
            int(data["target"]),
            TaskKind(data["label"]),
            Fraction(str(data.get("probability", "1"))),
        )


_ONE = Fraction(1)
_ORDER = operator.attrgetter("source", "target", "label")
# Transition(...) through the slots' own setters (a frozen dataclass's __init__ goes through
# object.__setattr__ per field): the same record, for the maps the planner grows
_T_SETTERS = tuple(Transition.__dict__[name].__set__ for name in ("source", "target", "label", "probability"))
if tuple(f.name for f in fields(Transition)) != ("source", "target", "label", "probability"):  # pragma: no cover
    raise ImportError("clomp.formal.lts: _transition() names Transition's fields in another order than Transition has them")
_set_source, _set_target, _set_label, _set_probability = _T_SETTERS
_new = object.__new__


def _transition(source: int, target: int, label: TaskKind, probability: Fraction) -> Transition:
    """``Transition(source, target, label, probability)``, built at less than half the cost.

    >>> _transition(0, 1, TaskKind.LEFT, _ONE) == Transition(0, 1, TaskKind.LEFT)
    True
    """
    t: Transition = _new(Transition)
    _set_source(t, source)
    _set_target(t, target)
    _set_label(t, label)
    _set_probability(t, probability)
    return t


def _json_ready(value: Any) -> Any:
    """A metadata value as JSON holds it: a numpy array (the planner keeps its obstacle
    boxes as one, converting them only when the map is written) becomes nested lists.

    >>> import numpy as np
    >>> _json_ready(np.zeros((1, 2))), _json_ready([1, 2])
    ([[0.0, 0.0]], [1, 2])
    """
    return value.tolist() if isinstance(value, np.ndarray) else value


class CognitiveMap:
    """An explicit labelled transition system of simulated task outcomes.

    >>> from clomp.formal.model import Pose, State, TaskKind, Disturbance
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap(goal=g)
    >>> q0 = m.add_state(State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)))
    >>> q1 = m.add_state(State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0)))
    >>> m.add_transition(0, 1)
    Transition(source=0, target=1, label=<TaskKind.STRAIGHT: 'STRAIGHT'>, probability=Fraction(1, 1))
    >>> [s.ident for s in m.successors(0)]
    [1]
    """

    def __init__(self, goal: Disturbance | None = None, initial: int | None = None) -> None:
        self.goal: Disturbance | None = goal
        self._initial: int | None = initial
        self._states: dict[int, State] = {}
        self._out: dict[int, dict[tuple[int, TaskKind], Transition]] = {}
        self._graph: Any = None  # the networkx view, built on demand, dropped on every change
        self.metadata: dict[str, Any] = {}
        """What the builder records beside the map (JSON-ready values, or numpy arrays,
        which :meth:`to_dict` writes as nested lists)."""

    # -- construction -------------------------------------------------------------
    def add_state(self, state: State) -> State:
        """Add ``state``; the first state added becomes q0 unless one was named."""
        if state.ident in self._states:
            raise MapError(f"duplicate state ident {state.ident}")
        self._states[state.ident] = state
        self._out.setdefault(state.ident, {})
        self._graph = None
        if self._initial is None:
            self._initial = state.ident
        return state

    def replace_state(self, state: State) -> None:
        """Replace the record of an existing state (same ident), e.g. to set its cost."""
        if state.ident not in self._states:
            raise MapError(f"no state q{state.ident}")
        self._states[state.ident] = state
        self._graph = None

    def add_transition(
        self,
        source: int,
        target: int,
        label: TaskKind | None = None,
        probability: Fraction | int | str = 1,
    ) -> Transition:
        """Add q_source ↪ q_target; the label defaults to the target's task."""
        states = self._states
        for ident in (source, target):
            if ident not in states:
                raise MapError(f"transition names unknown state q{ident}")
        if label is None:
            label = states[target].task
        # the common case (a TaskKind, probability 1) without conversions: maps grow in the
        # planner's hot path
        kind = label if type(label) is TaskKind else TaskKind(label)
        p = _ONE if probability == 1 and type(probability) in (int, Fraction) else Fraction(probability)
        t = _transition(source, target, kind, p)
        self._out[source][(target, t.label)] = t
        self._graph = None
        return t

    def set_initial(self, ident: int) -> None:
        """Name q0."""
        if ident not in self._states:
            raise MapError(f"no state q{ident}")
        self._initial = ident
        self._graph = None

    # -- queries --------------------------------------------------------------------
    @property
    def initial(self) -> State:
        """q0, the initial state."""
        if self._initial is None or self._initial not in self._states:
            raise MapError("map has no initial state")
        return self._states[self._initial]

    @property
    def initial_id(self) -> int | None:
        """The ident of q0, or None for an empty map."""
        return self._initial

    def __len__(self) -> int:
        return len(self._states)

    def __contains__(self, ident: object) -> bool:
        return ident in self._states

    def __getitem__(self, ident: int) -> State:
        try:
            return self._states[ident]
        except KeyError:
            raise MapError(f"no state q{ident}") from None

    def __iter__(self) -> Iterator[State]:
        return iter(self.states())

    def states(self) -> list[State]:
        """All states, by ident."""
        return [self._states[k] for k in sorted(self._states)]

    def transitions(self) -> list[Transition]:
        """All transitions, sorted by (source, target, label)."""
        # (source, target, label) is unique in a map, so this key orders as the dataclass's
        # own comparison does, without building two tuples per comparison
        return sorted((t for out in self._out.values() for t in out.values()), key=_ORDER)

    @property
    def n_transitions(self) -> int:
        """The number of transitions."""
        return sum(len(out) for out in self._out.values())

    def out_transitions(self, ident: int) -> list[Transition]:
        """Transitions leaving q_ident, sorted."""
        return sorted(self._out[self[ident].ident].values())

    def successors(self, ident: int) -> list[State]:
        """States reachable from q_ident in one transition, by ident, without repeats."""
        return [self._states[i] for i in sorted({t.target for t in self._out[self[ident].ident].values()})]

    def has_transition(self, source: int, target: int) -> bool:
        """True when some transition q_source ↪ q_target exists."""
        out = self._out.get(source)
        if not out:
            return False
        for k in out:
            if k[0] == target:
                return True
        return False

    def reachable(self, source: int | None = None) -> set[int]:
        """Idents reachable from ``source`` (default q0), itself included.

        >>> from clomp.formal.model import Pose
        >>> m = CognitiveMap()
        >>> for i in range(4):
        ...     _ = m.add_state(State(i, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(i, 0)))
        >>> _ = m.add_transition(0, 1); _ = m.add_transition(1, 2); _ = m.add_transition(3, 0)
        >>> sorted(m.reachable()), sorted(m.reachable(3))
        ([0, 1, 2], [0, 1, 2, 3])
        """
        start = self.initial.ident if source is None else self[source].ident
        # a search over the map's own adjacency: the planner asks this of every map it
        # builds, and the networkx view cost more than the rest of a small plan's extraction
        out = {start}
        todo = [start]
        adjacency = self._out
        while todo:
            for target, _ in adjacency[todo.pop()]:
                if target not in out:
                    out.add(target)
                    todo.append(target)
        return out

    def coreachable(self, targets: Iterable[int]) -> set[int]:
        """Idents from which some state of ``targets`` is reachable, ``targets`` included
        (the states that are not blocking with respect to ``targets``).

        >>> from clomp.formal.model import Pose
        >>> m = CognitiveMap()
        >>> for i in range(4):
        ...     _ = m.add_state(State(i, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(i, 0)))
        >>> _ = m.add_transition(0, 1); _ = m.add_transition(1, 2); _ = m.add_transition(0, 3)
        >>> sorted(m.coreachable([2]))
        [0, 1, 2]
        """
        ends = sorted({self[i].ident for i in targets})
        if not ends:
            return set()
        back = self.to_networkx().reverse(copy=False)
        return {i for layer in nx.bfs_layers(back, ends) for i in layer}

    def path(self, target: int, source: int | None = None) -> list[int]:
        """A shortest path (fewest transitions) of idents from ``source`` (q0) to ``target``.

        Ties are broken towards lower idents (a breadth-first search that visits each
        state's successors in ascending order), so the path is deterministic. Raises
        :class:`MapError` when ``target`` is not reachable.
        """
        start = self.initial.ident if source is None else self[source].ident
        self[target]
        parent: dict[int, int] = {start: start}
        if target != start:
            # breadth first over the map's own adjacency, each state's successors in
            # ascending order (as networkx's bfs_edges with sort_neighbors=sorted visits them)
            adjacency = self._out
            queue = deque([start])
            while queue:
                u = queue.popleft()
                for v in sorted({k[0] for k in adjacency[u]}):
                    if v not in parent:
                        parent[v] = u
                        if v == target:
                            break
                        queue.append(v)
                else:
                    continue
                break
            else:
                raise MapError(f"q{target} is not reachable from q{start}")
        out = [target]
        while out[-1] != start:
            out.append(parent[out[-1]])
        return out[::-1]

    # -- conversions ---------------------------------------------------------------
    def to_networkx(self) -> Any:
        """The map's one graph view: a frozen :class:`networkx.MultiDiGraph` whose nodes
        are the idents (attributes ``state``, ``task``, ``interrupted``, ``cost``), added by
        ident, and whose edges are the transitions, added in the map's stable order (key
        and ``label``: the task name; ``probability``). Built once and kept until the map
        changes; frozen because it is shared (``networkx.MultiDiGraph(view)`` makes a
        copy to change).

        >>> from clomp.formal.model import Pose
        >>> m = CognitiveMap()
        >>> for i in range(2):
        ...     _ = m.add_state(State(i, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(i, 0)))
        >>> _ = m.add_transition(0, 1)
        >>> g = m.to_networkx()
        >>> list(g.edges(keys=True)), g is m.to_networkx()
        ([(0, 1, 'STRAIGHT')], True)
        """
        goal = None if self.goal is None else (self.goal.x, self.goal.y)
        g = self._graph
        if g is not None and g.graph["goal"] == goal:
            return g
        g = nx.MultiDiGraph(initial=self._initial, goal=goal)
        for s in self.states():
            g.add_node(s.ident, state=s, task=s.task.value, interrupted=s.interrupted, cost=s.cost)
        for t in self.transitions():
            g.add_edge(t.source, t.target, key=t.label.value, label=t.label.value, probability=t.probability)
        self._graph = nx.freeze(g)
        return self._graph

    def to_dict(self) -> dict[str, Any]:
        """The lossless JSON form."""
        return {
            "format": "clomp-cognitive-map",
            "version": FORMAT_VERSION,
            "goal": None if self.goal is None else self.goal.to_dict(),
            "initial": self._initial,
            "states": [s.to_dict() for s in self.states()],
            "transitions": [t.to_dict() for t in self.transitions()],
            "metadata": {k: _json_ready(v) for k, v in self.metadata.items()},
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "CognitiveMap":
        """Inverse of :meth:`to_dict`; raises :class:`MapError` on a malformed document."""
        if not isinstance(data, dict) or data.get("format") != "clomp-cognitive-map":
            raise MapError("not a clomp cognitive map (missing 'format': 'clomp-cognitive-map')")
        version = data.get("version")
        if version != FORMAT_VERSION or isinstance(version, bool):
            raise MapError(
                f"cognitive map format version {version!r} is not supported (this clomp reads version {FORMAT_VERSION})"
            )
        try:
            goal = None if data.get("goal") is None else Disturbance.from_dict(data["goal"])
            m = cls(goal=goal)
            for sd in data["states"]:
                m.add_state(State.from_dict(sd))
            for td in data["transitions"]:
                t = Transition.from_dict(td)
                m.add_transition(t.source, t.target, t.label, t.probability)
            init = data.get("initial")
            m._initial = None if init is None else int(init)
            if m._initial is not None and m._initial not in m._states:
                raise MapError(f"initial state q{m._initial} is not in the map")
            m.metadata = dict(data.get("metadata", {}))
        except MapError:
            raise
        except (KeyError, TypeError, ValueError) as exc:
            raise MapError(f"malformed cognitive map: {exc!r}") from None
        return m

    def write_json(self, dest: str | os.PathLike[str] | IO[str], indent: int | None = 1) -> None:
        """Write the JSON form to a path or an open text file."""
        text = json.dumps(self.to_dict(), indent=indent, allow_nan=False)
        if hasattr(dest, "write"):
            dest.write(text + "\n")
        else:
            with open(dest, "w", encoding="utf-8") as fh:
                fh.write(text + "\n")

    @classmethod
    def read_json(cls, src: str | os.PathLike[str] | IO[str]) -> "CognitiveMap":
        """Read a map written by :meth:`write_json` from a path or an open text file.

        A path that is no regular file (a FIFO would block, ``/dev/zero`` never ends) or
        holds more than :data:`MAX_MAP_BYTES` is a :class:`MapError`, as is anything that
        is not a map's JSON (binary content, nesting too deep to decode)."""
        try:
            if hasattr(src, "read"):
                data = json.load(src)  # type: ignore[arg-type]
            else:
                if not os.path.isfile(src):
                    raise MapError("not a regular file (a folder, FIFO, device or socket)")
                if os.path.getsize(src) > MAX_MAP_BYTES:
                    raise MapError(f"larger than the {MAX_MAP_BYTES // 2**20} MiB limit for a map")
                with open(src, encoding="utf-8") as fh:
                    data = json.load(fh)
        except json.JSONDecodeError as exc:
            raise MapError(f"not valid JSON: {exc}") from None
        except UnicodeDecodeError:
            raise MapError("not a text file (binary content)") from None
        except (RecursionError, ValueError) as exc:  # nested too deep; an integer too long to decode
            raise MapError(f"not valid JSON: {str(exc)[:80]}") from None
        return cls.from_dict(data)

    def __getstate__(self) -> dict[str, Any]:
        # copies and pickles leave the graph view behind: it is rebuilt on demand
        return {**self.__dict__, "_graph": None}

    # a map is mutable (states and transitions are added to it), so it is not hashable:
    # equal maps must hash alike, and a map's contents may change while it is in a set
    __hash__ = None  # type: ignore[assignment]

    def __eq__(self, other: object) -> bool:
        """Equal goal, initial state, states and transitions (metadata is not compared)."""
        if not isinstance(other, CognitiveMap):
            return NotImplemented
        return (
            self.goal == other.goal
            and self._initial == other._initial
            and self.states() == other.states()
            and self.transitions() == other.transitions()
        )

    def __repr__(self) -> str:
        return f"CognitiveMap({len(self)} states, {self.n_transitions} transitions, q0=q{self._initial})"

    @classmethod
    def from_parts(
        cls,
        states: Iterable[State],
        transitions: Iterable[tuple[int, int]] | Iterable[Transition],
        goal: Disturbance | None = None,
        initial: int | None = None,
    ) -> "CognitiveMap":
        """Build a map by hand from states and (source, target) pairs or transitions."""
        m = cls(goal=goal)
        for s in states:
            m.add_state(s)
        for t in transitions:
            if isinstance(t, Transition):
                m.add_transition(t.source, t.target, t.label, t.probability)
            else:
                m.add_transition(*t)
        if initial is not None:
            m.set_initial(initial)
        return m
