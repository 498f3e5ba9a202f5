"""The architecture, checked on the source: which room may import which, and one geometry.

Rules (each test names one; docs/layout.md's table states them for people):

- the one-way rule: formal imports neither planner nor runtime nor pymunk; planner does
  not import runtime;
- the device layer stands alone: ``runtime/devices/`` imports nothing of clomp outside it;
- the robot backends (``runtime/backends/``) and the devices never import the supervision room;
- supervision, records, ``runtime/interface.py`` and ``runtime/clock.py`` import none of the rooms
  above them (robots, experiment, cli; supervision not the devices either);
- the experiment room (``runtime/experiment/``) runs on simulated robots only: it imports
  neither the cli, nor the devices, nor the hardware backends (hardware, emulated), nor pyserial;
- the cli (``runtime/cli/``) is the top room: nothing outside it imports it;
- estimation imports none of the rooms that use it (supervision, robots, experiment, cli);
- a room's private modules (``_name.py``) are imported only inside that room;
- ``runtime/`` has at most 10 modules at its top level and no module in planner, formal or
  runtime has more than 600 lines;
- one geometry: only ``formal/geometry.py`` defines pose integration, frame composition
  or angle wrapping. Concretely, outside it no function is named like one of its functions,
  no code steps a pose by ``speed * dt`` with a cos/sin (Euler or midpoint), no code has
  the exact arc's ``sin(a) - sin(b)`` / ``cos(a) - cos(b)``, and no code wraps angles with
  ``fmod``/``%`` by ``2 * pi``.

Imports are read from the AST, so an import inside a function counts too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("formal", "planner", "runtime")
GEOMETRY = REPO / "formal" / "geometry.py"
GEOMETRY_NAMES = {
    "wrap_angle",
    "compose",
    "relative",
    "arc_step",
    "drive",
    "integrate",
    "_integrate",
    "points_from_frame",
    "points_to_frame",
}


def _modules(*roots: str) -> list[Path]:
    return sorted(p for r in roots for p in (REPO / r).rglob("*.py"))


def _raw_imports(path: Path) -> set[str]:
    """Every module ``path`` imports, as written (absolute names; relative imports resolved)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = ".".join(path.relative_to(REPO).with_suffix("").parts[:-1])
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join([*base, node.module] if node.module else base)
            else:
                mod = node.module or ""
            found.add(mod)
            found.update(f"{mod}.{a.name}" for a in node.names)
    return found


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, named by its folder in the repository (``clomp.planner.x`` → ``planner.x``)."""
    return {n.removeprefix("clomp.") for n in _raw_imports(path)}


def test_every_import_goes_through_clomp() -> None:
    """The packages are installed only as ``clomp.planner`` …: a bare ``import planner`` would load a second copy."""
    paths = [p for p in _modules(*PACKAGES, "specs", "tests", "bench") if p.name != "test_architecture.py"]
    assert len(paths) > 150
    bare = [f"{p.relative_to(REPO)} imports {n}" for p in paths for n in sorted(_raw_imports(p))
            if n.split(".")[0] in (*PACKAGES, "specs")]
    assert bare == []


def test_the_clomp_package_is_the_repository_s_folders() -> None:
    """``clomp/`` holds the namespace and links to the design card's top-level folders, nothing else."""
    links = {p.name: p for p in (REPO / "clomp").iterdir() if p.name != "__pycache__"}
    for name in (*PACKAGES, "specs"):
        assert links[name].is_symlink() and links[name].resolve() == REPO / name
    assert not {n for n, p in links.items() if p.suffix == ".py"} - {"__init__.py", "__main__.py"}


def _violations(paths: list[Path], forbidden: tuple[str, ...]) -> list[str]:
    return [
        f"{p.relative_to(REPO)} imports {name}"
        for p in paths
        for name in sorted(_imports(p))
        if any(name == f or name.startswith(f + ".") for f in forbidden)
    ]


def test_formal_imports_neither_planner_nor_runtime_nor_physics() -> None:
    assert _violations(_modules("formal"), ("planner", "runtime", "pymunk")) == []


def test_planner_does_not_import_runtime_or_serial_ports() -> None:
    assert _violations(_modules("planner"), ("runtime", "serial")) == []


