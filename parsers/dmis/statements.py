"""DMIS output text → logical statements (continuations joined, line numbers kept).

Why hand-written: DMIS has no maintained Python reader; the statement grammar needed
here (``LABEL(name)=MAJOR/arg,arg,…``) is small, and the continuation rules must be
exactly those of the real files in ``../shared/cmm-samples/dmis_dmo``:

* a line ending in ``$`` continues on the next line, which may split a label or a
  number (``T(Es$`` / ``fera_10_DIAM)``, ``-0.$`` / ``0019``);
* a line ending in ``$$`` continues on the next, indented line (the indentation is
  layout, not content: ``FA(Cono_9)=FEAT/CONE,CART,$$`` / ``   74.9658,…``);
* a line starting with ``,`` continues the previous statement although that one did
  not end in ``$`` (``,T(Rectángulo_12_WID)`` in ``DMO_Example1_PiezaDemo.dmo``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["Statement", "split_statements", "parse_statement"]

#: ``F(label)=…``, ``TA(label)=…``: the label part of an assignment.
_ASSIGN = re.compile(r"^\s*([A-Z]{1,3})\((.*?)\)\s*=\s*(.*)$", re.DOTALL)


@dataclass(frozen=True)
class Statement:
    """One logical DMIS statement.

    Attributes
    ----------
    line : int
        1-based line on which the statement starts.
    kind : str
        Label type of an assignment (``F``, ``FA``, ``T``, ``TA``), else the major word
        (``UNITS``, ``OUTPUT``, ``ENDFIL``, ``DATE``…).
    label : str
        The label in parentheses, "" for non-assignments.
    words : tuple of str
        Comma-separated arguments after ``MAJOR/`` (``("CORTOL", "XAXIS", "-0.05", "0.05")``
        for ``TOL/CORTOL,…``); the major word itself is ``major``.
    major : str
        ``FEAT``, ``TOL``, … for assignments; the statement word otherwise.
    """

    line: int
    kind: str
    label: str
    major: str
    words: tuple[str, ...]
    text: str = ""


def split_statements(text: str) -> list[tuple[int, str]]:
    """Join continuation lines; return (first line number, statement text) pairs."""
    out: list[tuple[int, str]] = []
    pending: list[str] = []
    start = 0
    strip_next = False
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.rstrip("\r\n")
        if pending:
            piece = line.lstrip() if strip_next else line
        elif line.lstrip().startswith(",") and out:
            start, prev = out.pop()
            pending, piece = [prev], line.lstrip()
        elif line.lstrip().startswith("$$"):
            continue  # a DMIS comment line
        else:
            start, piece = number, line.strip()
        stripped = piece.rstrip()
        if stripped.endswith("$$"):
            pending.append(stripped[:-2])
            strip_next = True
            continue
        if stripped.endswith("$"):
            pending.append(stripped[:-1])
            strip_next = False
            continue
        pending.append(piece)
        statement = "".join(pending).strip()
        pending, strip_next = [], False
        if statement:
            out.append((start, statement))
    if pending:
        out.append((start, "".join(pending).strip()))
    return out


def parse_statement(line: int, text: str) -> Statement:
    """Split one statement into label, major word and arguments (never raises)."""
    match = _ASSIGN.match(text)
    if match:
        kind, label, rest = match.group(1).upper(), match.group(2).strip(), match.group(3)
    else:
        kind, label, rest = "", "", text
    major, _, args = rest.partition("/")
    major = major.strip().upper()
    words = tuple(w.strip() for w in args.split(",")) if args else ()
    if not kind:
        kind = major.split("=")[0].strip()
    return Statement(line=line, kind=kind, label=label, major=major, words=words, text=text)
