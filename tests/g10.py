"""The project's own G10 interpreter for the tests: runs the G10 blocks of a Fanuc/Haas program on a state.

It exists because LinuxCNC's ``rs274`` (:mod:`rs274`) reads ``G10 L20`` and ``G10 L10``–``L13``
differently from Fanuc and Haas (L20 sets an offset so that the *current position* reads
the value; L10/L11 write its tool table from the current position; L12/L13 are errors) and
ignores ``G91`` on ``G10 L2`` (it always sets): those blocks, and every incremental program,
are checked here.  Semantics (Fanuc/Haas, memory C): ``G90 G10 Ln Pp W±v …`` sets the
register (L, p) word W to v, ``G91`` adds v to it; one block may carry several axis words.
An incremental program's guard (custom macro B) runs too: ``#n=v`` sets the common variable n
(state key ``(0, n, "#")``), ``IF [#n EQ v] THEN #3000=k (TEXT)`` raises :class:`Alarm` when it
holds v, before any later block runs.
"""

from __future__ import annotations

import re

__all__ = ["run_g10", "Key", "Alarm"]

#: (L, P, word): ``(2, 1, "X")`` is G54 X; ``(11, 5, "R")`` the H5 wear.
Key = tuple[int, int, str]

_BLOCK = re.compile(r"^(G9[01]) G10 L(\d+) P(\d+)((?: [XYZABCR][-+]?\d+\.\d*)+)(?: \(.*\))?$")
_WORD = re.compile(r" ([XYZABCR])([-+]?\d+\.\d*)")
_SET = re.compile(r"^#(\d+)=(\d+)$")
_GUARD = re.compile(r"^IF \[#(\d+) EQ (\d+)\] THEN #3000=(\d+) \((.*)\)$")


class Alarm(Exception):
    """A program stopped with a macro alarm (``#3000``): nothing after it ran."""


def run_g10(program: str, state: dict[Key, float] | None = None) -> dict[Key, float]:
    """The register state after running ``program``'s G10 blocks on ``state``.

    Raises
    ------
    AssertionError
        A line that starts with ``G9`` and is not a well-formed G10 block (every word with a
        decimal point), or a line that is neither a block, a comment, ``%``, ``O…``, ``G20``/``G21``,
        ``G90``, ``M30`` nor a guard line.
    Alarm
        The guard found its plan number already set (a second run).
    """
    out = dict(state or {})
    for line in program.splitlines():
        if line in ("%", "G20", "G21", "G90", "M30") or line.startswith("(") or re.match(r"^O\d+( \(.*\))?$", line):
            continue
        guard, assign = _GUARD.match(line), _SET.match(line)
        if guard:
            if out.get((0, int(guard.group(1)), "#")) == float(guard.group(2)):
                raise Alarm(f"{guard.group(3)} {guard.group(4)}")
            continue
        if assign:
            out[(0, int(assign.group(1)), "#")] = float(assign.group(2))
            continue
        m = _BLOCK.match(line)
        assert m, f"not a G10 block: {line!r}"
        absolute, lcode, p = m.group(1) == "G90", int(m.group(2)), int(m.group(3))
        for word, value in _WORD.findall(m.group(4)):
            key = (lcode, p, word)
            out[key] = float(value) if absolute else out.get(key, 0.0) + float(value)
    return out
