"""Cross-tool check: one model loaded four ways must give the same model and values.

The four loads a user may run: the PRISM-language file in PRISM and in Storm, PRISM's
explicit files in PRISM (named rewards), and the DRN in plain Storm
(``stormpy.build_model_from_drn``). :func:`cross_check` checks every property of the
property files on each load and reports the (reachable) state and transition counts and
the values side by side; :attr:`CrossCheck.agrees` says whether they match (values
within :data:`AGREEMENT`, infinities and booleans exactly).

>>> CrossCheck("x", "dtmc", ("a",), {"PRISM language in PRISM": (1, 1, [0.5])}).agrees
True
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from clomp.formal.checking import PropertyFile, check_properties, default_property_files, load_storm_model, read_properties
from clomp.formal.export import ExportModel, ModelKind, export_model, write_drn, write_prism
from clomp.formal.lts import CognitiveMap
from clomp.formal.prism import check_with_prism

__all__ = ["AGREEMENT", "LOADS", "CrossCheck", "cross_check", "values_agree"]

AGREEMENT = 1e-9
"""Largest absolute gap between two tools' values that counts as agreement."""

LOADS = ("PRISM language in PRISM", "PRISM language in Storm", "explicit files in PRISM", "DRN in Storm")
"""The four ways a model is loaded."""


def values_agree(a: float | bool, b: float | bool, tol: float = AGREEMENT) -> bool:
    """Equal booleans, equal infinities, or numbers within ``tol``."""
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= tol


@dataclass
class CrossCheck:
    """Per load: (states, transitions, values of the properties in order)."""

    title: str
    kind: ModelKind
    names: tuple[str, ...]
    loads: dict[str, tuple[int, int, list[float | bool]]]

    @property
    def sizes_agree(self) -> bool:
        """Every load built the same number of (reachable) states and transitions."""
        return len({(n, t) for n, t, _ in self.loads.values()}) <= 1

    def disagreements(self) -> list[str]:
        """One line per property whose values differ between loads (empty when all agree)."""
        out = []
        ref_name, (_, _, ref) = next(iter(self.loads.items()))
        for name, (_, _, vals) in self.loads.items():
            for prop, a, b in zip(self.names, ref, vals):
                if not values_agree(a, b):
                    out.append(f"{self.title} ({self.kind}) {prop}: {ref_name} {a!r} vs {name} {b!r}")
        return out

    @property
    def agrees(self) -> bool:
        """Sizes and values agree across every load."""
        return self.sizes_agree and not self.disagreements()


def cross_check(
    source: CognitiveMap | ExportModel,
    kind: ModelKind,
    files: Sequence[PropertyFile] | None = None,
    title: str = "map",
    loads: Sequence[str] = LOADS,
) -> CrossCheck:
    """Load the ``kind`` model of ``source`` in each of ``loads`` and check every property
    of the files about ``kind`` (default: ``specs/properties/``); one PRISM run per load."""
    files = [read_properties(p) for p in default_property_files()] if files is None else list(files)
    specs = [p for pf in files if pf.model == kind for p in pf.properties]
    formulas = [p.formula for p in specs]
    m = source if isinstance(source, ExportModel) else export_model(source, kind)
    out: dict[str, tuple[int, int, list[float | bool]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for load in loads:
            if load not in LOADS:
                raise ValueError(f"unknown load {load!r}: expected one of {', '.join(LOADS)}")
            if load.endswith("in PRISM"):
                r = check_with_prism(m, formulas, via="prism" if load.startswith("PRISM language") else "explicit")
                out[load] = (r.n_states, r.n_transitions, r.values)
                continue
            path = Path(tmp) / ("m.prism" if load.startswith("PRISM language") else "m.drn")
            (write_prism if load.startswith("PRISM language") else write_drn)(m, path)
            sm = load_storm_model(path)
            n, t = sm.reachable_size()
            out[load] = (n, t, [r.value for r in check_properties(sm, specs)])
    return CrossCheck(title, m.kind, tuple(p.name for p in specs), out)
