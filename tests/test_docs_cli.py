"""The site's command-line reference (docs/cliref.py) is written from the argparse parsers: every
subcommand, nested ones included, has its section and every option string of every argument its
``.. option::`` entry, so the reference cannot fall behind the command."""

from __future__ import annotations

import argparse
import importlib.util
import re
from pathlib import Path

from clomp.runtime.cli import build_parser

DOCS = Path(__file__).resolve().parent.parent / "docs"


def _cliref():
    spec = importlib.util.spec_from_file_location("cliref", DOCS / "cliref.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _walk(prog: str, parser: argparse.ArgumentParser):
    yield prog, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _walk(f"{prog} {name}", sub)


def test_every_subcommand_and_option_is_in_the_reference(tmp_path):
    names = _cliref().write_cli_pages(tmp_path)
    parser = build_parser()
    top = {n for n in next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices}
    assert set(names) == top and {p.stem for p in tmp_path.glob("*.rst")} == top | {"index"}
    index = (tmp_path / "index.rst").read_text(encoding="utf-8")
    checked = 0
    for name in names:
        page = (tmp_path / f"{name}.rst").read_text(encoding="utf-8")
        assert f":doc:`{name}`" in index
        sections = page.split(".. program:: ")[1:]
        programs = {s.splitlines()[0]: s for s in sections}
        for prog, p in _walk(f"clomp {name}", parser._subparsers._group_actions[0].choices[name]):
            assert prog in programs, prog
            options = re.findall(r"^\.\. option:: (.*)$", programs[prog].split("\n.. program:: ")[0], re.M)
            for action in p._actions:
                if isinstance(action, argparse._SubParsersAction) or action.help is argparse.SUPPRESS:
                    continue
                for opt in action.option_strings or [action.metavar or action.dest]:
                    assert any(opt in {part.split(" ")[0] for part in o.split(", ")} for o in options), (prog, opt)
                    checked += 1
    assert checked > 150
