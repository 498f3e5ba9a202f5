"""One import name: what a user installs is ``clomp`` and nothing else, from a wheel and from the tree.

The repository keeps ``planner/``, ``formal/``, ``runtime/``, ``specs/`` at its top (the design
card's layout); they are installed only as ``clomp.planner`` … A second copy loaded under a bare
name would be a second set of classes (``isinstance`` failing across them), so a bare import must
fail, and the doctests, the tutorials and the tests must all see one module tree.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TOP = ("planner", "formal", "runtime", "specs")


def _python(code: str, cwd: Path, path: str | None = None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if path is not None:
        env["PYTHONPATH"] = path
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


def test_no_bare_copy_is_loaded_in_this_session() -> None:
    import clomp.planner
    import clomp.runtime.cli

    assert sys.modules["clomp.planner"] is clomp.planner
    assert not sorted(n for n in sys.modules if n.split(".")[0] in TOP)


@pytest.mark.parametrize("name", TOP)
def test_a_bare_import_from_the_repository_root_fails_and_names_clomp(name: str) -> None:
    # from the root, Python finds the folder itself: the package refuses to load under that name
    r = _python(f"import {name}", cwd=REPO)
    assert r.returncode != 0 and f"import clomp.{name}, not {name}" in r.stderr, r.stderr


def test_the_wheel_installs_clomp_alone_with_its_data(tmp_path: Path) -> None:
    """Built as a user would (``pip wheel .``), installed into a folder of its own, imported from it."""
    # from a clean copy of the tree: a build/ or *.egg-info left in the checkout would hide a missing file
    src = tmp_path / "src"
    shutil.copytree(REPO, src, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", ".mypy_cache", ".ruff_cache", ".hypothesis", "clomp-*-out"))
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                            "-w", str(tmp_path / "dist"), str(src)], capture_output=True, text=True, timeout=600)
    assert build.returncode == 0, build.stderr
    (wheel,) = (tmp_path / "dist").glob("clomp-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert {n.split("/")[0] for n in names} == {"clomp", wheel.name.split("-")[0] + "-" + wheel.name.split("-")[1] + ".dist-info"}
    for data in ("clomp/specs/scenarios/overtaking.json", "clomp/specs/properties/supervisor/machine.pctl",
                 "clomp/specs/properties/closed_loop/map.pctl", "clomp/specs/properties/closed_loop/plan.pctl",
                 "clomp/specs/noise_presets.json", "clomp/specs/policies/linear-default.json", "clomp/planner/py.typed"):
        assert data in names
    site = tmp_path / "site"
    inst = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site), str(wheel)],
                          capture_output=True, text=True, timeout=600)
    assert inst.returncode == 0, inst.stderr
    assert sorted(p.name for p in site.iterdir() if not p.name.endswith(".dist-info")) in (["clomp"], ["bin", "clomp"])
    r = _python("import clomp, clomp.planner, clomp.formal, clomp.runtime, clomp.specs\n"
                "from clomp.formal.control import machine_property_file\n"
                "print(clomp.__file__, clomp.load_scenario('overtaking').name, machine_property_file().exists())",
                cwd=tmp_path, path=str(site))
    assert r.returncode == 0, r.stderr
    where, scenario, props = r.stdout.split()
    assert Path(where).is_relative_to(site) and scenario == "overtaking" and props == "True"
    assert "No module named 'planner'" in _python("import planner", cwd=tmp_path, path=str(site)).stderr
