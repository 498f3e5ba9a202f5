"""Command-line conventions a user relies on: arguments as typed, exit statuses, help text."""

from __future__ import annotations

import json

import pytest

from runtime.cli import main


@pytest.mark.parametrize("argv", [["--goal", "-0.8,0"], ["--goal=-0.8,0"], ["--goal", "-.5,-0.2"]])
def test_a_negative_goal_is_taken_as_typed(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    rc = main(["plan", "--scenario", "open", *argv, "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0
    assert out["goal"][0] < 0
