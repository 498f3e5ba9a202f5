"""One place per concept (issue #37), checked on the source: the polar conversion and the footprint test.

- range and bearing → x, y is :func:`clomp.formal.geometry.polar_to_xy`: outside it no code
  pairs ``r * np.cos(a)`` with ``r * np.sin(a)`` (the same bearing) in one tuple, list or
  call (``np.c_[...]``, ``np.column_stack((...))``, ``x, y = ...``);
- which points lie inside the robot's body (grown by a margin) is
  :func:`clomp.planner.footprint.inside`: outside ``planner/footprint.py`` no code tests one
  expression against a negated bound from below and another bound from above in one
  ``&`` or ``and`` chain (``(u >= -rear) & (u <= front) & …``, ``-rear <= u <= front``).

The scans read the AST of ``formal/``, ``planner/`` and ``runtime/``; the tests below the
rules show that each scan recognises the real thing and a copy of it.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("formal", "planner", "runtime")
POLAR_HOME = Path("formal/geometry.py")
FOOTPRINT_HOME = Path("planner/footprint.py")

# places allowed their own copy, and why
POLAR_EXCEPTIONS = {
    # the device layer imports nothing of clomp outside runtime/devices (tests/test_architecture.py),
    # and the A1 counts its bearings clockwise
    Path("runtime/devices/rplidar_codec.py"): "devices stand alone",
}
FOOTPRINT_EXCEPTIONS = {
    # numba-compiled scalar loops: the same test point by point, held bit-equal to the
    # array form by tests/runtime/test_plancheck*.py
    Path("runtime/supervision/_contacts_core.py"): "compiled loops",
    # the planner's compiled loops (perception's own returns, the known-free test), held
    # to perception's and visibility's numpy statements by tests/planner/test_kernels.py
    # and tests/planner/test_free_kernels.py
    Path("planner/_kernels.py"): "compiled loops",
    Path("planner/_free_kernels.py"): "compiled loops",
}


def _modules() -> list[Path]:
    return sorted(p for r in PACKAGES for p in (REPO / r).rglob("*.py"))


def _trig(node: ast.AST) -> tuple[str, str] | None:
    """("cos" | "sin", the argument's source) for a numpy ``np.cos(a)`` / ``numpy.sin(a)`` call."""
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr in ("cos", "sin")
        and isinstance(node.func.value, ast.Name)
        and node.func.value.id in ("np", "numpy")
        and len(node.args) == 1
    ):
        return node.func.attr, ast.unparse(node.args[0])
    return None


def _scaled_trig(node: ast.AST) -> set[tuple[str, str]]:
    """Every numpy cos/sin that ``node`` multiplies by something (at any depth)."""
    found: set[tuple[str, str]] = set()
    for n in ast.walk(node):
        if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mult):
            for side in (n.left, n.right):
                t = _trig(side)
                if t is not None:
                    found.add(t)
    return found