def test_devices_stand_alone() -> None:
    devices = _modules("runtime/devices")
    assert devices, "no device modules found"
    assert _violations(devices, ("planner", "formal", "runtime.backends", "runtime.supervision",
                                 "runtime.experiment", "runtime.cli", "runtime.interface", "runtime.clock")) == []


def test_backends_and_devices_do_not_import_the_supervisor() -> None:
    paths = _modules("runtime/backends", "runtime/devices")
    assert len(paths) >= 8
    assert _violations(paths, ("runtime.supervision",)) == []


def test_supervision_and_records_stay_below_robots_experiment_and_cli() -> None:
    assert _violations(_modules("runtime/supervision"), ("runtime.backends", "runtime.experiment", "runtime.cli", "runtime.devices")) == []
    assert _violations(_modules("runtime/records"), ("runtime.backends", "runtime.supervision", "runtime.experiment", "runtime.cli")) == []
    assert _violations([REPO / "runtime" / "interface.py", REPO / "runtime" / "clock.py"], ("runtime.backends", "runtime.supervision",
                                                                                     "runtime.experiment", "runtime.cli")) == []


def test_experiment_runs_on_simulated_robots_only() -> None:
    experiment = _modules("runtime/experiment")
    assert len(experiment) >= 5, "no experiment modules found"
    assert _violations(experiment, ("runtime.cli", "runtime.devices", "runtime.backends.hardware",
                                    "runtime.backends.emulated", "serial")) == []


def test_only_the_cli_imports_the_cli() -> None:
    cli = REPO / "runtime" / "cli"
    below = [p for p in _modules(*PACKAGES) if not p.is_relative_to(cli)]
    assert len(below) >= 50 and _modules("runtime/cli")
    assert _violations(below, ("runtime.cli",)) == []


def test_estimation_stays_below_its_users() -> None:
    assert _violations(_modules("runtime/estimation"), ("runtime.supervision", "runtime.backends",
                                                        "runtime.experiment", "runtime.cli")) == []


def _private_crossings(module: Path, imported: set[str]) -> list[str]:
    """Which of ``imported`` are private modules (``_name``) of a room ``module`` is not in."""
    room = module.parts[:-1]
    found = []
    for name in sorted(imported):
        parts = name.split(".")
        for i, part in enumerate(parts[1:], 1):
            if part.startswith("_") and not part.startswith("__"):
                target = REPO.joinpath(*parts[: i + 1])
                if room[:i] != tuple(parts[:i]) and (target.with_suffix(".py").exists() or target.is_dir()):
                    found.append(f"{module} imports {name}")
                break
    return found


def test_private_modules_stay_in_their_room() -> None:
    found = [f for p in _modules(*PACKAGES) for f in _private_crossings(p.relative_to(REPO), _imports(p))]
    assert found == []


def test_the_private_module_rule_catches_a_crossing() -> None:
    # the robots room reaching into the cli's private plumbing, and the cli into robots' own
    assert _private_crossings(Path("runtime/backends/hardware.py"), {"runtime.cli._signals", "runtime.cli._signals.x"}) == [
        "runtime/backends/hardware.py imports runtime.cli._signals",
        "runtime/backends/hardware.py imports runtime.cli._signals.x",
    ]
    assert _private_crossings(Path("runtime/cli/run.py"), {"runtime.backends._simulated"}) != []
    # inside the room, and a private *name* of a public module, are fine
    assert _private_crossings(Path("runtime/cli/run.py"), {"runtime.cli._signals", "runtime.experiment.world._TracedSimRobot"}) == []


def test_runtime_top_level_is_small_and_no_module_is_too_long() -> None:
    top = sorted(p.name for p in (REPO / "runtime").glob("*.py"))
    assert len(top) <= 10, top
    long = {str(p.relative_to(REPO)): n for p in _modules(*PACKAGES) if (n := len(p.read_text(encoding="utf-8").splitlines())) > 600}
    assert long == {}


def _is_trig(node: ast.AST) -> str | None:
    """'cos' or 'sin' when ``node`` is a call of math/np cos or sin."""
    if isinstance(node, ast.Call):
        f = node.func
        name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None
        if name in ("cos", "sin"):
            return name
    return None


def _names(node: ast.AST) -> set[str]:
    out: set[str] = set()
    for n in ast.walk(node):
        if isinstance(n, ast.Name):
            out.add(n.id)
        elif isinstance(n, ast.Attribute):
            out.add(n.attr)
    return out


