"""The command examples of the documentation, read from the Markdown, run and compared.

One checker serves the pytest suite (``tests/docs/``) and the Sphinx build (``docs/_ext/docs_examples.py``
loads this file), so a drifting example fails both.

An example is a fenced block whose info string is ``console``: each line starting with ``$ `` is a
command (run by bash in the page's own scratch folder, where ``sample_reports`` is the repository's),
the lines up to the next command its expected output (standard output and error, in order).
A ``…`` in an expected line stands for any text (times, paths); a line ``...`` alone for any number of
lines. A fenced block preceded by the comment ``<!-- file: NAME -->`` is written to NAME in that folder
before the page's next command runs (the model a tutorial edits). The blocks of one page run in order,
in one folder.

Every other block that shows commands (info string ``bash``, ``sh``, ``shell``, …, or any block whose
first line starts with ``$ ``) must be preceded by the comment ``<!-- not run: REASON -->``, saying why
it cannot run here (a server, a real machine, a placeholder for the reader's own file); an unmarked one
is a failure. An inline command (`` `setupfix correct --offsets` ``, `` `history import --db` ``) is
checked against the argument parser: its sub-commands and options must exist.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted([*(p for p in DOCS.rglob("*.md") if "_build" not in p.parts), ROOT / "README.md"])

#: Info strings of blocks that show shell commands.
COMMAND_INFOS = frozenset({"bash", "sh", "shell", "zsh", "shell-session", "sh-session", "console"})

_FENCE = re.compile(r"^( *)(`{3,})(\S*)[^\n]*$")  # indented: a fence inside a list item
_FILE = re.compile(r"^<!-- file: (\S+) -->$")
_NOT_RUN = re.compile(r"^<!-- not run:(.*)-->$")
_INLINE = re.compile(r"(?<!`)`([^`\n]+)`(?!`)")


@dataclass(frozen=True)
class Block:
    """A fenced block: its first line (1-based), info string, body and the comment right before it."""

    line: int
    info: str
    body: tuple[str, ...]
    file: str | None = None  # <!-- file: NAME -->
    not_run: str | None = None  # <!-- not run: REASON -->


@dataclass(frozen=True)
class Step:
    """One thing to do on a page: write a file, or run a command and compare its output."""

    line: int
    command: str | None  # None: write `text` to `file`
    text: str
    file: str | None = None


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of one page, in page order, each with the marker comment before it."""
    out: list[Block] = []
    lines = page.read_text(encoding="utf-8").split("\n")
    i = 0
    pending_file: str | None = None
    pending_reason: str | None = None
    while i < len(lines):
        stripped = lines[i].strip()
        m = _FILE.match(stripped)
        n = _NOT_RUN.match(stripped)
        if m or n:
            pending_file = m.group(1) if m else None
            pending_reason = n.group(1).strip() if n else None
            i += 1
            continue
        fence = _FENCE.match(lines[i])
        if not fence:
            if stripped:
                pending_file = pending_reason = None
            i += 1
            continue
        indent, ticks, info = fence.group(1), fence.group(2), fence.group(3)
        j = i + 1
        while j < len(lines) and not lines[j].lstrip(" ").startswith(ticks):
            j += 1
        body = tuple(line[len(indent) :] if line.startswith(indent) else line.lstrip(" ") for line in lines[i + 1 : j])
        out.append(Block(i + 1, info, body, pending_file, pending_reason))
        pending_file = pending_reason = None
        i = j + 1
    return out


def steps(page: Path) -> list[Step]:
    """The file writes and commands of one page, in page order."""
    out: list[Step] = []
    for block in blocks(page):
        if block.file is not None:
            out.append(Step(block.line, None, "\n".join(block.body) + "\n", block.file))
        elif block.info == "console" and block.not_run is None:
            command: str | None = None
            expected: list[str] = []
            first = block.line + 1
            for k, text in enumerate(block.body):
                if text.startswith("$ "):
                    if command is not None:
                        out.append(Step(first, command, "\n".join(expected)))
                    command, expected, first = text[2:], [], block.line + 1 + k
                elif command is not None:
                    expected.append(text)
            if command is not None:
                out.append(Step(first, command, "\n".join(expected)))
    return out


def _shows_commands(block: Block) -> bool:
    first = next((line for line in block.body if line.strip()), "")
    return block.info in COMMAND_INFOS or first.startswith("$ ")


def unmarked(page: Path) -> list[str]:
    """Blocks that show commands but are neither run nor marked ``<!-- not run: REASON -->``."""
    problems = []
    for block in blocks(page):
        if block.file is not None or not _shows_commands(block):
            continue
        where = f"{_name(page)}:{block.line}"
        if block.not_run == "":
            problems.append(f"{where}: '<!-- not run: -->' without a reason")
        elif block.not_run is None and block.info != "console":
            problems.append(
                f"{where}: a ```{block.info or '(no info)'} block shows commands but is not run:"
                " make it ```console with its output, or mark it <!-- not run: REASON -->"
            )
    return problems


