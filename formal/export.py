"""Exporters: one intermediate model extracted from a cognitive map, then renderers.

:func:`export_model` (:mod:`clomp.formal.export_model`) extracts the intermediate model; the
renderers below print it.


Renderers (each takes a path or a text file object, networkx-style): :func:`write_prism`
(PRISM language), :func:`write_prism_explicit` (``.tra .sta .lab`` and named reward files),
:func:`write_drn` (Storm's DRN), :func:`write_dot` (Graphviz) and :func:`write_json` (the
lossless map). Probabilities are printed exactly (``p/q`` where the format allows it,
exact decimals otherwise) and every printed distribution is parsed back and checked to
sum to 1 before it is written.
"""

from __future__ import annotations

import io
import os
import shutil
import subprocess
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from fractions import Fraction
from pathlib import Path
from typing import IO, Any

from clomp.formal import dot_picture
from clomp.formal.export_model import LABELS, STAY, Choice, ExportError, ExportModel, ModelKind, export_model, induced_model
from clomp.formal.lts import CognitiveMap
from clomp.formal.model import State

__all__ = [
    "ModelKind",
    "ExportError",
    "Choice",
    "ExportModel",
    "export_model",
    "induced_model",
    "write_prism",
    "write_prism_explicit",
    "write_drn",
    "write_dot",
    "write_json",
    "render_svg",
    "write",
    "FORMATS",
    "STAY",
    "LABELS",
    "LABEL_HOLDER",
    "drn_label_holder",
    "drn_adds_holder",
    "prism_import_args",
]

Dest = str | os.PathLike[str] | IO[str]


# -- printing numbers exactly ---------------------------------------------------------------
def _rational(p: Fraction) -> str:
    return str(p.numerator) if p.denominator == 1 else f"{p.numerator}/{p.denominator}"


def _decimal(p: Fraction, places: int = 17) -> str:
    """``p`` as a decimal string: exact when it terminates, else rounded to ``places``."""
    d = p.denominator
    for f in (2, 5):
        while d % f == 0:
            d //= f
    if d == 1:
        digits = 0
        while (p * 10**digits).denominator != 1:
            digits += 1
    else:
        digits = places
    scaled = round(p * 10**digits)
    sign = "-" if scaled < 0 else ""
    s = str(abs(scaled)).rjust(digits + 1, "0")
    whole, frac = s[: len(s) - digits], s[len(s) - digits :]
    return sign + whole + ("." + frac if frac else "")


def _printed(probs: list[Fraction], exact_rationals: bool) -> list[str]:
    """Print a distribution and check that what was printed sums to exactly 1."""
    if exact_rationals:
        text = [_rational(p) for p in probs]
    else:
        text = [_decimal(p) for p in probs[:-1]]
        text.append(_decimal(1 - sum((Fraction(t) for t in text), Fraction(0))))
    back = [Fraction(t) for t in text]
    if sum(back) != 1 or any(not 0 < b <= 1 for b in back):
        raise ExportError(f"printed probabilities {text} do not sum to 1")
    return text


def _num(x: float) -> str:
    """A reward as the shortest decimal that reads back as the same double."""
    return "0" if x == 0 else repr(float(x))


# -- file handling ------------------------------------------------------------------------------
@contextmanager
def _open(dest: Dest) -> Iterator[IO[str]]:
    if hasattr(dest, "write"):
        yield dest  # type: ignore[misc]
    else:
        with open(dest, "w", encoding="utf-8", newline="\n") as fh:
            yield fh


def _model(source: CognitiveMap | ExportModel, kind: ModelKind) -> ExportModel:
    return source if isinstance(source, ExportModel) else export_model(source, kind)


def _header(m: ExportModel, comment: str) -> list[str]:
    n_map = m.n_transitions - len(m.self_loops)
    if m.title is not None:
        return [
            f"{comment} clomp {m.title} ({m.kind.upper()}: actions are events)",
            f"{comment} {m.n_states} states, {n_map} transitions + {len(m.self_loops)} absorbing self-loops",
        ]
    what = ("unsupervised map (MDP: actions are tasks)" if m.kind == "mdp"
            else "supervised system (Ψ applied, DTMC)" if m.policy == "plan" else f"system under {m.policy} (DTMC)")
    goal = "none" if m.goal is None else f"({m.goal[0]:g}, {m.goal[1]:g})"
    return [
        f"{comment} clomp cognitive map, {what}",
        f"{comment} {m.n_states} states, {n_map} map transitions + {len(m.self_loops)} absorbing self-loops; goal {goal}",
        f"{comment} plan: {' '.join(f'q{i}' for i in m.plan.states)}",
    ]


