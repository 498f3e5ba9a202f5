"""Model checking exported maps with Storm (stormpy), and the property-file format.

Property files (``specs/properties/*.pctl``) hold PCTL properties in PRISM syntax, one
per line::

    // @model dtmc                      which model the file is about: mdp | dtmc
    // Under Ψ the robot never collides.  ← comment lines above a property describe it
    // @required = 0                    ← the next property must give 0 (or: true, false,
    "no_collision": P=? [F "collision"]    <= 0.5, >= 1 …); without it, it is reported only

``//`` starts a comment; blank lines are ignored; ``"name":`` before a formula names it.
``@model`` appears once, before the first property. A ``@required`` line applies to the
next property. Anything else starting with ``// @`` is a syntax error, and so is a
property line that is not a P, R or S query (errors name the file and line).

stormpy is an optional dependency (``pip install -e '.[verify]'``): it is imported
inside the functions that need it, and :class:`StormMissing` says how to install it.
Storm renumbers states, so results are mapped back to map states through the ``q``
variable (PRISM language) or the ``q<ident>`` labels (DRN), never by index.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import networkx as nx

from clomp.formal.export import ExportModel, ModelKind, export_model, write_drn, write_prism
from clomp.formal.invariants import map_plan
from clomp.formal.lts import CognitiveMap, MapError
from clomp.formal.toolio import captured_fds
from clomp.formal.witness import drn_actions, witness_trace

__all__ = [
    "SpecError",
    "StormMissing",
    "Requirement",
    "PropertySpec",
    "PropertyFile",
    "CheckResult",
    "StormModel",
    "parse_properties",
    "read_properties",
    "default_property_files",
    "shipped_property_files",
    "closed_loop_property_files",
    "meant_for",
    "property_labels",
    "file_labels",
    "require_stormpy",
    "build_storm_model",
    "load_storm_model",
    "check_properties",
    "check_map_properties",
    "plan_distance",
    "DistanceComparison",
    "compare_distance",
    "TOLERANCE",
]

TOLERANCE = 1e-6
"""Absolute tolerance when comparing a numeric result with a required value."""

INSTALL_HINT = "pip install -e '.[verify]' (from the clomp source folder, as in the README)"


class SpecError(ValueError):
    """A property file is malformed; the message names the file and line."""


class StormMissing(RuntimeError):
    """stormpy is not installed."""

    def __init__(self) -> None:
        super().__init__(f"model checking needs stormpy, which is not installed: {INSTALL_HINT}")


def require_stormpy() -> Any:
    """Import and return :mod:`stormpy`, or raise :class:`StormMissing` with the install hint."""
    try:
        import stormpy
    except ImportError:
        raise StormMissing() from None
    return stormpy


# -- the property-file format ----------------------------------------------------------------------
_OPS = ("<=", ">=", "<", ">", "=")


@dataclass(frozen=True, slots=True)
class Requirement:
    """What a required property must give: ``op value`` (``value`` a number or a bool)."""

    op: str
    value: float | bool

    @classmethod
    def parse(cls, text: str) -> "Requirement":
        """``"true"``, ``"false"``, ``"0"``, ``"= 1"``, ``"<= 0.5"`` …; ValueError otherwise."""
        t = text.strip()
        if t.lower() in ("true", "false"):
            return cls("=", t.lower() == "true")
        op = next((o for o in _OPS if t.startswith(o)), "=")
        number = t[len(op) :].strip() if t.startswith(op) else t
        value = float(number)
        if math.isnan(value):
            raise ValueError("NaN is not a value")
        return cls(op, value)

    def holds(self, result: float | bool) -> bool:
        """Whether ``result`` meets the requirement (numbers within :data:`TOLERANCE`)."""
        if isinstance(self.value, bool):
            return isinstance(result, bool) and result is self.value
        if isinstance(result, bool):
            return False
        x, v = float(result), float(self.value)
        close = x == v or abs(x - v) <= TOLERANCE
        return {
            "=": close,
            "<=": x <= v or close,
            ">=": x >= v or close,
            "<": x < v and not close,
            ">": x > v and not close,
        }[self.op]

    def __str__(self) -> str:
        if isinstance(self.value, bool):
            return str(self.value).lower()
        return f"{self.op} {self.value:g}"


@dataclass(frozen=True, slots=True)
class PropertySpec:
    """One property of a file: formula, name, description, requirement (None = report only)."""

    formula: str
    name: str
    description: str = ""
    required: Requirement | None = None
    line: int = 0


@dataclass(frozen=True)
class PropertyFile:
    """A parsed property file: the model kind it is about and its properties."""

    model: ModelKind
    properties: tuple[PropertySpec, ...]
    source: str = "<string>"


_NAME = re.compile(r'^"([A-Za-z_][A-Za-z0-9_]*)"\s*:\s*(.*)$')
_QUERY = re.compile(r"^(!?\s*\"[A-Za-z_][A-Za-z0-9_]*\"\s*[|&]\s*)*!?\s*\(?\s*[PRS](\{\"[A-Za-z_][A-Za-z0-9_]*\"\})?(min|max)?\s*(=\?|[<>]=?\s*[0-9.eE+-]+)\s*\[")


@dataclass
class _Parse:
    """What :func:`parse_properties` has read so far."""

    source: str
    model: str | None = None
    props: list[PropertySpec] = field(default_factory=list)
    comments: list[str] = field(default_factory=list)
    required: Requirement | None = None
    req_line: int = 0
    names: set[str] = field(default_factory=set)

    def directive(self, body: str, n: int, where: str) -> None:
        """A ``// @key arg`` line."""
        key, _, arg = body[1:].partition(" ")
        if key == "model":
            if self.model is not None or self.props:
                raise SpecError(f"{where}: @model must appear once, before the first property")
            if arg.strip() not in ("mdp", "dtmc"):
                raise SpecError(f"{where}: @model must be 'mdp' or 'dtmc', got {arg.strip()!r}")
            self.model = arg.strip()
        elif key == "required":
            if self.required is not None:
                raise SpecError(f"{where}: two @required lines for one property")
            try:
                self.required = Requirement.parse(arg)
            except ValueError:
                raise SpecError(f"{where}: @required expects true, false or [op] number, got {arg.strip()!r}") from None
            self.req_line = n
        else:
            raise SpecError(f"{where}: unknown directive @{key} (expected @model or @required)")

    def property(self, line: str, n: int, where: str) -> None:
        """A property line, with the comments and requirement above it."""
        m = _NAME.match(line)
        name, formula = (m.group(1), m.group(2).strip()) if m else (None, line)
        formula = formula.rstrip(";").strip()
        if not _QUERY.match(formula) or formula.count("[") != formula.count("]") or formula.count("(") != formula.count(")"):
            raise SpecError(f"{where}: not a PCTL property (expected e.g. P=? [F \"goal\"]): {line!r}")
        if self.model is None:
            raise SpecError(f"{where}: a property before '// @model mdp|dtmc'")
        name = name or formula
        if name in self.names:
            raise SpecError(f"{where}: duplicate property name {name!r}")
        self.names.add(name)
        self.props.append(PropertySpec(formula, name, " ".join(self.comments), self.required, n))
        self.comments, self.required = [], None

    def done(self) -> PropertyFile:
        """The parsed file, once every line is read."""
        if self.required is not None:
            raise SpecError(f"{self.source}:{self.req_line}: @required is not followed by a property")
        if self.model is None:
            raise SpecError(f"{self.source}: no '// @model mdp|dtmc' line")
        if not self.props:
            raise SpecError(f"{self.source}: no properties")
        return PropertyFile(self.model, tuple(self.props), self.source)  # type: ignore[arg-type]


