"""Generate the reference pages from the code: every command and option from the argparse parser
(:func:`setupfix.cli.build_parser`), every model key from the loader's key tables.

Used two ways: as a Sphinx extension (``conf.py`` lists it; the pages are written before Sphinx reads
the sources, so the site can never describe a parser that is not the one installed) and from the tests
(tests/docs/), which compare the parser with the generated text.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
REFERENCE = HERE.parent / "reference"
CLI_PAGE = REFERENCE / "cli.md"
KEYS_PAGE = REFERENCE / "model-keys.md"


def commands(
    parser: argparse.ArgumentParser | None = None, path: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """Every (sub)command of the parser, depth first: ``(("model", "init"), parser)``."""
    if parser is None:
        from setupfix.cli import build_parser

        parser = build_parser()
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from commands(sub, (*path, name))


def options(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    """The arguments of one parser, sub-command groups left out."""
    return [a for a in parser._actions if not isinstance(a, argparse._SubParsersAction)]


def _help_of(parser: argparse.ArgumentParser) -> dict[str, str]:
    helps: dict[str, str] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                helps[choice.dest] = choice.help or ""
    return helps


def _escape(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ").replace("*", "\\*").replace("<", "&lt;")


def _describe(action: argparse.Action, parser: argparse.ArgumentParser) -> str:
    text = action.help or ""
    if text == argparse.SUPPRESS:
        text = ""
    params: dict[str, Any] = {**vars(action), "prog": parser.prog}
    if isinstance(params.get("choices"), dict | list | tuple | set | frozenset):
        params["choices"] = ", ".join(map(str, params["choices"]))
    with contextlib.suppress(KeyError, TypeError, ValueError):
        text = text % params
    extra = []
    if action.choices is not None and not isinstance(action, argparse._SubParsersAction):
        extra.append("choices: " + ", ".join(f"`{c}`" for c in action.choices))
    if action.default not in (None, False, argparse.SUPPRESS) and action.option_strings and "default" not in text:
        extra.append(f"default: `{action.default}`")
    if extra:
        text = f"{text} ({'; '.join(extra)})" if text else "; ".join(extra)
    return _escape(" ".join(text.split()))


def _form(action: argparse.Action) -> str:
    if not action.option_strings:
        meta = action.metavar or action.dest
        return f"`{_cell(str(meta))}`" + (" …" if action.nargs in ("*", "+") else "")
    meta = ""
    if action.nargs != 0:
        m = action.metavar or action.dest.upper()
        meta = " " + (" ".join(m) if isinstance(m, tuple) else str(m))
    return ", ".join(f"`{o}{_cell(meta)}`" for o in action.option_strings)


def _cell(code: str) -> str:
    """Code in a table cell: a ``|`` would end the cell (``--db PATH|URL``)."""
    return code.replace("|", "\\|")


def cli_markdown() -> str:
    """The command-line reference page (MyST Markdown)."""
    lines = [
        "# Command-line reference",
        "",
        "Generated from the argument parser (`setupfix.cli.build_parser`) by `docs/_ext/setupfix_reference.py`",
        "at every build; do not edit by hand. Each command also answers `--help`.",
        "",
    ]
    for path, parser in commands():
        if not path:
            lines += ["## `setupfix`", "", "Global options:", ""]
        else:
            lines += [f"{'#' * min(len(path) + 1, 4)} `setupfix {' '.join(path)}`", ""]
        parent_help = ""
        if path:
            parents = dict(commands())
            parent_help = _help_of(parents[path[:-1]]).get(path[-1], "")
        if parent_help:
            lines += [_escape(parent_help[0].upper() + parent_help[1:]) + ".", ""]
        usage = " ".join(parser.format_usage().split())
        lines += ["```text", usage.removeprefix("usage: "), "```", ""]
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if subs:
            lines += ["| command | what it does |", "|---|---|"]
            for name, help_ in _help_of(parser).items():
                lines.append(f"| `{name}` | {_escape(help_)} |")
            lines.append("")
        acts = options(parser)
        if acts:
            lines += ["| argument | meaning |", "|---|---|"]
            for action in acts:
                lines.append(f"| {_form(action)} | {_describe(action, parser)} |")
            lines.append("")
        if parser.epilog and path:
            lines += ["```text", parser.epilog.strip("\n"), "```", ""]
    return "\n".join(lines).rstrip() + "\n"


def key_tables() -> dict[str, dict[str, frozenset[str]]]:
    """Every key the model loader accepts, by table: ``{"one-axis": {"process": {...}}, ...}``."""
    from setupfix.model import axes, effects, safety, stations, tables

    free = frozenset(tables.FREE_TEXT)
    base = {section: frozenset(keys) - free for section, keys in tables.TABLE_KEYS.items()}
    for section in ("wks", "tools"):
        base[section] = base[section] | safety.REGISTER_KEYS
    return {
        "tables": base,
        "multi-axis": {s: frozenset(k) for s, k in axes.MULTI_KEYS.items()},
        "sections": {
            "safety": frozenset(safety.SAFETY_KEYS),
            "safety.dimensions.ID": frozenset(safety.DIMENSION_KEYS),
            "measurement": frozenset(safety.MEASUREMENT_KEYS),
            # the head of [effects]: literal in effects.py (tested in tests/docs/test_reference.py)
            "effects": EFFECTS_HEAD,
            "effects.ID": frozenset(effects.EFFECT_KEYS) - free,
        },
        "stations": {
            "stations.ID": frozenset(stations.STATION_KEYS) - free,
            "template": frozenset(stations.TEMPLATE_KEYS),
        },
        "free": {"any table": free},
    }


#: The keys of the ``[effects]`` table itself (its sub-tables are the effects).
EFFECTS_HEAD = frozenset({"origin", "cycle_hours", "last_hours"})

_TABLE_NAME = {
    "process": "[process]",
    "machine": "[machine.ID]",
    "wks": "[wks.ID]",
    "tools": "[tools.ID]",
    "features": "[features.ID]",
    "dimensions": "[dimensions.ID]",
}


def keys_markdown() -> str:
    """The model-key reference page (MyST Markdown)."""
    from setupfix.model import effects

    t = key_tables()
    lines = [
        "# Model keys",
        "",
        "Generated from the model loader's key tables (`setupfix/model/tables.py` `TABLE_KEYS`,",
        "`setupfix/model/axes.py` `MULTI_KEYS`, `setupfix/model/safety.py`, `setupfix/model/effects.py`,",
        "`setupfix/model/stations.py`) at every build; do not edit by hand. What each key means is in",
        "[the process model file](process-model.md); a key not listed here is refused by the loader",
        "with the list of the keys it expected.",
        "",
    ]
    lines += ["## Tables of every model", "", "| table | keys |", "|---|---|"]
    for s, keys in t["tables"].items():
        lines.append(f"| `{_TABLE_NAME.get(s, s)}` | {', '.join(f'`{k}`' for k in sorted(keys))} |")
    lines += [
        "",
        "## Multi-axis keys",
        "",
        "Accepted only in a model whose `[process]` table has `axes = [...]`; elsewhere refused as",
        '"a multi-axis key".',
        "",
        "| table | keys |",
        "|---|---|",
    ]
    for s, keys in t["multi-axis"].items():
        lines.append(f"| `{_TABLE_NAME.get(s, s)}` | {', '.join(f'`{k}`' for k in sorted(keys))} |")
    lines += ["", "## Safety and effects", "", "| table | keys |", "|---|---|"]
    for s, keys in t["sections"].items():
        lines.append(f"| `[{s}]` | {', '.join(f'`{k}`' for k in sorted(keys))} |")
    lines += [
        "",
        "Effect kinds (`kind` in `[effects.ID]`): " + ", ".join(f"`{k}`" for k in effects.EFFECT_KINDS) + ".",
        "",
    ]
    lines += ["## Station templates", "", "| table | keys |", "|---|---|"]
    for s, keys in t["stations"].items():
        lines.append(f"| `[{s}]` | {', '.join(f'`{k}`' for k in sorted(keys))} |")
    lines += [
        "",
        "## Free text",
        "",
        "Any table may also hold "
        + ", ".join(f"`{k}`" for k in sorted(t["free"]["any table"]))
        + ": text for people, ignored by the loader.",
        "",
    ]
    return "\n".join(lines).rstrip() + "\n"


def write_pages() -> list[Path]:
    """(Re)write the generated pages; only files whose text changed are touched."""
    written = []
    for path, text in ((CLI_PAGE, cli_markdown()), (KEYS_PAGE, keys_markdown())):
        path.parent.mkdir(parents=True, exist_ok=True)
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
            written.append(path)
    return written


def setup(app: Any) -> dict[str, Any]:
    """Sphinx entry point: the pages are written when the extension loads, before any source is read."""
    write_pages()
    return {"parallel_read_safe": True, "parallel_write_safe": True}


if __name__ == "__main__":
    for p in write_pages():
        print(f"wrote {p}")