# -- PRISM language ------------------------------------------------------------------------------
def write_prism(source: CognitiveMap | ExportModel, dest: Dest, kind: ModelKind = "mdp") -> None:
    """Write the PRISM-language model: variable ``q`` holds the state's ident (so that
    state valuations name map states), one command per choice labelled with its action,
    labels ``init goal collision plan goal_in_map``, rewards ``distance`` and ``time``."""
    m = _model(source, kind)
    idents = [s.ident for s in m.states]
    lines = _header(m, "//")
    lines += ["", m.kind, "", "module cognitive_map" if m.title is None else "module machine"]
    # PRISM refuses a range of one value (q : [0..0]); it builds only reachable states,
    # so widening the range of a one-state model adds no state
    lo, hi = min(idents), max(idents)
    lines.append(f"  q : [{lo}..{max(hi, lo + 1)}] init {idents[m.initial]};")
    for k, row in enumerate(m.choices):
        for ch in row:
            probs = _printed([p for _, p in ch.branches], exact_rationals=True)
            upd = " + ".join(f"{p}:(q'={idents[j]})" for p, (j, _) in zip(probs, ch.branches))
            lines.append(f"  [{ch.action}] q={idents[k]} -> {upd};")
    lines += ["endmodule", ""]
    for name in m.labels:
        if name == "init":
            continue  # "init" is built in
        members = sorted(idents[k] for k in m.labels[name])
        expr = " | ".join(f"q={i}" for i in members) if members else "false"
        lines.append(f'label "{name}" = {expr};')
    for reward in ("distance", "time"):
        items = [
            f"  [{ch.action}] q={idents[k]} : {_num(getattr(ch, reward))};"
            for k, row in enumerate(m.choices)
            for ch in row
            if getattr(ch, reward)
        ]
        # Storm refuses a reward block without items: a model that earns nothing (a
        # one-state plan) gets an explicit zero state reward
        lines += ["", f'rewards "{reward}"', *(items or ["  true : 0;"]), "endrewards"]
    with _open(dest) as fh:
        fh.write("\n".join(lines) + "\n")


# -- Storm DRN ---------------------------------------------------------------------------------
def write_drn(source: CognitiveMap | ExportModel, dest: Dest, kind: ModelKind = "mdp") -> None:
    """Write Storm's DRN: exact rational probabilities, action rewards ``distance time``,
    and besides the named labels one label ``q<ident>`` per state, so that a model Storm
    builds (and renumbers) can be matched back to the map by label.

    DRN declares a label only through the states that carry it, and a reward structure
    only through nonzero values: Storm refuses a property naming a label no state
    carries (``P=? [F "collision"]`` on a model without collisions) or a reward that is
    zero everywhere (a one-state model). So when some exporter label (:data:`LABELS`) is
    carried by no state, or some reward is earned nowhere, the file ends with one extra
    absorbing state labelled :data:`LABEL_HOLDER` that carries those labels and earns 1
    of those rewards: no state reaches it, so no value at the initial state changes.
    There is no cleaner way: Storm's DRN parser (DirectEncodingParser) accepts only
    ``@type @value_type @parameters @placeholders @reward_models @nr_states @nr_choices
    @model`` in the header (any other line: "Could not parse line"), creates a label
    when a ``state`` line first carries it, and a reward model only from nonzero values;
    a test keeps these facts checked.
    """
    m = _model(source, kind)
    missing = drn_label_holder(m)
    earned = [any(getattr(ch, r) for row in m.choices for ch in row) for r in REWARDS]
    holder = drn_adds_holder(m)
    lines = _header(m, "//")
    if holder:
        lines.append(
            f"// state {m.n_states} is unreachable: it only declares labels no state carries "
            f"({' '.join(missing) or 'none'}) and rewards earned nowhere "
            f"({' '.join(r for r, e in zip(REWARDS, earned) if not e) or 'none'})"
        )
    lines += [f"@type: {m.kind.upper()}", "@parameters", "", "@reward_models", " ".join(REWARDS)]
    lines += ["@nr_states", str(m.n_states + holder)]
    lines += ["@nr_choices", str(m.n_choices + holder)]
    lines.append("@model")
    for k, (s, row) in enumerate(zip(m.states, m.choices)):
        labels = " ".join([*m.state_labels(k), f"q{s.ident}"])
        lines.append(f"state {k} [0, 0] {labels}")
        for ch in row:
            if m.kind == "mdp":
                lines.append(f"\taction {ch.action} [{_num(ch.distance)}, {_num(ch.time)}]")
            else:
                # a DTMC has one unnamed choice per state; its rewards are the state's
                lines[-1] = f"state {k} [{_num(ch.distance)}, {_num(ch.time)}] {labels}"
                lines.append("\taction 0")
            probs = _printed([p for _, p in ch.branches], exact_rationals=True)
            lines += [f"\t\t{j} : {p}" for p, (j, _) in zip(probs, ch.branches)]
    if holder:
        n = m.n_states
        rew = ", ".join("0" if e else "1" for e in earned)
        lines.append(f"state {n} [{'0, 0' if m.kind == 'mdp' else rew}] {' '.join([*missing, LABEL_HOLDER])}")
        lines.append(f"\taction {STAY} [{rew}]" if m.kind == "mdp" else "\taction 0")
        lines.append(f"\t\t{n} : 1")
    with _open(dest) as fh:
        fh.write("\n".join(lines) + "\n")


