"""The ROS 2 room: only ``runtime/ros/`` and the cli import rclpy, the ROS message
packages or ``runtime/ros``; and runtime/ros imports nothing of the cli. So the planner,
the supervisor and every other command work without ROS 2 installed.

Imports are read from the AST (an import inside a function counts too).
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ROS_MODULES = ("rclpy", "sensor_msgs", "geometry_msgs", "nav_msgs", "visualization_msgs", "std_msgs",
               "builtin_interfaces", "runtime.ros")


def _imports(path: Path) -> set[str]:
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
    return {n.removeprefix("clomp.") for n in found}


def _ros_imports(path: Path) -> list[str]:
    return sorted(n for n in _imports(path) if any(n == m or n.startswith(m + ".") for m in ROS_MODULES))


def test_only_runtime_ros_and_the_cli_import_ros() -> None:
    allowed = (REPO / "runtime" / "ros", REPO / "runtime" / "cli")
    offenders = [f"{p.relative_to(REPO)}: {', '.join(_ros_imports(p))}"
                 for room in ("formal", "planner", "runtime", "specs")
                 for p in sorted((REPO / room).rglob("*.py"))
                 if not any(p.is_relative_to(a) for a in allowed) and _ros_imports(p)]
    assert offenders == []


def test_runtime_ros_does_not_import_the_cli() -> None:
    offenders = [str(p.relative_to(REPO)) for p in sorted((REPO / "runtime" / "ros").rglob("*.py"))
                 if any(n == "runtime.cli" or n.startswith("runtime.cli.") for n in _imports(p))]
    assert offenders == []


def test_the_rule_catches_an_import(tmp_path: Path) -> None:
    bad = tmp_path / "x.py"
    bad.write_text("def f():\n    from clomp.runtime.ros.robot import RosRobot\n    import rclpy\n")
    assert _ros_imports(bad) == ["rclpy", "runtime.ros.robot"]


def test_the_cli_imports_ros_only_lazily() -> None:
    """``clomp --help`` and every other command must work without rclpy: the cli's module
    level imports nothing of ROS (only its functions do)."""
    path = REPO / "runtime" / "cli" / "ros.py"
    top = ast.parse(path.read_text(encoding="utf-8"))
    names = {n.module for n in top.body if isinstance(n, ast.ImportFrom) and n.module}
    names |= {a.name for n in top.body if isinstance(n, ast.Import) for a in n.names}
    assert not [n for n in names if any(m in n for m in ("rclpy", "_msgs", "runtime.ros"))]