def parse_properties(text: str, source: str = "<string>") -> PropertyFile:
    """Parse the property-file format (see the module docstring); raises :class:`SpecError`.

    >>> pf = parse_properties('// @model dtmc\\n// Never a collision.\\n// @required = 0\\n"safe": P=? [F "collision"]')
    >>> pf.model, pf.properties[0].name, pf.properties[0].description, str(pf.properties[0].required)
    ('dtmc', 'safe', 'Never a collision.', '= 0')
    """
    state = _Parse(source)
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        where = f"{source}:{n}"
        if not line:
            state.comments = []
        elif not line.startswith("//"):
            state.property(line, n, where)
        elif line[2:].strip().startswith("@"):
            state.directive(line[2:].strip(), n, where)
        else:
            state.comments.append(line[2:].strip())
    return state.done()


def read_properties(path: str | os.PathLike[str]) -> PropertyFile:
    """Read and parse a property file; :class:`SpecError` when unreadable or malformed."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: cannot read property file: {exc}") from None
    return parse_properties(text, str(path))


def default_property_files() -> list[Path]:
    """The property files shipped in ``specs/properties/`` for cognitive maps."""
    from clomp import specs
    folder = Path(specs.__file__).resolve().parent / "properties"
    return sorted(folder.glob("*.pctl"))


def shipped_property_files() -> list[Path]:
    """Every property file shipped in ``specs/properties/``, the supervisor's
    (``supervisor/machine.pctl``) included."""
    from clomp import specs
    return sorted((Path(specs.__file__).resolve().parent / "properties").rglob("*.pctl"))


def closed_loop_property_files() -> list[Path]:
    """The property files of the closed loop's model (``specs/properties/closed_loop/``)."""
    return [p for p in shipped_property_files() if p.parent.name == "closed_loop"]


