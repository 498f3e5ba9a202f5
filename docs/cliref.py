"""The command-line reference, written from ``clomp``'s own argparse parsers (not by hand).

:func:`write_cli_pages` walks :func:`clomp.runtime.cli.build_parser` and writes one
reStructuredText page per subcommand under ``docs/cli/`` — its description, usage, every
argument as a Sphinx ``option`` (with its choices and default) and its exit statuses — and an
index listing the subcommands. ``docs/conf.py`` calls it when Sphinx starts, so a new option
appears in the site the moment it is added to a parser.

>>> import tempfile
>>> from pathlib import Path
>>> out = Path(tempfile.mkdtemp())
>>> names = write_cli_pages(out)
>>> "simulate" in names and (out / "simulate.rst").read_text(encoding="utf-8").count(".. option:: --scenario") == 1
True
"""

from __future__ import annotations

import argparse
import re
import textwrap
from pathlib import Path

HERE = Path(__file__).resolve().parent

_SPECIAL = re.compile(r"([\\*`|_\[\]<>])")
_OPTION = re.compile(r"(?<![\w`])(--?[a-z][\w-]*)")


def _escape(text: str) -> str:
    """Help text as plain reStructuredText: markup characters escaped, options shown as code
    (so that ``--noise`` is not typeset as a dash).

    >>> _escape("a *b* d_ as --noise ideal")
    'a \\\\*b\\\\* d\\\\_ as ``--noise`` ideal'
    """
    return _OPTION.sub(r"``\1``", _SPECIAL.sub(r"\\\1", text))


def _literal(text: str, width: int = 78) -> list[str]:
    """``text`` as a plain-text block: the lines of a flush-left paragraph joined and wrapped to
    ``width``, indented lines (lists, tables, usage) kept, wrapped under their own indentation.

    >>> _literal("a b\\nc\\n  - x")[2:]
    ['   a b c', '     - x', '']
    """
    paras: list[tuple[str, str]] = []
    for line in text.replace("``", "").rstrip().splitlines():  # reST literals as plain text (as --help shows)
        body = line.strip()
        indent = line[: len(line) - len(line.lstrip())]
        joins = body and not indent and paras and paras[-1][1] and not paras[-1][0] and not re.match(r"[-*•]|\d+\.", body)
        if joins:
            paras[-1] = ("", paras[-1][1] + " " + body)
        else:
            paras.append((indent, body))
    out = [".. code-block:: text", ""]
    for indent, body in paras:
        wrapped = textwrap.wrap(body, width - len(indent), subsequent_indent="  " if indent else "") or [""]
        out += ["   " + indent + w if w else "" for w in wrapped]
    return out + [""]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _helps(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Subcommand → its one-line help (what ``clomp --help`` lists)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return {a.dest: a.help or "" for a in action._choices_actions}
    return {}


def _signature(action: argparse.Action, formatter: argparse.HelpFormatter) -> str:
    """``--noise {ideal,paper}``, ``-o FILE, --output FILE``, ``family``: as ``--help`` shows it."""
    if not action.option_strings:
        return action.dest if action.metavar is None else str(action.metavar)
    if action.nargs == 0:
        return ", ".join(action.option_strings)
    arg = formatter._format_args(action, formatter._get_default_metavar_for_optional(action))
    return ", ".join(f"{opt} {arg}" for opt in action.option_strings)


def _option(action: argparse.Action, formatter: argparse.HelpFormatter) -> list[str]:
    help_text = "" if action.help is None else action.help
    if "%(" in help_text:
        help_text = help_text % {**vars(action), "prog": "clomp", "default": action.default}
    lines = [f".. option:: {_signature(action, formatter)}", ""]
    lines.append("   " + (_escape(help_text) or "(no help text)"))
    extra = []
    if action.choices is not None and not isinstance(action.choices, dict):
        extra.append("choices: " + ", ".join(f"``{c}``" for c in action.choices))
    default = action.default
    if action.option_strings and default not in (None, False, argparse.SUPPRESS) and action.nargs != 0:
        extra.append(f"default: ``{default}``")
    if extra:
        lines += ["", "   " + "; ".join(extra) + "."]
    return lines + [""]


def _body(prog: str, parser: argparse.ArgumentParser, under: str) -> list[str]:
    """Description, usage, arguments and notes of one parser; its own subcommands (``clomp ros
    node``) follow as sections underlined with ``under``, their parts one level deeper."""
    lines: list[str] = []
    if parser.description:
        lines += [".. rubric:: Description", ""] + _literal(parser.description)
    lines += [".. rubric:: Usage", ""] + _literal(parser.format_usage().removeprefix("usage: "))
    lines += [f".. program:: {prog}", ""]
    formatter = parser._get_formatter()
    deeper = {"-": "~", "~": "^", "^": '"'}[under]
    nested = _subparsers(parser)
    for group in parser._action_groups:
        actions = [a for a in group._group_actions
                   if a.help is not argparse.SUPPRESS and not isinstance(a, argparse._SubParsersAction)]
        if not actions:
            continue
        heading = {"options": "Options", "positional arguments": "Arguments"}.get(group.title or "", group.title or "Options")
        lines += [heading, under * len(heading), ""]
        if group.description:
            lines += [_escape(group.description), ""]
        for action in actions:
            lines += _option(action, formatter)
    if parser.epilog:
        lines += ["Notes and exit status", under * len("Notes and exit status"), ""] + _literal(parser.epilog)
    helps = _helps(parser)
    for name, sub in nested.items():
        title = f"{prog} {name}"
        lines += [title, under * len(title), ""]
        if helps.get(name):
            lines += [_escape(helps[name]) + ".", ""]
        lines += _body(title, sub, deeper)
    return lines


def command_page(name: str, parser: argparse.ArgumentParser, summary: str) -> str:
    """One subcommand's page (reStructuredText), its own subcommands included."""
    title = f"clomp {name}"
    lines = [f".. _cli-{name}:", "", title, "=" * len(title), "", _escape(summary) + ".", ""]
    lines += _body(title, parser, "-")
    return "\n".join(lines) + "\n"


def write_cli_pages(out: Path = HERE / "cli") -> list[str]:
    """Write ``out/index.rst`` and one page per subcommand; returns the subcommands, in ``--help``'s order."""
    from clomp.runtime.cli import build_parser

    parser = build_parser()
    commands = _subparsers(parser)
    helps = _helps(parser)
    out.mkdir(parents=True, exist_ok=True)
    for name, sub in commands.items():
        (out / f"{name}.rst").write_text(command_page(name, sub, helps.get(name, "")), encoding="utf-8")
    index = ["Command-line reference", "======================", "",
             "Written when the site is built from ``clomp``'s own argument parsers (``docs/cliref.py``), so",
             "it lists exactly the options the installed command takes. ``clomp COMMAND --help`` prints the same.", "",
             ".. rubric:: Usage", ""] + _literal(parser.format_usage().removeprefix("usage: "))
    index += [f"* :doc:`{name}` — {_escape(helps.get(name, ''))}" for name in commands] + [""]
    if parser.epilog:
        index += [".. rubric:: Exit status", ""] + _literal(parser.epilog)
    index += [".. toctree::", "   :hidden:", ""] + [f"   {name}" for name in commands] + [""]
    (out / "index.rst").write_text("\n".join(index), encoding="utf-8")
    return list(commands)