def inline_commands(page: Path) -> list[tuple[int, str]]:
    """The inline code spans outside fenced blocks, with their line: ``(12, "correct --offsets x.nc")``."""
    spans: list[tuple[int, str]] = []
    fenced: set[int] = set()
    for block in blocks(page):
        fenced.update(range(block.line, block.line + len(block.body) + 2))
    for number, line in enumerate(page.read_text(encoding="utf-8").split("\n"), start=1):
        if number not in fenced:
            spans.extend((number, m.group(1)) for m in _INLINE.finditer(line))
    return spans


def _parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    subs: dict[str, argparse.ArgumentParser] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            subs.update(action.choices)
    return subs


def option_errors(page: Path, parser: argparse.ArgumentParser) -> list[str]:
    """Inline commands that name a sub-command or an option the parser does not have.

    A span is a command when it starts with ``setupfix`` or with a top-level sub-command followed by an
    option (``diagnose --db``); each ``--option`` in it must belong to the (sub-)command it follows.
    """
    problems = []
    top = _parsers(parser)
    for number, span in inline_commands(page):
        try:
            words = shlex.split(span)
        except ValueError:
            words = span.split()
        if words and words[0] == "setupfix":
            words = words[1:]
        elif not (len(words) > 1 and words[0] in top and any(w.startswith("--") for w in words[1:])):
            continue
        current, path = parser, ["setupfix"]
        known = {o for a in parser._actions for o in a.option_strings}
        for word in words:
            subs = _parsers(current)
            if word in subs and not word.startswith("-"):
                current = subs[word]
                path.append(word)
                known |= {o for a in current._actions for o in a.option_strings}
            elif word.startswith("--") and len(word) > 2:
                option = word.split("=", 1)[0]
                if option not in known:
                    problems.append(f"{_name(page)}:{number}: `{span}`: {' '.join(path)} has no option {option}")
    return problems


def matches(expected: str, actual: str) -> bool:
    """Whether the output matches the expected text (``…`` any text in a line, ``...`` any lines)."""
    pattern = []
    for line in expected.rstrip("\n").split("\n") if expected.strip() else []:
        if line.strip() == "...":
            pattern.append(r"(?:[^\n]*\n)*?")
        else:
            parts = [re.escape(p) for p in line.rstrip().split("…")]
            pattern.append("[^\n]*".join(parts) + r"[ \t]*\n")
    regex = "".join(pattern)
    text = "\n".join(line.rstrip() for line in actual.rstrip("\n").split("\n")) + "\n" if actual.strip() else ""
    return re.fullmatch(regex, text) is not None


def run(command: str, cwd: Path) -> str:
    """Run one documented command in ``cwd`` with this checkout's package; its output, both streams."""
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "PYTHONUNBUFFERED": "1",
        "COLUMNS": "100",
        "SETUPFIX_DB": "",
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
    }
    env.pop("SETUPFIX_DB")
    done = subprocess.run(
        ["bash", "-c", command],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=120,
    )
    return done.stdout


def scratch(tmp: Path) -> Path:
    """A page's scratch folder: empty but for a link to the repository's sample reports."""
    tmp.mkdir(parents=True, exist_ok=True)
    link = tmp / "sample_reports"
    if not link.is_symlink():  # a folder that pages share, followed one after the other
        link.symlink_to(ROOT / "sample_reports")
    return tmp


def _name(page: Path) -> str:
    return page.relative_to(ROOT).as_posix() if page.is_relative_to(ROOT) else str(page)


def run_page(page: Path, folder: Path) -> list[str]:
    """Run one page's steps in order in a scratch folder; the failures, each with line, command, both texts."""
    cwd = scratch(folder)
    failures = []
    for step in steps(page):
        if step.command is None:
            assert step.file is not None
            (cwd / step.file).write_text(step.text, encoding="utf-8")
            continue
        actual = run(step.command, cwd)
        if not matches(step.text, actual):
            failures.append(
                f"{_name(page)}:{step.line}: $ {step.command}\n--- expected\n{step.text}\n--- got\n{actual}"
            )
    return failures


def with_examples(pages: Iterable[Path] = PAGES) -> list[Path]:
    """The pages that hold at least one command to run."""
    return [p for p in pages if any(s.command for s in steps(p))]


def run_pages(pages: Iterable[Path], base: Path, *, workers: int = 4) -> dict[Path, list[str]]:
    """Run every page once, each in its own folder under ``base``; the failures per page.

    The examples are sub-processes: threads overlap their start-up. Pages never share a folder, so
    their order between pages does not matter.
    """
    todo = list(pages)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = {page: pool.submit(run_page, page, base / f"page{i}") for i, page in enumerate(todo)}
        return {page: future.result() for page, future in futures.items()}


def static_problems(pages: Iterable[Path] = PAGES) -> list[str]:
    """What needs no run: unmarked command blocks and inline commands the parser does not know."""
    from setupfix.cli import build_parser

    parser = build_parser()
    problems: list[str] = []
    for page in pages:
        problems += unmarked(page) + option_errors(page, parser)
    return problems
