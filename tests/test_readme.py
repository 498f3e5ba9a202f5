"""The README's examples run: its Python block and every command of its `clomp …` blocks.

The two install commands of the quick start make virtualenvs (what ``.ci/run`` does on a
clean clone); every other code block of the README is run here, as a user would paste it,
in a folder holding the files it names (``scan.dat``, ``DIR``).
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text(encoding="utf-8")
BLOCKS = re.findall(r"```(\w+)\n(.*?)```", README, flags=re.S)
INSTALL = ("python3 -m venv",)


def _commands() -> list[str]:
    out = []
    for lang, body in BLOCKS:
        if lang != "sh":
            continue
        for line in body.splitlines():
            cmd = re.split(r"\s+#", line)[0].strip()
            if cmd and not cmd.startswith(INSTALL):
                out.append(cmd)
    return out


@pytest.fixture
def workdir(tmp_path: Path) -> Path:
    scan = np.array([[0.5, 0.25], [0.5, -0.25], [0.6, 0.3], [0.7, -0.3]])
    np.savetxt(tmp_path / "scan.dat", scan)
    (tmp_path / "DIR").mkdir()
    np.savetxt(tmp_path / "DIR" / "a.dat", scan)
    np.savetxt(tmp_path / "DIR" / "b.dat", scan[:2])
    return tmp_path


def test_the_readme_has_its_examples() -> None:
    assert [lang for lang, _ in BLOCKS].count("python") >= 1 and len(_commands()) >= 5
    assert len(README.splitlines()) <= 200


@pytest.mark.parametrize("command", _commands())
def test_every_clomp_command_of_the_readme_runs(command: str, workdir: Path) -> None:
    argv = shlex.split(command)
    assert argv[0] == "clomp", command
    argv = [a.replace("../shared/", str(REPO.parent / "shared") + "/") for a in argv[1:]]
    if any("shared" in a for a in argv) and not (REPO.parent / "shared").is_dir():
        pytest.skip("the shared recorded scans are not beside this clone")
    r = subprocess.run([sys.executable, "-m", "clomp", *argv], cwd=workdir, capture_output=True, text=True, timeout=300)
    assert r.returncode in (0, 1), (command, r.stderr[-2000:])  # 1: ran, the goal not reached (a partial plan)
    assert "Traceback" not in r.stderr


def test_the_readme_python_example_runs(workdir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(workdir)
    for lang, body in BLOCKS:
        if lang == "python":
            exec(compile(body, "README.md", "exec"), {})  # noqa: S102 - the README's own example
    assert (workdir / "map.json").stat().st_size > 0
