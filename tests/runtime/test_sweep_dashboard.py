"""Issue #41: a sweep on a local cluster (``--workers N``) names the Dask dashboard, and the
``dask`` extra installs what serves it (bokeh)."""

from __future__ import annotations

import tomllib
import urllib.request
from pathlib import Path

import pytest

from clomp.runtime.experiment.driver import run_specs
from clomp.runtime.experiment.runspec import RunSpec

REPO = Path(__file__).resolve().parents[2]


def test_the_dask_extra_installs_bokeh_for_the_dashboard() -> None:
    extras = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert any(req.replace(" ", "").startswith("bokeh") for req in extras["dask"]), extras["dask"]


def test_a_local_cluster_names_its_dashboard() -> None:
    pytest.importorskip("distributed")
    pytest.importorskip("bokeh")
    links: list[tuple[str, int]] = []

    def served(link: str) -> None:  # asked while the cluster runs: the page must be there, not only its address
        with urllib.request.urlopen(link, timeout=120) as page:  # a hang bound, not a deadline
            links.append((link, page.status))

    recs = run_specs([RunSpec("open", 0, 0, "reactive", "ideal", max_time=2.0)], workers=1, on_dashboard=served)
    assert len(recs) == 1
    assert len(links) == 1 and links[0][0].startswith("http://127.0.0.1:") and links[0][1] == 200, links
