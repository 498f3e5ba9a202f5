"""Running the real PRISM model checker on exported models, one JVM start per model.

PRISM is an optional tool (a Java program, not a Python package). :func:`find_prism`
looks for it in this order: the ``CLOMP_PRISM`` environment variable (the path of the
``prism`` launcher), ``<repo>/../shared/tools/prism-*/bin/prism`` (where the project's
machines and CI keep a build), then ``prism`` on ``PATH``. :func:`run_prism` checks a
batch of properties in one call (PRISM costs ~0.4 s per start) and parses what PRISM
printed: the model's size and one result per property, in order.

>>> isinstance(find_prism(), (Path, type(None)))
True
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from clomp.formal.export import ExportModel, ModelKind, export_model, prism_import_args, write_prism, write_prism_explicit
from clomp.formal.lts import CognitiveMap, MapError

__all__ = ["PrismMissing", "PrismError", "PrismResult", "find_prism", "require_prism", "run_prism", "check_with_prism", "ENV_VAR"]

ENV_VAR = "CLOMP_PRISM"
"""The environment variable naming the ``prism`` launcher."""

_REPO = Path(__file__).resolve().parents[1]


class PrismMissing(RuntimeError):
    """PRISM is not installed where clomp looks for it."""

    def __init__(self) -> None:
        super().__init__(
            f"model checking with PRISM needs the prism launcher: set {ENV_VAR}=/path/to/prism/bin/prism "
            "(PRISM from https://www.prismmodelchecker.org, Java 11 or newer) or put prism on PATH"
        )


class PrismError(MapError):
    """PRISM refused a model or a property; the message is PRISM's own."""


def find_prism() -> Path | None:
    """The ``prism`` launcher: ``$CLOMP_PRISM``, the shared build beside the repo, or PATH."""
    env = os.environ.get(ENV_VAR)
    if env:
        p = Path(env)
        return p if p.is_file() else None
    shared = sorted((_REPO.parent / "shared" / "tools").glob("prism-*/bin/prism"))
    if shared:
        return shared[-1]
    which = shutil.which("prism")
    return Path(which) if which else None


def require_prism() -> Path:
    """:func:`find_prism` or :class:`PrismMissing` saying how to install it."""
    found = find_prism()
    if found is None:
        raise PrismMissing()
    return found


@dataclass
class PrismResult:
    """What PRISM printed: the model's size and one value per property (None: not computed)."""

    n_states: int
    n_transitions: int
    n_choices: int | None
    values: list[float | bool] = field(default_factory=list)
    output: str = ""


_RESULT = re.compile(r"^Result: (\S+)", re.M)
_ERROR = re.compile(r"^Error: (.*)$", re.M)


def _parse_value(text: str) -> float | bool:
    if text in ("true", "false"):
        return text == "true"
    if text in ("Infinity", "+Infinity"):
        return math.inf
    if text == "-Infinity":
        return -math.inf
    if text == "NaN":
        return math.nan
    return float(text)


def run_prism(
    model_args: Sequence[str],
    properties: Sequence[str],
    timeout: float = 300.0,
    prism: Path | None = None,
) -> PrismResult:
    """Run PRISM once on a model (``model_args``: a model file, or explicit import
    arguments) with every formula of ``properties``; :class:`PrismError` when PRISM
    refuses the model or a property, :class:`PrismMissing` when it is not installed.

    The explicit engine with a tight convergence threshold is used, so that values agree
    with Storm's to well below 1e-9 on the maps' (mostly acyclic) models.
    """
    exe = prism or require_prism()
    with tempfile.TemporaryDirectory() as tmp:
        props = Path(tmp) / "props.props"
        props.write_text("\n".join(properties) + "\n", encoding="utf-8")
        cmd = [str(exe), *model_args, str(props), "-ex", "-epsilon", "1e-12", "-maxiters", "1000000"]
        env = dict(os.environ)
        # a short-lived JVM: skip the optimising compiler (PRISM runs well under a
        # second here, mostly start-up), which roughly halves its CPU time
        env.setdefault("PRISM_JAVA_PARAMS", "-XX:TieredStopAtLevel=1 -XX:+UseSerialGC")
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=tmp, env=env)
        except subprocess.TimeoutExpired:
            raise PrismError(f"PRISM took longer than {timeout:g} s") from None
        except OSError as exc:
            raise PrismError(f"cannot run PRISM at {exe}: {exc}") from None
    out = done.stdout + done.stderr
    errors = _ERROR.findall(out)
    if errors:
        raise PrismError(f"PRISM: {'; '.join(dict.fromkeys(e.strip() for e in errors))}")
    sizes = {key: int(v) for key, v in re.findall(r"^(States|Transitions|Choices):\s+(\d+)", out, re.M)}
    if "States" not in sizes:
        raise PrismError(f"PRISM printed no model (exit status {done.returncode}): {out.strip()[-500:]}")
    values = [_parse_value(v) for v in _RESULT.findall(out)]
    if len(values) != len(properties):
        raise PrismError(f"PRISM gave {len(values)} results for {len(properties)} properties: {out.strip()[-500:]}")
    return PrismResult(sizes["States"], sizes["Transitions"], sizes.get("Choices"), values, out)


def check_with_prism(
    source: CognitiveMap | ExportModel,
    properties: Sequence[str],
    kind: ModelKind = "mdp",
    via: str = "prism",
    timeout: float = 300.0,
) -> PrismResult:
    """Export ``source`` as the PRISM language (``via="prism"``) or PRISM's explicit
    files (``via="explicit"``) and check ``properties`` in one PRISM run."""
    m = source if isinstance(source, ExportModel) else export_model(source, kind)
    with tempfile.TemporaryDirectory() as tmp:
        if via == "prism":
            path = Path(tmp) / ("map.nm" if m.kind == "mdp" else "map.pm")
            write_prism(m, path)
            args = [str(path)]
        elif via == "explicit":
            write_prism_explicit(m, Path(tmp) / "map")
            args = prism_import_args(Path(tmp) / "map", m.kind)
        else:
            raise ValueError(f"via must be 'prism' or 'explicit', got {via!r}")
        return run_prism(args, properties, timeout)