def meant_for(pf: PropertyFile, kind: str, labels: set[str]) -> bool:
    """Whether the shipped file ``pf`` is about a ``kind`` model declaring ``labels``: its
    kind, every label it names declared, and the closed loop's files (``closed_loop/``)
    for exactly the closed loop's models (those declaring ``interrupted``).

    >>> pf = parse_properties('// @model dtmc\\n"p": P=? [F "goal"]', "specs/properties/closed_loop/plan.pctl")
    >>> meant_for(pf, "dtmc", {"goal", "interrupted"}), meant_for(pf, "dtmc", {"goal"}), meant_for(pf, "mdp", {"goal", "interrupted"})
    (True, False, False)
    """
    from clomp.formal.retry import INTERRUPTED

    closed = Path(pf.source).parent.name == "closed_loop"
    return pf.model == kind and property_labels(pf) <= labels and closed == (INTERRUPTED in labels)


_LABEL_REF = re.compile(r'(?<!\{)"([A-Za-z_][A-Za-z0-9_]*)"')


def property_labels(pf: PropertyFile) -> set[str]:
    """The labels the formulas of ``pf`` name (reward names ``R{"…"}`` excluded).

    >>> sorted(property_labels(parse_properties('// @model mdp\\n"d": R{"time"}min=? [!"collision" U "goal"]')))
    ['collision', 'goal']
    """
    return {name for p in pf.properties for name in _LABEL_REF.findall(p.formula)}


def file_labels(path: str | os.PathLike[str]) -> set[str]:
    """The labels a written ``.prism`` or ``.drn`` model declares (read from its text)."""
    text = Path(path).read_text(encoding="utf-8", errors="replace")
    if Path(path).suffix == ".drn":
        found = {"init"}
        for line in text.splitlines():
            if line.startswith("state "):
                found.update(line.split("]", 1)[1].split() if "]" in line else line.split()[2:])
        return found
    return {"init", *re.findall(r'^\s*label\s+"([A-Za-z_][A-Za-z0-9_]*)"', text, re.M)}