LABEL_HOLDER = "label_holder"
"""The label of the unreachable state a DRN file adds to declare labels no state carries
and rewards no state earns."""


def drn_adds_holder(m: ExportModel) -> bool:
    """Whether the DRN of ``m`` ends with the unreachable :data:`LABEL_HOLDER` state."""
    return bool(drn_label_holder(m)) or not all(any(getattr(ch, r) for row in m.choices for ch in row) for r in REWARDS)


def drn_label_holder(m: ExportModel) -> list[str]:
    """The exporter labels no state of ``m`` carries: the DRN declares them on an extra,
    unreachable state (empty when every label is carried)."""
    return [name for name in m.labels if not m.labels[name]]


# -- PRISM explicit ------------------------------------------------------------------------------
EXPLICIT_SUFFIXES = ("tra", "sta", "lab", "srew", "trew", "time.srew", "time.trew")
REWARDS = ("distance", "time")
"""The reward structures of every exported model (metres, seconds of the task started)."""


def write_prism_explicit(
    source: CognitiveMap | ExportModel,
    dest: str | os.PathLike[str] | Mapping[str, IO[str]],
    kind: ModelKind = "mdp",
) -> list[str]:
    """Write PRISM's explicit files ``.tra .sta .lab`` and the named reward files.

    ``dest`` is a path stem (``model`` or ``model.tra`` → ``model.tra``, ``model.sta`` …)
    or a mapping from suffix (a key of :data:`EXPLICIT_SUFFIXES`) to an open text file.
    Probabilities are exact decimals (the last branch of a row is written as 1 minus the
    others, so each printed row sums to 1). Each reward file starts with the header
    ``# Reward structure "NAME"`` so that ``R{"distance"}`` and ``R{"time"}`` name them:
    ``.srew``/``.trew`` hold the distance structure, ``.time.srew``/``.time.trew`` the
    time. State rewards are all zero (tasks earn rewards, not states). In an MDP a
    transition reward belongs to the choice, so every successor line of one choice
    carries the choice's expected reward. :func:`prism_import_args` gives the PRISM
    command line that loads the files. Returns the paths written.
    """
    m = _model(source, kind)
    texts = _explicit_texts(m)
    if isinstance(dest, Mapping):
        for suffix, text in texts.items():
            if suffix in dest:
                dest[suffix].write(text)
        return []
    stem = _stem(dest)
    written = []
    for suffix, text in texts.items():
        path = stem.parent / f"{stem.name}.{suffix}"
        path.write_text(text, encoding="utf-8")
        written.append(str(path))
    return written


def _stem(dest: str | os.PathLike[str]) -> Path:
    stem = Path(dest)
    for suffix in sorted(EXPLICIT_SUFFIXES, key=len, reverse=True):
        if stem.name.endswith("." + suffix):
            return stem.with_name(stem.name[: -len(suffix) - 1])
    return stem


def prism_import_args(stem: str | os.PathLike[str], kind: ModelKind) -> list[str]:
    """PRISM's arguments to import the files :func:`write_prism_explicit` wrote at ``stem``.

    >>> prism_import_args("m", "dtmc")[:4]
    ['-importtrans', 'm.tra', '-importstates', 'm.sta']
    """
    base = _stem(stem)

    def f(suffix: str) -> str:
        return str(base.parent / f"{base.name}.{suffix}")

    return [
        "-importtrans", f("tra"), "-importstates", f("sta"), "-importlabels", f("lab"),
        "-importstaterewards", f("srew"), "-importstaterewards", f("time.srew"),
        "-importtransrewards", f("trew"), "-importtransrewards", f("time.trew"),
        f"-{kind}",
    ]