def polar_conversions(path: Path) -> list[str]:
    """Places in ``path`` that turn range and bearing into x, y themselves."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    where = path.relative_to(REPO) if path.is_relative_to(REPO) else path
    found: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Tuple, ast.List)):
            parts: list[ast.AST] = list(node.elts)
        elif isinstance(node, ast.Call):
            parts = [*node.args, *(k.value for k in node.keywords)]
        else:
            continue
        per_part = [_scaled_trig(p) for p in parts]
        cos = {a for s in per_part for f, a in s if f == "cos"}
        sin = {a for s in per_part for f, a in s if f == "sin"}
        if any(("cos", a) in s and ("sin", a) in t for a in cos & sin for i, s in enumerate(per_part)
               for j, t in enumerate(per_part) if i != j):
            found.append(f"{where}:{node.lineno}: polar to x, y {ast.unparse(node)}")
    return found


def _negated(node: ast.AST) -> bool:
    return isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and not isinstance(node.operand, ast.Constant)


def _bounds(node: ast.Compare) -> list[tuple[str, str]]:
    """("low" | "high", the bounded expression's source) for each link of a comparison whose
    lower bound is a negated name (``u >= -rear``, ``-rear < u``) or that bounds it from above."""
    out: list[tuple[str, str]] = []
    items = [node.left, *node.comparators]
    for op, a, b in zip(node.ops, items, items[1:]):
        if isinstance(op, (ast.Gt, ast.GtE)):
            a, b = b, a  # read as b < a: a is above b
        elif not isinstance(op, (ast.Lt, ast.LtE)):
            continue
        # now a < b (or <=): b bounded from below by a, a bounded from above by b
        if _negated(a):
            out.append(("low", ast.unparse(b)))
        if not _negated(b):
            out.append(("high", ast.unparse(a)))
    return out


def _chain(node: ast.AST) -> list[ast.AST]:
    """The operands of an ``&`` chain or an ``and``."""
    if isinstance(node, ast.BoolOp) and isinstance(node.op, ast.And):
        return [x for v in node.values for x in _chain(v)]
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitAnd):
        return _chain(node.left) + _chain(node.right)
    return [node]


def footprint_tests(path: Path) -> list[str]:
    """Places in ``path`` that test points against a body box themselves."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    where = path.relative_to(REPO) if path.is_relative_to(REPO) else path
    found: list[str] = []
    seen: set[int] = set()
    for node in ast.walk(tree):
        if id(node) in seen:
            continue
        if isinstance(node, (ast.BoolOp, ast.BinOp)) or isinstance(node, ast.Compare):
            parts = _chain(node)
            if isinstance(node, (ast.BoolOp, ast.BinOp)):
                seen.update(id(n) for n in ast.walk(node) if isinstance(n, (ast.BoolOp, ast.BinOp)))
            bounds = [b for p in parts if isinstance(p, ast.Compare) for b in _bounds(p)]
            low = {x for kind, x in bounds if kind == "low"}
            high = {x for kind, x in bounds if kind == "high"}
            if low & high:
                found.append(f"{where}:{node.lineno}: footprint test {ast.unparse(node)}")
    return found


def test_only_formal_geometry_turns_range_and_bearing_into_x_y() -> None:
    found = [
        f for p in _modules() if p.relative_to(REPO) not in POLAR_EXCEPTIONS | {POLAR_HOME: ""} for f in polar_conversions(p)
    ]
    assert found == []


def test_only_planner_footprint_tests_points_against_the_body() -> None:
    found = [
        f for p in _modules() if p.relative_to(REPO) not in FOOTPRINT_EXCEPTIONS | {FOOTPRINT_HOME: ""}
        for f in footprint_tests(p)
    ]
    assert found == []


def test_the_scans_recognise_the_one_place_of_each() -> None:
    # else the two tests above would prove nothing
    polar = polar_conversions(REPO / POLAR_HOME)
    assert len(polar) == 1 and "ranges * np.cos(angles)" in polar[0]
    footprint = footprint_tests(REPO / FOOTPRINT_HOME)
    assert len(footprint) == 2  # closed and strict


def test_each_exception_is_still_a_copy() -> None:
    """An exception no longer needed is dropped from the lists (they name only real copies)."""
    for path in POLAR_EXCEPTIONS:
        assert polar_conversions(REPO / path), f"{path} has no polar conversion left: drop its exception"
    for path in FOOTPRINT_EXCEPTIONS:
        assert footprint_tests(REPO / path), f"{path} has no footprint test left: drop its exception"


_COPIES = [
    (polar_conversions, "pts = np.c_[r * np.cos(a), r * np.sin(a)]\n"),
    (polar_conversions, "pts = np.column_stack((r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])))\n"),
    (polar_conversions, "pts = np.stack([np.cos(a) * d, np.sin(a) * d], axis=1)\n"),
    (polar_conversions, "x, y = np.round(r * np.cos(a) / q) * q, np.round(r * np.sin(a) / q) * q\n"),
    (polar_conversions, "y, x = -r * np.sin(a), r * np.cos(a)\n"),
    (footprint_tests, "m = (u >= -rear) & (u <= front) & (v <= half)\n"),
    (footprint_tests, "m = (u > -rrear) & (u < rfront) & (np.abs(v) < rhalf)\n"),
    (footprint_tests, "m = (v <= half) & (front >= u) & (-rear <= u)\n"),
    (footprint_tests, "m = -rear <= u <= front\n"),
    (footprint_tests, "ok = v <= half and u >= -rear and u <= front\n"),
    (footprint_tests, "m = ((x - x0) * c >= -rear) & ((x - x0) * c <= front) & live\n"),
]
_OTHERS = [
    (polar_conversions, "import math\ndef f(r, a):\n    return r * math.cos(a), r * math.sin(a)\n"),  # scalar
    (polar_conversions, "d = np.c_[np.cos(a), np.sin(a)]\n"),  # unit vectors, no ranges
    (polar_conversions, "c, s = np.cos(th)[:, None], np.sin(th)[:, None]\n"),
    (polar_conversions, "px, py = r * np.sin(th), r * (1 - np.cos(th))\n"),  # an arc, not a reading
    (polar_conversions, "p = (r * np.cos(a), r * np.sin(b))\n"),  # two bearings
    (footprint_tests, "m = (u.max(axis=1) >= lo) & (u.min(axis=1) <= hi) & (v.max(axis=1) >= -h) & (v.min(axis=1) <= h)\n"),
    (footprint_tests, "m = (u >= -rear) & ahead\n"),
    (footprint_tests, "m = (v < rhalf) & (u <= front) & (u >= rfront)\n"),  # a band ahead, no negated bound
    (footprint_tests, "m = (x >= -1.0) & (x <= 1.0)\n"),  # a constant interval
]


@pytest.mark.parametrize("scan, source", _COPIES + _OTHERS)
def test_each_scan_catches_a_copy_and_leaves_the_rest_alone(
    tmp_path: Path, scan: Callable[[Path], list[str]], source: str
) -> None:
    f = tmp_path / "code.py"
    f.write_text("import numpy as np\n" + source, encoding="utf-8")
    assert bool(scan(f)) is ((scan, source) in _COPIES)