# -- building models with Storm ----------------------------------------------------------------------
@dataclass
class StormModel:
    """A model Storm built, with the map ident of each Storm state (found by label or valuation)."""

    model: Any
    kind: ModelKind
    idents: list[int]
    program: Any = None
    source: str = ""
    actions: list[list[str]] | None = None  # a DRN's action names per state (Storm drops them)
    _graph: nx.DiGraph | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def n_states(self) -> int:
        """Number of states Storm built."""
        return int(self.model.nr_states)

    @property
    def n_transitions(self) -> int:
        """Number of transitions (matrix entries) Storm built."""
        return int(self.model.nr_transitions)

    def graph(self) -> nx.DiGraph:
        """Storm's states and transitions as a :class:`networkx.DiGraph` (each state's
        successors in matrix order), built once."""
        if self._graph is None:
            g = nx.DiGraph()
            for s in range(self.n_states):
                g.add_node(s)
                g.add_edges_from((s, t) for t in self.successors(s))
            self._graph = g
        return self._graph

    def reachable(self) -> list[int]:
        """Storm states reachable from the initial states, sorted (a DRN file's
        :data:`~clomp.formal.export.LABEL_HOLDER` state is not among them)."""
        starts = [int(s) for s in self.model.initial_states]
        return sorted(s for layer in nx.bfs_layers(self.graph(), starts) for s in layer)

    def reachable_size(self) -> tuple[int, int]:
        """(states, transitions) reachable from the initial states: what PRISM, which
        builds only reachable states, reports for the same model."""
        states = self.reachable()
        n = 0
        for s in states:
            for action in self.model.states[s].actions:
                n += len(list(action.transitions))
        return len(states), n

    def labels_of(self, state: int) -> set[str]:
        """The labels of Storm state ``state``."""
        return set(self.model.labeling.get_labels_of_state(state))

    def successors(self, state: int) -> list[int]:
        """Storm states reachable in one step from ``state``, in matrix order."""
        out: list[int] = []
        for action in self.model.states[state].actions:
            for t in action.transitions:
                if t.column not in out:
                    out.append(int(t.column))
        return out

    def describe(self, state: int) -> str:
        """``q12[collision]``: the map state and its interesting labels."""
        extra = sorted(lab for lab in self.labels_of(state) if not re.fullmatch(r"q\d+", lab) and lab not in ("init", "plan", "goal_in_map"))
        return f"q{self.idents[state]}" + (f"[{','.join(extra)}]" if extra else "")


def _idents_from(model: Any) -> list[int]:
    out = []
    for s in range(model.nr_states):
        ident = None
        if model.has_state_valuations():
            data = json.loads(str(model.state_valuations.to_json(s)))
            if "q" in data:
                ident = int(data["q"])
        if ident is None:
            found = [lab for lab in model.labeling.get_labels_of_state(s) if re.fullmatch(r"q\d+", lab)]
            ident = int(found[0][1:]) if len(found) == 1 else -1
        out.append(ident)
    return out


def load_storm_model(path: str | os.PathLike[str]) -> StormModel:
    """Build a ``.prism`` or ``.drn`` file with Storm (the kind is read from the file)."""
    stormpy = require_stormpy()
    p = Path(path)
    if not p.is_file():
        raise MapError(f"{p}: no such file")
    if p.suffix not in (".drn", ".prism", ".pm", ".nm"):
        raise MapError(f"{p}: Storm builds .prism or .drn files (got {p.suffix or 'no suffix'})")
    try:
        with captured_fds():  # Storm's C++ log stays off stdout; its exception says what failed
            if p.suffix == ".drn":
                model = stormpy.build_model_from_drn(str(p))
                program, actions = None, drn_actions(p.read_text(encoding="utf-8", errors="replace"))
            else:
                program, actions = stormpy.parse_prism_program(str(p)), None
                options = stormpy.BuilderOptions(build_full=True)
                options.set_build_choice_labels(True)  # the commands' actions, for witness paths
                model = stormpy.build_model(program, options=options)
    except RuntimeError as exc:
        raise MapError(f"{p}: Storm cannot build the model: {str(exc).strip()}") from None
    kind: ModelKind = "mdp" if "Mdp" in type(model).__name__ else "dtmc"
    return StormModel(model, kind, _idents_from(model), program, str(p), actions)


