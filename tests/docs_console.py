"""The console examples of the documentation, read from the Markdown and run.

An example is a fenced block whose info string is ``console``: each line starting with ``$ `` is a
command (run by bash in the page's own scratch folder, where ``sample_reports`` is the repository's),
the lines up to the next command its expected output (standard output and error, in order).
A ``…`` in an expected line stands for any text (times, paths); a line ``...`` alone for any number of
lines. A fenced block preceded by the comment ``<!-- file: NAME -->`` is written to NAME in that folder
before the page's next command runs (the model a tutorial edits). The blocks of one page run in order,
in one folder.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted([*(p for p in DOCS.rglob("*.md") if "_build" not in p.parts), ROOT / "README.md"])

_FENCE = re.compile(r"^(`{3,})(\S*)[^\n]*$")
_FILE = re.compile(r"^<!-- file: (\S+) -->$")


@dataclass(frozen=True)
class Step:
    """One thing to do on a page: write a file, or run a command and compare its output."""

    line: int
    command: str | None  # None: write `text` to `file`
    text: str
    file: str | None = None


def steps(page: Path) -> list[Step]:
    """The file writes and commands of one page, in page order."""
    out: list[Step] = []
    lines = page.read_text(encoding="utf-8").split("\n")
    i = 0
    pending_file: str | None = None
    while i < len(lines):
        m = _FILE.match(lines[i].strip())
        if m:
            pending_file = m.group(1)
            i += 1
            continue
        fence = _FENCE.match(lines[i])
        if not fence:
            if lines[i].strip():
                pending_file = None
            i += 1
            continue
        ticks, info = fence.group(1), fence.group(2)
        start = i
        j = i + 1
        while j < len(lines) and not lines[j].startswith(ticks):
            j += 1
        body = lines[i + 1 : j]
        if pending_file is not None:
            out.append(Step(start + 1, None, "\n".join(body) + "\n", pending_file))
        elif info == "console":
            command: str | None = None
            expected: list[str] = []
            first = start + 2
            for k, text in enumerate(body):
                if text.startswith("$ "):
                    if command is not None:
                        out.append(Step(first, command, "\n".join(expected)))
                    command, expected, first = text[2:], [], start + 2 + k
                elif command is not None:
                    expected.append(text)
            if command is not None:
                out.append(Step(first, command, "\n".join(expected)))
        pending_file = None
        i = j + 1
    return out


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
    (tmp / "sample_reports").symlink_to(ROOT / "sample_reports")
    return tmp
