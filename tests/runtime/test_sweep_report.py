"""``clomp sweep`` and ``clomp experiment --report``: every cell run once, one page a browser and a parser read."""

from __future__ import annotations

import json
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

from clomp.runtime.cli import main
from clomp.runtime.cli.sweep import parse_seeds
from clomp.runtime.experiment.htmlpage import write_report


class _Count(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: dict[str, int] = {}
        self.external: list[str] = []
        self.h2: list[str] = []
        self._in_h2 = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags[tag] = self.tags.get(tag, 0) + 1
        self._in_h2 = tag == "h2"
        for k, v in attrs:
            if k in ("src", "href") and v and not (v.startswith("#") or v.startswith("data:")):
                self.external.append(v)

    def handle_data(self, data: str) -> None:
        if self._in_h2:
            self.h2.append(data)
            self._in_h2 = False


def _parse(text: str) -> _Count:
    p = _Count()
    p.feed(text)
    return p


def test_a_sweep_runs_every_cell_once_and_writes_one_page(tmp_path: Path) -> None:
    out = tmp_path / "sw"
    code = main(["sweep", "--families", "overtaking,doorway", "--noise", "ideal,paper", "--runs", "1",
                 "--condition", "planning", "--condition", "reactive", "--workers", "0", "--out", str(out)])
    assert code == 0
    keys = [json.loads(line)["key"] for line in (out / "runs.jsonl").read_text().splitlines()]
    assert len(keys) == len(set(keys)) == 2 * 2 * 1 * 2  # families × presets × runs × conditions, nothing lost
    summary = json.loads((out / "summary.json").read_text())
    assert sorted((c["family"], c["noise"]) for c in summary["cells"]) == [
        ("doorway", "ideal"), ("doorway", "paper"), ("overtaking", "ideal"), ("overtaking", "paper")]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in (out / "table.md").read_text().splitlines()[2:]]
    assert len(rows) == 8  # one row per cell and condition, as the runs say
    by_row = {(r[0], r[1], r[2]): r for r in rows}
    for line in (out / "runs.jsonl").read_text().splitlines():
        rec = json.loads(line)
        row = by_row[(rec["family"], rec["noise"], rec["condition"])]
        assert row[3] == "1" and row[4].split()[0] == str(rec["success"]) and row[5] == str(rec["collisions"])
    page = _parse((out / "report.html").read_text())
    assert page.tags["details"] == 8 and page.tags["svg"] == 8  # every run drillable, drawn
    assert len([h for h in page.h2 if "runs" in h]) == 4  # one section per cell
    assert page.external == []  # offline: nothing fetched


def test_seeds_and_names_are_checked_before_any_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert parse_seeds("3,0-1") == [0, 1, 3]
    for argv, words in ((["--seeds", "2-1"], "--seeds"), (["--families", "nowhere"], "--families"),
                        (["--noise", "loud"], "--noise")):
        assert main(["sweep", *argv, "--workers", "0", "--out", str(tmp_path / "x")]) == 2
        assert words in capsys.readouterr().err


def test_experiment_report_embeds_its_figures_and_chromium_renders_it(tmp_path: Path) -> None:
    out = tmp_path / "ex"
    assert main(["experiment", "overtaking", "--runs", "2", "--noise", "ideal", "--workers", "0", "--out", str(out),
                 "--report"]) == 0
    text = (out / "report.html").read_text()
    page = _parse(text)
    assert page.tags.get("img", 0) >= 2 and page.external == []  # the PNGs are inside the page
    assert page.tags["details"] == 4 and "McNemar" in text
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("no headless Chromium on this machine")
    dom = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--disable-quic", "--no-first-run",
                          "--disable-background-networking", "--disable-component-update", "--disable-sync", "--dump-dom",
                          (out / "report.html").as_uri()], capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0
    rendered = _parse(dom.stdout)
    assert rendered.tags.get("details") == 4 and rendered.tags.get("svg") == 4


def test_a_record_without_its_trace_still_gets_a_row(tmp_path: Path) -> None:
    rec = {"key": "k", "family": "open", "noise": "ideal", "condition": "planning", "run": 0, "success": 0,
           "reached_goal": 0, "believed_goal": 1, "false_success": 1, "collisions": 0, "brushes": 0,
           "final_error_m": 0.4, "time_s": 5.0, "wall_s": 0.1}
    text = write_report([rec], tmp_path / "r.html", "t").read_text()
    assert "FALSE SUCCESS" in text and "no trace kept" in text


def _rec(run: int, family: str, path: list[list[float]]) -> dict[str, object]:
    return {"key": f"{family}/{run}", "family": family, "noise": "ideal", "noise_scale": 1.0, "gyro": 1,
            "condition": "planning", "run": run, "success": 1, "reached_goal": 1, "believed_goal": 1,
            "false_success": 0, "collisions": 0, "brushes": 0, "final_error_m": 0.02, "time_s": 11.0,
            "time_to_goal_s": 11.0, "wall_s": 0.5, "end_state": "GOAL_REACHED", "obstacles": [], "goal": [1.0, 0.0],
            "start": [0.0, 0.0, 0.0], "path": path, "estimate": [], "contacts": []}


def test_a_large_sweeps_page_stays_small_and_opens_on_every_cell(tmp_path: Path) -> None:
    # a robot that stands 100 s then drives: a point every 0.1 s, most within a pixel of the last
    path = [[0.0, 0.0]] * 1000 + [[i / 100, 0.0] for i in range(101)]
    recs = [_rec(k, fam, path) for fam in ("overtaking", "doorway") for k in range(3)]
    text = write_report(recs, tmp_path / "r.html", "t").read_text()
    drawn = [seg.split('"')[0].split() for seg in text.split('<polyline points="')[1:]]
    assert len(drawn) == 6 and all(2 < len(pts) <= 60 for pts in drawn)  # 1,101 points → under the stroke's width apart
    assert all(pts[0] == drawn[0][0] and pts[-1] == drawn[0][-1] for pts in drawn)  # the ends kept
    page = _parse(text)
    cells = text.split("<h2>Every cell</h2>")[1].split("</table>")[0]
    assert cells.count("<tr>") == 1 + 2  # a header and a row per cell and condition
    assert 'href="#b0"' in cells and 'href="#b1"' in cells and page.tags["details"] == 6