def build_storm_model(
    source: CognitiveMap | ExportModel,
    kind: ModelKind = "mdp",
    via: str = "drn",
    workdir: str | os.PathLike[str] | None = None,
) -> StormModel:
    """Export ``source`` (as ``via`` = ``"drn"`` or ``"prism"``) and build it with Storm."""
    require_stormpy()
    m = source if isinstance(source, ExportModel) else export_model(source, kind)
    writer = {"drn": write_drn, "prism": write_prism}.get(via)
    if writer is None:
        raise ValueError(f"via must be 'drn' or 'prism', got {via!r}")
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        path = Path(tmp) / f"map-{m.kind}.{via}"
        writer(m, path)
        return load_storm_model(path)


# -- checking -----------------------------------------------------------------------------------
@dataclass
class CheckResult:
    """The outcome of one property on one model."""

    spec: PropertySpec
    kind: ModelKind
    value: float | bool
    passed: bool | None  # None: not required
    witness: list[str] = field(default_factory=list)
    trace: list[dict[str, Any]] = field(default_factory=list)
    """The witness as records: state, ident, labels, action (:func:`~clomp.formal.witness.witness_trace`)."""

    @property
    def verdict(self) -> str:
        """``pass``, ``FAIL`` or ``-`` (reported only)."""
        return "-" if self.passed is None else ("pass" if self.passed else "FAIL")

    def value_text(self) -> str:
        """The result as printed in the table."""
        if isinstance(self.value, bool):
            return str(self.value).lower()
        return f"{self.value:.6g}"


def _value(result: Any, state: int) -> float | bool:
    if result.is_qualitative():
        return bool(result[state])
    return float(result.get_value(state))


def check_properties(sm: StormModel, props: PropertyFile | Iterable[PropertySpec]) -> list[CheckResult]:
    """Check every property on ``sm`` (values at the initial state).

    A failed required property gets a witness: the shortest path (map states with their
    labels) from the initial state to an absorbing state whose own value violates the
    requirement, e.g. the way into a collision. Raises :class:`SpecError` when Storm
    cannot parse a property for this model.
    """
    stormpy = require_stormpy()
    specs = props.properties if isinstance(props, PropertyFile) else tuple(props)
    source = props.source if isinstance(props, PropertyFile) else "<properties>"
    init = int(sm.model.initial_states[0])
    out = []
    for spec in specs:
        try:
            with captured_fds():  # Storm's C++ log stays off stdout; its exception says what failed
                parsed = stormpy.parse_properties(spec.formula, sm.program) if sm.program is not None else stormpy.parse_properties(spec.formula)
                if len(parsed) != 1:
                    raise RuntimeError(f"expected one property, got {len(parsed)}")
                result = stormpy.model_checking(sm.model, parsed[0], only_initial_states=False)
        except RuntimeError as exc:
            raise SpecError(f"{source}:{spec.line}: Storm cannot check {spec.formula!r}: {str(exc).strip()}") from None
        value = _value(result, init)
        passed = None if spec.required is None else spec.required.holds(value)
        path: list[int] = []
        if passed is False:
            path = _target_witness(sm, spec) or _witness(sm, result, spec.required)  # type: ignore[arg-type]
        out.append(CheckResult(spec, sm.kind, value, passed, [sm.describe(x) for x in path], witness_trace(sm, path)))
    return out


_EVENTUALLY = re.compile(r"^P(?:min|max)?\s*=\?\s*\[\s*(?:F|.+?\sU)\s+(.+)\]$")


