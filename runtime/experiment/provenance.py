"""Which code made an experiment's results: resume only what this code would produce.

A run is a pure function of its spec *and of the code*. ``--resume`` keeps the runs already
in the output folder, so a folder filled by another version of clomp (a ``git pull``, an
edited preset) would mix two experiments in one table. Each output folder therefore holds
``provenance.json`` naming the code that made it; resuming with different code is refused
with a clear message instead.

>>> v = code_version()
>>> v.startswith("clomp ") and len(v.split()[-1]) == 16
True
"""

from __future__ import annotations

import hashlib
import json
from functools import lru_cache
from importlib import metadata
from pathlib import Path

__all__ = ["PROVENANCE_FILE", "ResumeMismatch", "claim_folder", "code_version"]

PROVENANCE_FILE = "provenance.json"

_ROOT = Path(__file__).resolve().parents[2]
#: what a run's result depends on: the three packages and the specs (noise presets, scenarios)
_SOURCES = ("formal", "planner", "runtime", "specs")


class ResumeMismatch(RuntimeError):
    """``--resume`` on a folder whose runs another version of the code made."""


@lru_cache(maxsize=1)
def code_version() -> str:
    """``"clomp VERSION SOURCEHASH"``: the package version and a hash of every source and spec
    file a run depends on (so an edit without a version bump still counts as other code)."""
    digest = hashlib.sha256()
    for top in _SOURCES:
        for path in sorted((_ROOT / top).rglob("*")):
            if path.is_file() and path.suffix in (".py", ".json", ".yaml", ".yml") and "__pycache__" not in path.parts:
                digest.update(path.relative_to(_ROOT).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    try:
        version = metadata.version("clomp")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return f"clomp {version} {digest.hexdigest()[:16]}"


def claim_folder(folder: Path, resume: bool) -> None:
    """Create ``folder`` for this code's runs; with ``resume``, refuse one another code made.

    A folder from before provenance was recorded has no file: its runs are kept (nothing
    says they differ) and the file is written from now on.
    """
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / PROVENANCE_FILE
    mine = code_version()
    if resume and path.exists():
        try:
            theirs = json.loads(path.read_text(encoding="utf-8")).get("code")
        except (OSError, ValueError, AttributeError):
            theirs = None
        if theirs != mine:
            raise ResumeMismatch(
                f"--resume: the runs in {folder} were made by {theirs or 'unrecorded code'}, this is {mine}; "
                "results of two versions would mix: use a new --out folder or run without --resume"
            )
    path.write_text(json.dumps({"code": mine}) + "\n", encoding="utf-8")