def _explicit_texts(m: ExportModel) -> dict[str, str]:
    n = m.n_states
    tra: list[str] = []
    trew: dict[str, list[str]] = {name: [] for name in REWARDS}
    for k, row in enumerate(m.choices):
        for c, ch in enumerate(row):
            probs = _printed([p for _, p in ch.branches], exact_rationals=False)
            for p, (j, _prob) in zip(probs, ch.branches):
                if m.kind == "mdp":
                    tra.append(f"{k} {c} {j} {p} {ch.action}")
                else:
                    tra.append(f"{k} {j} {p}")
                for reward in REWARDS:
                    if m.kind == "mdp":
                        # the reward of the choice on each of its successor lines (PRISM
                        # refuses different values within one choice)
                        r = getattr(ch, reward)
                    else:
                        # a DTMC's transition reward is the branch's own task; its
                        # expectation over the row is the choice's reward
                        r = getattr(m.states[j], "distance" if reward == "distance" else "duration") if ch.action != STAY else 0.0
                    if r:
                        trew[reward].append(f"{k} {c} {j} {_num(r)}" if m.kind == "mdp" else f"{k} {j} {_num(r)}")
    head = f"{n} {m.n_choices} {len(tra)}" if m.kind == "mdp" else f"{n} {len(tra)}"
    idents = [s.ident for s in m.states]
    names = list(m.labels)
    lab = [" ".join(f'{i}="{name}"' for i, name in enumerate(names))]
    for k in range(n):
        ids = [str(i) for i, name in enumerate(names) if k in m.labels[name]]
        if ids:
            lab.append(f"{k}: {' '.join(ids)}")

    def rew(name: str, lines: list[str]) -> str:
        h = f"{n} {m.n_choices} {len(lines)}" if m.kind == "mdp" else f"{n} {len(lines)}"
        return "\n".join([f'# Reward structure "{name}"', "# Transition rewards", h, *lines]) + "\n"

    def srew(name: str) -> str:
        return f'# Reward structure "{name}"\n# State rewards\n{n} 0\n'

    return {
        "tra": "\n".join([head, *tra]) + "\n",
        "sta": "\n".join(["(q)", *(f"{k}:({i})" for k, i in enumerate(idents))]) + "\n",
        "lab": "\n".join(lab) + "\n",
        "srew": srew("distance"),
        "trew": rew("distance", trew["distance"]),
        "time.srew": srew("time"),
        "time.trew": rew("time", trew["time"]),
    }


# -- DOT -------------------------------------------------------------------------------------------
def _dot_quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def write_dot(source: CognitiveMap | ExportModel, dest: Dest, kind: ModelKind = "mdp") -> None:
    """Write Graphviz DOT: integer node ids with quoted labels (state, task, outcome, φ, end pose);
    plan transitions bold, collision states red octagons, goal states green, q0 a double
    border; added self-loops are dashed grey; a state's self-loops on several events one
    labelled loop; a legend node, and a layout that fits a page (:mod:`clomp.formal.dot_picture`)."""
    m = _model(source, kind)
    name = "cognitive_map" if m.title is None else (m.title if m.title.isidentifier() else "machine")
    lines = [f"digraph {name} {{"]
    lines += [f"  // {h[3:]}" for h in _header(m, "//")]
    lines += dot_picture.layout(m)
    lines.append('  node [shape=box, style="rounded", fontname="Helvetica", fontsize=10];')
    lines.append('  edge [fontname="Helvetica", fontsize=9];')
    for k, s in enumerate(m.states):
        attrs = _dot_state(m, k, s) if isinstance(s, State) else _dot_node(m, k, s)
        lines.append(f"  {k} [{', '.join(attrs)}];")
    lines += _dot_edges(m)
    lines += dot_picture.folded_loops(m)
    lines += dot_picture.legend(m)
    lines.append("}")
    with _open(dest) as fh:
        fh.write("\n".join(lines) + "\n")


def _dot_node(m: ExportModel, k: int, s: Any) -> list[str]:
    """The DOT attributes of a state that is not a map's (the supervisor's machine)."""
    attrs = [f"label={_dot_quote(str(getattr(s, 'name', k)))}"]
    if k in m.labels.get("motors", ()):
        attrs += ['style="rounded,filled"', 'fillcolor="#c6e5c6"']
    if k in m.labels.get("terminal", ()):
        attrs.append("peripheries=2")
    if k in m.labels.get("after_fault", ()):
        attrs.append("color=red")
    return attrs