def _target_witness(sm: StormModel, spec: PropertySpec) -> list[int]:
    """For ``P=? [F ψ]`` / ``[φ U ψ]`` that came out too high: a shortest path to a state
    where ψ holds (the violation itself); [] when the property is not of that shape."""
    req = spec.required
    if req is None or isinstance(req.value, bool) or req.op not in ("=", "<=", "<"):
        return []
    m = _EVENTUALLY.match(spec.formula.strip())
    if m is None:
        return []
    stormpy = require_stormpy()
    try:
        with captured_fds():
            parsed = stormpy.parse_properties(m.group(1), sm.program) if sm.program is not None else stormpy.parse_properties(m.group(1))
            result = stormpy.model_checking(sm.model, parsed[0], only_initial_states=False)
    except RuntimeError:
        return []
    if not result.is_qualitative():
        return []
    path = _shortest_path_to(sm.graph(), int(sm.model.initial_states[0]), lambda s: bool(result[s]))
    return path or []


def _witness(sm: StormModel, result: Any, req: Requirement) -> list[int]:
    """A shortest path to an absorbing state whose own value violates ``req``."""
    g = sm.graph()
    start = int(sm.model.initial_states[0])
    path = _shortest_path_to(g, start, lambda s: list(g.successors(s)) == [s] and not req.holds(_value(result, s)))
    return path or [start]


def _shortest_path_to(g: nx.DiGraph, start: int, accept: Callable[[int], bool]) -> list[int] | None:
    """A shortest path from ``start`` to the first state, breadth-first, that ``accept``s;
    None when no reachable state does."""
    if accept(start):
        return [start]
    parent: dict[int, int] = {}
    for u, v in nx.bfs_edges(g, start):
        parent[v] = u
        if accept(v):
            path = [v]
            while path[-1] != start:
                path.append(parent[path[-1]])
            return path[::-1]
    return None


def check_map_properties(
    cmap: CognitiveMap,
    files: Sequence[PropertyFile] | None = None,
    via: str = "drn",
) -> list[CheckResult]:
    """Export ``cmap`` for every model kind the property files ask for, build it with Storm
    and check every property (default: the files in ``specs/properties/``)."""
    files = [read_properties(p) for p in default_property_files()] if files is None else list(files)
    built: dict[str, StormModel] = {}
    out: list[CheckResult] = []
    for pf in files:
        if pf.model not in built:
            built[pf.model] = build_storm_model(cmap, pf.model, via)
        out += check_properties(built[pf.model], pf)
    return out


# -- differential check: Storm's optimum vs the Configurator's plan -----------------------------
def plan_distance(cmap: CognitiveMap) -> float:
    """The distance the plan drives: Σ distance of q1 … qn (q0 is the present task)."""
    return float(sum(cmap[i].distance for i in map_plan(cmap).states[1:]))


@dataclass(frozen=True)
class DistanceComparison:
    """Storm's least expected distance to the goal over the explored map, and the plan's."""

    storm_min: float
    plan: float
    plan_reaches_goal: bool

    @property
    def consistent(self) -> bool:
        """The relation that must hold: when the plan reaches the goal, Storm's optimum is
        finite and no greater than the plan's distance (the plan is one scheduler of the
        MDP; the Configurator is greedy best-first on φ, not distance-optimal)."""
        if not self.plan_reaches_goal:
            return True
        return math.isfinite(self.storm_min) and self.storm_min <= self.plan + TOLERANCE


def compare_distance(cmap: CognitiveMap, via: str = "drn") -> DistanceComparison:
    """``R{"distance"}min=? [F "goal"]`` on the unsupervised MDP vs :func:`plan_distance`."""
    sm = build_storm_model(cmap, "mdp", via)
    spec = PropertySpec('R{"distance"}min=? [F "goal"]', "min_distance")
    (res,) = check_properties(sm, [spec])
    rho = map_plan(cmap)
    end = cmap[rho.end]
    return DistanceComparison(float(res.value), plan_distance(cmap), end.reached_goal and not end.interrupted)