def _is_two_pi(node: ast.AST) -> bool:
    src = ast.unparse(node).replace(" ", "")
    return src in ("2*math.pi", "math.pi*2", "2*np.pi", "np.pi*2", "math.tau", "np.tau", "tau", "2*pi")


def geometry_reimplementations(path: Path) -> list[str]:
    """Places in ``path`` that re-implement what formal/geometry.py owns (see the module doc)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    where = path.relative_to(REPO) if path.is_relative_to(REPO) else path
    found: list[str] = []
    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name in GEOMETRY_NAMES:
            found.append(f"{where}:{line}: defines {node.name}()")
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Sub):
            a, b = _is_trig(node.left), _is_trig(node.right)
            if a is not None and a == b:
                found.append(f"{where}:{line}: exact-arc step {ast.unparse(node)}")
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
            # a product of a cos/sin, a speed and a time step: Euler or midpoint integration
            flat: list[ast.AST] = []
            stack: list[ast.AST] = [node]
            while stack:
                n = stack.pop()
                if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mult):
                    stack += [n.left, n.right]
                else:
                    flat.append(n)
            has_trig = any(_is_trig(n) for n in flat)
            has_dt = any({"dt", "tick"} & _names(n) for n in flat if not _is_trig(n))
            if has_trig and has_dt:
                found.append(f"{where}:{line}: pose step {ast.unparse(node)}")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "fmod":
            if len(node.args) == 2 and _is_two_pi(node.args[1]):
                found.append(f"{where}:{line}: angle wrapping {ast.unparse(node)}")
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mod) and _is_two_pi(node.right):
            found.append(f"{where}:{line}: angle wrapping {ast.unparse(node)}")
    return found


def test_only_formal_geometry_defines_pose_integration_frames_and_angle_wrapping() -> None:
    found = [f for p in _modules(*PACKAGES) if p != GEOMETRY for f in geometry_reimplementations(p)]
    assert found == []


def test_the_geometry_module_itself_is_what_the_scan_recognises() -> None:
    # the scan must recognise the real thing, else the test above proves nothing
    found = "\n".join(geometry_reimplementations(GEOMETRY))
    for what in ("defines wrap_angle()", "defines compose()", "defines arc_step()", "exact-arc step", "angle wrapping"):
        assert what in found


@pytest.mark.parametrize(
    "source, what",
    [
        ("def f(x, v, th, dt):\n    return x + v * dt * math.cos(th)\n", "pose step"),
        ("def f(p, v, w, dt):\n    th = p.theta + w * dt / 2\n    return p.x + v * math.cos(th) * dt\n", "pose step"),
        ("def f(x, r, a, b):\n    return x + r * (math.sin(b) - math.sin(a))\n", "exact-arc step"),
        ("def f(a):\n    return math.fmod(a + math.pi, 2 * math.pi) - math.pi\n", "angle wrapping"),
        ("def f(a):\n    return (a + np.pi) % (2 * np.pi) - np.pi\n", "angle wrapping"),
        ("def relative(a, b):\n    return b\n", "defines relative()"),
    ],
)
def test_the_scan_catches_a_reimplementation(tmp_path: Path, source: str, what: str) -> None:
    f = tmp_path / "copy.py"
    f.write_text("import math\nimport numpy as np\n" + source, encoding="utf-8")
    assert any(what in v for v in geometry_reimplementations(f))


def test_the_scan_leaves_plain_trigonometry_alone(tmp_path: Path) -> None:
    f = tmp_path / "ok.py"
    f.write_text("import math\ndef f(r, a):\n    return r * math.cos(a), r * math.sin(a)\n", encoding="utf-8")
    assert geometry_reimplementations(f) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_resolves(package: str) -> None:
    # runtime's names are lazy: a name whose module moved or dropped it fails only on use
    import importlib

    mod = importlib.import_module(f"clomp.{package}")
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert missing == []


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_class_and_function_has_an_example(package: str) -> None:
    # the examples are doctests: the default suite runs them (--doctest-modules)
    import importlib
    import inspect

    mod = importlib.import_module(f"clomp.{package}")
    missing = []
    for name in mod.__all__:
        obj = getattr(mod, name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            doc = inspect.getdoc(obj) or ""
            if ">>>" not in doc:
                missing.append(name)
    assert missing == []
