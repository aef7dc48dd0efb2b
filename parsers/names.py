"""Names made safe to show: the one escaping of file names and user text for every output.

A file name read from the file system is ``os.fsdecode``'d: bytes that are not UTF-8
become lone surrogates (surrogateescape), which no UTF-8 output (a CSV, JSON, the
history store, a terminal in strict mode) can hold.  :func:`visible_name` turns such
text into printable text with visible escapes; :func:`parsers.load_source` names every
report by it, so the name a report carries in its table, its notes and its errors, in
the offsets CSV, a program's comment, the JSON and the store is the same printable text,
while the file itself is opened by its real path.
"""

from __future__ import annotations

__all__ = ["visible_name"]

_NAMED_ESCAPES = {"\t": "\\t", "\n": "\\n", "\r": "\\r", "\\": "\\\\"}


def visible_name(text: str) -> str:
    """``text`` (a file name or any user text) safe to print, store or write in any output.

    A name read from the file system with bytes that are not UTF-8 holds lone
    surrogates (``os.fsdecode``'s surrogateescape): each becomes a visible ``\\xff``
    escape of its byte; control characters become ``\\t``, ``\\n``, ``\\r`` or
    ``\\x07``; other lone surrogates ``\\udXXX``.  A backslash is kept as it is unless
    the name needs an escape (then it is doubled, so the escaped text is unambiguous).
    Printable UTF-8 text is returned unchanged.  Never raises.
    """
    if text.isprintable():
        return text
    out = []
    for c in text:
        code = ord(c)
        if 0xDC80 <= code <= 0xDCFF:
            out.append(f"\\x{code - 0xDC00:02x}")
        elif c in _NAMED_ESCAPES:
            out.append(_NAMED_ESCAPES[c])
        elif 0xD800 <= code <= 0xDFFF:
            out.append(f"\\u{code:04x}")
        elif c.isprintable() or c == " ":
            out.append(c)
        elif code < 0x100:
            out.append(f"\\x{code:02x}")
        else:
            out.append(f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}")
    return "".join(out)