def _dot_state(m: ExportModel, k: int, s: State) -> list[str]:
    """The DOT attributes of a map's state: its label, outcome colours, q0 and the plan."""
    outcome = "collision" if s.interrupted else "goal" if s.reached_goal else "ok"
    text = f"q{s.ident} {s.task.value}\n{outcome}  φ={s.cost:.3f}\n{dot_picture.pose_line(s)}"
    attrs = [f"label={_dot_quote(text)}"]
    if s.interrupted:
        attrs += ["shape=octagon", "color=red", "fontcolor=red"]
    elif s.reached_goal:
        attrs += ['style="rounded,filled"', "fillcolor=palegreen"]
    if k == m.initial:
        attrs += ["peripheries=2", "penwidth=2"]
    if k in m.labels["plan"]:
        attrs.append("penwidth=2")
    return list(dict.fromkeys(attrs))


def _dot_edges(m: ExportModel) -> list[str]:
    """One DOT edge per branch: plan steps bold, added self-loops dashed grey (a state's
    self-loops on several events are left to :func:`clomp.formal.dot_picture.folded_loops`)."""
    lines = []
    skip = dot_picture.folded(m)
    for k, row in enumerate(m.choices):
        for ch in row:
            if (k, ch.action) in skip:
                continue
            for j, p in ch.branches:
                if ch.action == STAY:
                    lines.append(f'  {k} -> {j} [style=dashed, color=grey, label="stay"];')
                    continue
                label = ch.action if p == 1 else f"{ch.action} {_rational(p)}"
                on_plan = ch.guarded and k in m.labels["plan"] and j in m.labels["plan"]
                style = ", style=bold, penwidth=3" if on_plan else ""
                lines.append(f"  {k} -> {j} [label={_dot_quote(label)}{style}];")
    return lines


def render_svg(
    source: CognitiveMap | ExportModel,
    dest: Dest,
    kind: ModelKind = "mdp",
    engine: str | None = None,
    timeout: float = 120.0,
) -> str:
    """Render the DOT graph of the ``kind`` model to SVG with Graphviz; returns the engine used.

    Takes ``(source, dest, kind)`` like every writer of :data:`FORMATS`.

    The engine defaults to ``dot`` for up to 100 states and ``sfdp`` for larger maps
    (``dot`` is slow on large cyclic graphs). Raises :class:`ExportError` when Graphviz
    is not installed or fails.
    """
    m = _model(source, kind)
    engine = engine or ("dot" if m.n_states <= 100 else "sfdp")
    exe = shutil.which(engine)
    if exe is None:
        raise ExportError(f"Graphviz '{engine}' is not installed (e.g. apt-get install graphviz)")
    buf = io.StringIO()
    write_dot(m, buf)
    try:
        done = subprocess.run([exe, "-Tsvg"], input=buf.getvalue(), capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise ExportError(f"Graphviz '{engine}' took longer than {timeout:g} s") from None
    if done.returncode != 0:
        raise ExportError(f"Graphviz '{engine}' failed: {done.stderr.strip()}")
    with _open(dest) as fh:
        fh.write(done.stdout)
    return engine


# -- JSON and dispatch ----------------------------------------------------------------------------
def write_json(source: CognitiveMap, dest: Dest, kind: ModelKind = "mdp") -> None:
    """Write the lossless JSON form of the map (``kind`` is ignored: JSON is the map itself)."""
    if not isinstance(source, CognitiveMap):
        raise ExportError("JSON is written from a CognitiveMap, not from an exported model")
    source.write_json(dest)


FORMATS: dict[str, Callable[..., Any]] = {
    "prism": write_prism,
    "prism-explicit": write_prism_explicit,
    "drn": write_drn,
    "dot": write_dot,
    "svg": render_svg,
    "json": write_json,
}
"""Format name → writer ``(map, dest, kind)``."""


def write(cmap: CognitiveMap, dest: Any, format: str, kind: ModelKind = "mdp") -> None:
    """Write ``cmap`` to ``dest`` in ``format`` (a key of :data:`FORMATS`)."""
    try:
        writer = FORMATS[format]
    except KeyError:
        raise ExportError(f"unknown format {format!r}: expected one of {', '.join(FORMATS)}") from None
    writer(cmap, dest, kind)
