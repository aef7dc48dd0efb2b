"""The truncation property (issue 10), as a function the suite and the bench share.

A report read while the CMM is still writing it, or copied with an interruption,
is a prefix of the whole file.  Such a prefix must be refused, or every row it
yields must equal a row of the whole file — never a number cut short
(``2499.3`` → ``24.993``) or a phantom part.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from parsers.registry import read_report
from parsers.rowkeys import ROW_COLUMNS, row_keys
from parsers.source import Source
from setupfix.core.errors import SetupfixError

__all__ = ["ROW_COLUMNS", "row_keys", "cut_points", "line_cut_points", "CutOutcome", "check_prefixes"]


def cut_points(size: int, n: int = 40) -> list[int]:
    """``n`` deterministic cut lengths in ``[1, size)``, evenly spread (fewer for tiny files)."""
    if size <= 1:
        return []
    return sorted({max(1, min(size - 1, round(size * (i + 1) / (n + 1)))) for i in range(n)})


def line_cut_points(data: bytes, n: int = 40) -> list[int]:
    """Up to ``n`` cut lengths just after a line break, evenly spread: whole lines, a record cut short."""
    ends = [i + 1 for i in range(len(data) - 1) if data[i] == 0x0A]
    if len(ends) <= n:
        return ends
    return sorted({ends[round((i + 1) * (len(ends) - 1) / (n + 1))] for i in range(n)})


@dataclass(frozen=True)
class CutOutcome:
    """One prefix read: its length and what happened (``refused``, ``subset`` or ``changed``)."""

    cut: int
    verdict: str
    detail: str = ""


def check_prefixes(name: str, data: bytes, cuts: Iterable[int], **options: object) -> list[CutOutcome]:
    """Read each prefix of ``data`` (under the same ``name``) and compare its rows with the whole file's.

    Raises
    ------
    SetupfixError
        If the whole file itself cannot be read.
    """
    whole = set(row_keys(read_report(Source(name, data), **options).table))  # type: ignore[arg-type]  # reader options
    outcomes = []
    for cut in cuts:
        try:
            table = read_report(Source(name, data[:cut]), **options).table  # type: ignore[arg-type]  # reader options
        except SetupfixError:
            outcomes.append(CutOutcome(cut, "refused"))
            continue
        extra = [k for k in row_keys(table) if k not in whole]
        outcomes.append(CutOutcome(cut, "changed", repr(extra[0])[:200]) if extra else CutOutcome(cut, "subset"))
    return outcomes
