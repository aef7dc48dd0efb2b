"""Unwrapping the plain RTF that OGP measuring software saves as ``.txt``.

``OGP_L0_axial_top_module1_1.rtf.txt`` is a WordPad (Msftedit 5.41) document: a
font and colour table, ``\\viewkind4\\uc1…`` before the first text, ``\\\\`` for a
backslash, the report lines themselves on their own lines, a closing ``}`` and a NUL.
The lines are unwrapped one by one so that line numbers stay those of the file.
"""

from __future__ import annotations

import re

__all__ = ["is_rtf", "rtf_lines"]

_DESTINATION = re.compile(r"\{\\(?:\*|fonttbl|colortbl|stylesheet|info)[^{}]*(?:\{[^{}]*\}[^{}]*)*\}")
_CONTROL = re.compile(r"\\(?:'([0-9a-fA-F]{2})|([a-zA-Z]+)(-?\d+)? ?|([\\{}]))")


def is_rtf(text: str) -> bool:
    """True if ``text`` is an RTF document."""
    return text.lstrip("\ufeff \r\n").startswith("{\\rtf")


def _control(match: re.Match[str]) -> str:
    hexbyte, word, _arg, escaped = match.groups()
    if hexbyte:
        return bytes([int(hexbyte, 16)]).decode("cp1252", errors="replace")
    if escaped:
        return escaped
    return {"par": "", "line": "", "tab": "\t"}.get(word or "", "")


def rtf_lines(text: str) -> list[str]:
    """The plain text of each line of an RTF document (same number of lines).

    Destination groups (font table, colour table, ``{\\*…}``) are removed where they
    open and close on one line; control words are dropped, escaped ``\\\\ \\{ \\}``
    and ``\\'hh`` kept as characters, and bare braces and NULs removed.
    """
    out = []
    for line in text.split("\n"):
        line = _DESTINATION.sub("", line.rstrip("\r").replace("\x00", ""))
        line = line.replace("{\\rtf1", "")
        pieces = []
        pos = 0
        for match in _CONTROL.finditer(line):
            pieces.append(re.sub(r"[{}]", "", line[pos : match.start()]))
            pieces.append(_control(match))
            pos = match.end()
        pieces.append(re.sub(r"[{}]", "", line[pos:]))
        out.append("".join(pieces))
    return out
