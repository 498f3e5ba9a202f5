"""One place per concept (issue #37), the robot's side: one body type, one noise validator.

- one body type: only :class:`clomp.planner.robot_model.Body` declares a body's dimensions
  (a class with two or more fields named like ``length``, ``width``, ``front_offset``,
  ``wheel_base`` …, as annotations or ``self.`` assignments); the planner's RobotModel and
  the world's BodySpec are Bodies;
- one noise validator: only :func:`clomp.planner.noise.check_noise` checks noise numbers.
  A function that calls ``isfinite`` and raises a message naming a noise field (or the
  ``noise.`` field path) is a validator, and so is any method calling ``isfinite`` of a
  class with two or more noise fields; every such public class checks its fields in a
  ``__post_init__`` that calls ``check_noise`` (a private one, e.g. a rollout's task,
  holds numbers drawn from a checked noise).

Read from the AST of planner, formal, runtime and specs; the tests at the end show that
the scans catch a second body type and a second validator.
"""

from __future__ import annotations

import ast
import re
from dataclasses import fields
from pathlib import Path

import pytest

from clomp.planner.noise import NoiseTerms, RolloutNoise
from clomp.planner.robot_model import Body, RobotModel
from clomp.runtime.backends.sim import NoiseConfig
from clomp.runtime.backends.world import BodySpec

REPO = Path(__file__).resolve().parents[1]
ROOTS = ("planner", "formal", "runtime", "specs")
BODY_FIELDS = frozenset({"length", "width", "front_offset", "rear_offset", "wheel_base", "half_width",
                         "body_length", "body_width", "track_width"})
NOISE_FIELDS = frozenset(f.name for cls in (NoiseTerms, RolloutNoise, NoiseConfig) for f in fields(cls))
THE_BODY = ("planner/robot_model.py", "Body")
THE_VALIDATOR = ("planner/noise.py", "check_noise")


def _modules() -> list[Path]:
    return sorted(p for r in ROOTS for p in (REPO / r).rglob("*.py"))


def _where(path: Path) -> str:
    return str(path.relative_to(REPO)) if path.is_relative_to(REPO) else path.name


def _declared(cls: ast.ClassDef) -> set[str]:
    """The attributes a class declares: annotated class fields and ``self.x = …`` in its methods."""
    names = {n.target.id for n in cls.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)}
    for node in ast.walk(cls):
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        names |= {t.attr for t in targets if isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) and t.value.id == "self"}
    return names


def body_types(path: Path) -> list[tuple[str, str]]:
    """(module, class) for each class in ``path`` that declares two or more body dimensions."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [(_where(path), n.name) for n in ast.walk(tree)
            if isinstance(n, ast.ClassDef) and len(_declared(n) & BODY_FIELDS) >= 2]


def _calls(node: ast.AST, name: str) -> bool:
    for n in ast.walk(node):
        if isinstance(n, ast.Call):
            f = n.func
            if (f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None) == name:
                return True
    return False


def _raised_words(fn: ast.AST) -> str:
    return " ".join(c.value for r in ast.walk(fn) if isinstance(r, ast.Raise)
                    for c in ast.walk(r) if isinstance(c, ast.Constant) and isinstance(c.value, str))


def noise_validators(path: Path) -> list[tuple[str, str]]:
    """(module, function) for each function in ``path`` that checks noise numbers itself."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    noisy = [c for c in ast.walk(tree) if isinstance(c, ast.ClassDef) and len(_declared(c) & NOISE_FIELDS) >= 2]
    in_noisy = {id(f) for c in noisy for f in ast.walk(c) if isinstance(f, ast.FunctionDef)}
    found = []
    for fn in ast.walk(tree):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)) and _calls(fn, "isfinite"):
            said = _raised_words(fn)
            if id(fn) in in_noisy or "noise." in said or set(re.findall(r"\w+", said)) & NOISE_FIELDS:
                found.append((_where(path), fn.name))
    return found


