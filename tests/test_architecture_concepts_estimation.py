"""One geometry, in the estimator too: the forms of it that ``tests/test_architecture.py``'s
scan does not see, because they go through a name (``c, s = cos(th), sin(th)`` first).

The estimator (``runtime/estimation/``) had its own midpoint pose step (the Kalman filter's
``x + v * dt * cs``), its own exact arc (de-skewing: ``r * sin(th)``, ``r * (1 - cos(th))``),
three frame transforms (``c * px - s * py``) and an angle wrap by ``atan2(sin, cos)``; they
are :func:`clomp.formal.geometry.midpoint_step`, :func:`~clomp.formal.geometry.arc_offsets`,
:func:`~clomp.formal.geometry.points_from_frame(s)` / ``points_to_frame`` and
:func:`~clomp.formal.geometry.wrap_angle` now. This scan finds them again, written either way:

- a *rotation*: a sum or difference of two products that each hold a cos or sin (a call,
  or a name assigned from one);
- a *pose step*: a sum with a term that multiplies a cos or sin by a time step (``dt``,
  ``tick``), also through a name (the Kalman filter's Jacobian entries are products
  without a sum, and stay);
- an *arc offset*: ``1 - cos(...)``;
- an *angle wrap*: ``atan2(sin(a), cos(a))``.

The compiled ICP loop (``_icp_core.py``, numba) cannot call Python functions and keeps
its own rotation and wrap: it is the one module left out, by name.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ESTIMATION = REPO / "runtime" / "estimation"
COMPILED = {"_icp_core.py"}  # numba: calls no Python, keeps its own (see the module docstring)


def _trig_call(node: ast.AST) -> bool:
    if isinstance(node, ast.Call):
        f = node.func
        name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None
        return name in ("cos", "sin")
    return False


def _trig_names(tree: ast.AST) -> set[str]:
    """Names assigned from a cos or sin call (``c = cos(a)``, ``c, s = cos(a), sin(a)``)."""
    out: set[str] = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.Assign):
            continue
        for target in node.targets:
            if isinstance(target, ast.Name) and _trig_call(node.value):
                out.add(target.id)
            elif isinstance(target, ast.Tuple) and isinstance(node.value, ast.Tuple):
                out.update(t.id for t, v in zip(target.elts, node.value.elts) if isinstance(t, ast.Name) and _trig_call(v))
    return out


def _factors(node: ast.AST) -> list[ast.AST]:
    """The factors of a product (unary minus and division looked through), or [node]."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return _factors(node.operand)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
        return _factors(node.left) + _factors(node.right)
    return [node]


def _has_trig(factors: list[ast.AST], trig: set[str]) -> bool:
    return any(_trig_call(f) or (isinstance(f, ast.Name) and f.id in trig) for f in factors)


def _has_step(factors: list[ast.AST]) -> bool:
    return any(isinstance(n, ast.Name) and n.id in ("dt", "tick") for f in factors for n in ast.walk(f))


def _terms(node: ast.AST) -> list[ast.AST]:
    """The terms of a sum or difference (``a + b - c`` → a, b, c), or [node]."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        return _terms(node.left) + _terms(node.right)
    return [node]


def _is_product(node: ast.AST) -> bool:
    return len(_factors(node)) > 1


def geometry_in(path: Path) -> list[str]:
    """Places in ``path`` that do formal/geometry.py's work by hand (see the module docstring)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    trig = _trig_names(tree)
    where = path.name
    found: list[str] = []
    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
            terms = _terms(node)
            with_trig = [t for t in terms if _is_product(t) and _has_trig(_factors(t), trig)]
            if len(with_trig) >= 2:
                found.append(f"{where}:{line}: rotation {ast.unparse(node)}")
            elif any(_has_step(_factors(t)) for t in with_trig):
                found.append(f"{where}:{line}: pose step {ast.unparse(node)}")
            if isinstance(node.op, ast.Sub) and isinstance(node.left, ast.Constant) and node.left.value == 1 \
                    and _trig_call(node.right):
                found.append(f"{where}:{line}: arc offset {ast.unparse(node)}")
        elif isinstance(node, ast.Call) and isinstance(node.func, (ast.Attribute, ast.Name)):
            name = node.func.attr if isinstance(node.func, ast.Attribute) else node.func.id
            if name in ("atan2", "arctan2") and len(node.args) == 2 and all(_trig_call(a) for a in node.args):
                found.append(f"{where}:{line}: angle wrap {ast.unparse(node)}")
    return found


def test_the_estimator_leaves_frames_motion_and_angles_to_formal_geometry() -> None:
    found = [f for p in sorted(ESTIMATION.glob("*.py")) if p.name not in COMPILED for f in geometry_in(p)]
    assert found == []


def test_the_compiled_loop_is_what_the_scan_would_flag() -> None:
    # the one module left out must be left out for a reason the scan sees, else drop it from COMPILED
    found = "\n".join(geometry_in(ESTIMATION / "_icp_core.py"))
    assert "rotation" in found and "angle wrap" in found


@pytest.mark.parametrize(
    "source, what",
    [
        # the Kalman filter's midpoint step, as it was in ekf.py
        ("def f(x, vt, dt, th, dth):\n    thm = th + dth / 2\n    cs, sn = math.cos(thm), math.sin(thm)\n"
         "    return x + vt * dt * cs\n", "pose step"),
        # odometry.deskew's exact arc and its rotation, as they were
        ("def f(v, w, tau, p):\n    th = w * tau\n    r = v / w\n    py = r * (1 - np.cos(th))\n"
         "    c, s = np.cos(th), np.sin(th)\n    return py + s * p[:, 0] + c * p[:, 1]\n", "arc offset"),
        ("def f(pose, p):\n    c, s = math.cos(pose.theta), math.sin(pose.theta)\n"
         "    return pose.x + c * p[:, 0] - s * p[:, 1]\n", "rotation"),
        ("def f(th, n):\n    return -math.sin(th) * n[0] + math.cos(th) * n[1]\n", "rotation"),
        # icp.py's gate, as it was
        ("def f(a, b):\n    return abs(math.atan2(math.sin(a - b), math.cos(a - b)))\n", "angle wrap"),
    ],
)
def test_the_scan_catches_a_copy(tmp_path: Path, source: str, what: str) -> None:
    f = tmp_path / "copy.py"
    f.write_text("import math\nimport numpy as np\n" + source, encoding="utf-8")
    assert any(what in v for v in geometry_in(f))


def test_the_scan_leaves_jacobians_and_plain_trigonometry_alone(tmp_path: Path) -> None:
    f = tmp_path / "ok.py"
    f.write_text("import math\ndef f(vt, dt, th, r, a, m):\n    cs, sn = math.cos(th), math.sin(th)\n"
                 "    m[0, 2], m[1, 2] = -vt * dt * sn, vt * dt * cs\n    return r * math.cos(a), r * math.sin(a)\n",
                 encoding="utf-8")
    assert geometry_in(f) == []
