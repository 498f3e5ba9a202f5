"""Sphinx configuration of clomp's documentation site (``sphinx-build -W -b html docs <dir>``).

The Markdown pages under ``docs/`` are read by MyST; the API pages under ``docs/api/`` are
written here, at build time, from each public package's ``__all__``, so that a new public
name appears in the reference without anyone editing a page; the command-line reference under
``docs/cli/`` likewise from the argparse parsers (``docs/cliref.py``). No network: intersphinx is off.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # the checkout's clomp, not an installed copy
sys.path.insert(1, str(HERE))  # cliref: the command-line reference's writer

project = "clomp"
author = "the clomp contributors"
copyright = "2026, the clomp contributors"
release = version = "0.1.0"

# the docstrings are plain reStructuredText (no Google/NumPy sections), so no napoleon: it would read
# "what: why" in a constant's comment as "type: description"
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.viewcode"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
nitpicky = False
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"show-inheritance": True}
html_theme = "alabaster"
html_title = "clomp — closed-loop multi-step planning"
html_theme_options = {"description": "Closed-loop multi-step planning with innate physics knowledge", "fixed_sidebar": True,
                      "page_width": "1240px"}  # the wide tables (noise presets, experiment) fit

# the public packages whose ``__all__`` the API reference documents, outermost first
PACKAGES = [
    "clomp", "clomp.planner", "clomp.formal", "clomp.runtime",
    "clomp.runtime.backends", "clomp.runtime.cli", "clomp.runtime.devices", "clomp.runtime.estimation",
    "clomp.runtime.experiment", "clomp.runtime.gym", "clomp.runtime.records", "clomp.runtime.ros", "clomp.runtime.supervision",
    "clomp.specs",
]


def _owner(name: str, obj: object, exporters: list[str]) -> str:
    """The package that documents ``obj``: the deepest exporter its defining module lies in."""
    home = getattr(obj, "__module__", None) or ""
    inside = [p for p in exporters if home == p or home.startswith(p + ".")]
    return max(inside or exporters, key=lambda p: (p.count("."), -exporters.index(p)))


def _directive(obj: object) -> str:
    if inspect.isclass(obj):
        return "autoclass"
    if inspect.isfunction(obj) or inspect.isbuiltin(obj):
        return "autofunction"
    return "autodata"


def _defining_module(package: str, name: str) -> str:
    """The module under ``package`` whose source assigns ``name`` (a constant has no ``__module__``).

    autodoc reads a constant's ``#:`` comment from the module that assigns it; documented under
    the package instead, a constant would show its type's docstring (``int``'s, ``dict``'s).
    """
    assign = re.compile(rf"^{re.escape(name)}\b[^=\n]*=", re.M)
    for modname, mod in sorted(sys.modules.items()):
        if (modname == package or modname.startswith(package + ".")) and getattr(mod, "__file__", None):
            if assign.search(Path(mod.__file__).read_text(encoding="utf-8")):
                return modname
    return package


def write_api_pages(out: Path = HERE / "api") -> None:
    """One page per package: each name of its ``__all__``, documented once, where it is defined."""
    modules = {p: importlib.import_module(p) for p in PACKAGES}
    exported = {p: list(getattr(m, "__all__", [])) for p, m in modules.items()}
    exporters: dict[tuple[str, int], list[str]] = {}
    for p, names in exported.items():
        for n in names:
            exporters.setdefault((n, id(getattr(modules[p], n))), []).append(p)
    out.mkdir(exist_ok=True)
    for p, names in exported.items():
        title = f"``{p}``"
        lines = [title, "=" * len(title), "", f".. automodule:: {p}", "   :no-members:", ""]
        if not names:
            lines += ["This package exports no names of its own; see its modules' docstrings.", ""]
        for n in names:
            obj = getattr(modules[p], n)
            owner = _owner(n, obj, exporters[(n, id(obj))])
            if owner != p:
                lines += [f"* :py:obj:`{n} <{owner}.{n}>` — see :doc:`{owner}`", ""]
                continue
            d = _directive(obj)
            where = _defining_module(p, n) if d == "autodata" else p
            lines += [f".. {d}:: {where}.{n}"]
            if d == "autoclass":
                lines += ["   :members:"]
            if d == "autodata":
                lines += ["   :no-value:"]
            lines += [""]
        (out / f"{p}.rst").write_text("\n".join(lines), encoding="utf-8")
    toc = ["API reference", "=============", "",
           "Every public name of clomp's packages (their ``__all__``), documented once where it is defined;",
           "a package that re-exports a name links to that place.", "", ".. toctree::", "   :maxdepth: 1", ""]
    toc += [f"   {p}" for p in PACKAGES]
    (out / "index.rst").write_text("\n".join(toc) + "\n", encoding="utf-8")


_NO_DOT = ('<svg xmlns="http://www.w3.org/2000/svg" width="480" height="40"><text x="4" y="24" font-size="14">'
           "Graphviz (dot) was not installed where these docs were built: no picture</text></svg>\n")


def write_figures(out: Path = HERE / "_generated") -> None:
    """The figures the pages show, drawn by the library itself at build time (as ``clomp plan
    --scenario overtaking --figure``, ``clomp simulate --animate`` and ``clomp demo`` draw them),
    so a page never shows a stale picture."""
    import clomp
    from clomp.formal.export import render_svg
    from clomp.runtime.backends.world import WorldNoise
    from clomp.runtime.experiment.animation import animate_run
    from clomp.runtime.experiment.onerun import run_once
    from clomp.runtime.experiment.plots import plot_run
    from clomp.runtime.experiment.tasktree import plot_task_tree
    from clomp.runtime.supervision.states import state_machine_dot

    out.mkdir(exist_ok=True)
    scene = clomp.load_scenario("overtaking")
    scan = scene.scan()
    result = clomp.plan(scan, goal=scene.goal_in_robot_frame())
    plot_task_tree(result, out / "fig3c_overtaking.png", scan, title="overtaking: explored task tree")
    from clomp.runtime.experiment.physics_view import plot_physics_world

    plot_physics_world(result, out / "physics_overtaking.png", scan)
    dot = Path(out / "supervisor.dot")
    dot.write_text(state_machine_dot(), encoding="utf-8")
    import shutil
    import subprocess

    if shutil.which("dot") is not None:
        render_svg(result.map, out / "cognitive_map_overtaking.svg")
        subprocess.run(["dot", "-Tsvg", str(dot), "-o", str(out / "supervisor.svg")], check=True, timeout=60)
    else:  # no Graphviz on this machine: the pages still build, the two pictures say what is missing
        for name in ("cognitive_map_overtaking.svg", "supervisor.svg"):
            (out / name).write_text(_NO_DOT, encoding="utf-8")
    for name, gif in (("overtaking", True), ("cul-de-sac", False)):  # as clomp simulate runs them
        sc = clomp.load_scenario(name)
        run = run_once(sc, "planning", sc.raw.get("seed", 0), noise=WorldNoise.for_scene(sc, "paper", 1.0), keep_report=True)
        plot_run(run.trace(), out / f"trajectory_{name}.png", title=f"{name} — planning")
        if gif:
            animate_run(run.trace(), out / f"run_{name}.gif", title=f"{name}: planned and executed closed-loop")


def _write_cli() -> None:
    """The command-line reference (``docs/cli/``), from the argparse parsers themselves."""
    from cliref import write_cli_pages

    write_cli_pages(HERE / "cli")


def _drop_type_docstring(app: object, what: str, name: str, obj: object, options: object, lines: list[str]) -> None:
    """A constant without a ``#:`` comment: show nothing rather than its type's docstring."""
    if what == "data" and lines and type(obj).__doc__ and "\n".join(lines).strip() == inspect.cleandoc(type(obj).__doc__ or ""):
        lines.clear()


def setup(app: object) -> None:
    # the API pages are written when Sphinx starts, before it reads the sources (not on import:
    # pytest imports this file as a module when it collects doctests)
    app.connect("builder-inited", lambda _app: write_api_pages())  # type: ignore[attr-defined]
    app.connect("builder-inited", lambda _app: write_figures())  # type: ignore[attr-defined]
    app.connect("builder-inited", lambda _app: _write_cli())  # type: ignore[attr-defined]
    app.connect("autodoc-process-docstring", _drop_type_docstring)  # type: ignore[attr-defined]