def noise_types(path: Path) -> list[tuple[str, str, bool]]:
    """(module, class, checks with check_noise) for each public class with two or more noise fields."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    out = []
    for c in ast.walk(tree):
        if isinstance(c, ast.ClassDef) and not c.name.startswith("_") and len(_declared(c) & NOISE_FIELDS) >= 2:
            post = [f for f in c.body if isinstance(f, ast.FunctionDef) and f.name == "__post_init__"]
            out.append((_where(path), c.name, bool(post) and _calls(post[0], "check_noise")))
    return out


def test_one_body_type_declares_the_dimensions() -> None:
    found = [t for p in _modules() for t in body_types(p)]
    assert found == [THE_BODY]


def test_the_planners_model_and_the_worlds_body_are_bodies() -> None:
    assert issubclass(RobotModel, Body) and issubclass(BodySpec, Body)
    model = RobotModel(width=0.2)
    assert BodySpec.like(model).body == model.body == Body(width=0.2)


def test_one_noise_validator() -> None:
    found = [v for p in _modules() for v in noise_validators(p)]
    assert found == [THE_VALIDATOR]


def test_every_noise_type_checks_its_fields_with_the_validator() -> None:
    found = [t for p in _modules() for t in noise_types(p)]
    assert {(m, c) for m, c, _ in found} >= {("planner/noise.py", "NoiseTerms"), ("planner/noise.py", "RolloutNoise"),
                                              ("runtime/backends/sim.py", "NoiseConfig")}
    assert [t for t in found if not t[2]] == []


@pytest.mark.parametrize(
    "source",
    [
        "from dataclasses import dataclass\n@dataclass\nclass Chassis:\n    length: float = 0.3\n    width: float = 0.2\n",
        "class Footprint:\n    def __init__(self):\n        self.front_offset = 0.1\n        self.wheel_base = 0.15\n",
    ],
)
def test_the_scan_catches_a_second_body_type(tmp_path: Path, source: str) -> None:
    f = tmp_path / "copy.py"
    f.write_text(source, encoding="utf-8")
    assert len(body_types(f)) == 1


def test_the_scan_leaves_a_lone_length_alone(tmp_path: Path) -> None:
    f = tmp_path / "ok.py"
    f.write_text("class Packet:\n    length: int = 5\n    kind: int = 0\n", encoding="utf-8")
    assert body_types(f) == []


@pytest.mark.parametrize(
    "source",
    [  # a noise class with its own loop; a function checking a preset's field; a field path in a message
        "import math\nclass MyNoise:\n    range_sd: float = 0.0\n    dropout: float = 0.0\n"
        "    def __post_init__(self):\n        if not math.isfinite(self.range_sd):\n            raise ValueError('bad')\n",
        "import math\ndef check(v):\n    if not math.isfinite(v['slip']):\n        raise ValueError('slip: not finite')\n",
        "from math import isfinite\ndef check(k, v):\n    if not isfinite(v):\n        raise ValueError(f'noise.{k}: bad')\n",
    ],
)
def test_the_scan_catches_a_second_noise_validator(tmp_path: Path, source: str) -> None:
    f = tmp_path / "copy.py"
    f.write_text(source, encoding="utf-8")
    assert len(noise_validators(f)) == 1


def test_the_scan_catches_a_noise_type_that_checks_nothing(tmp_path: Path) -> None:
    f = tmp_path / "copy.py"
    f.write_text("class MyNoise:\n    range_sd: float = 0.0\n    dropout: float = 0.0\n", encoding="utf-8")
    assert noise_types(f) == [("copy.py", "MyNoise", False)]


def test_the_scan_leaves_other_finite_checks_alone(tmp_path: Path) -> None:
    f = tmp_path / "ok.py"
    f.write_text("import math\ndef speed(v):\n    if not math.isfinite(v):\n        raise ValueError(f'speed: {v}')\n",
                 encoding="utf-8")
    assert noise_validators(f) == []
