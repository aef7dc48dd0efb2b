"""Atomic file output: a result file is either complete or not there at all.

Every writer in setupfix goes through :func:`atomic_write`: the content goes to a
temporary file in the target's folder, is flushed to disk, then renamed over the
target (``os.replace`` is atomic on POSIX and Windows within one file system).
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from setupfix.errors import ExportError, SourceLocation

__all__ = ["atomic_write"]


@contextlib.contextmanager
def atomic_write(target: str | os.PathLike[str], *, newline: str | None = "",
                 binary: bool = False) -> Iterator[IO[Any]]:
    """Open a stream whose content replaces ``target`` only on success.

    ``target == "-"`` writes to standard output instead.  ``binary=True`` gives a
    bytes stream (figures).  The file gets the permissions a plain ``open`` would
    give it (0666 less the umask), not the private 0600 of a temporary file.

    Raises
    ------
    ExportError
        If the folder does not exist or cannot be written.
    """
    if str(target) == "-":
        stream = sys.stdout.buffer if binary else sys.stdout
        yield stream
        stream.flush()
        return
    path = Path(target)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise ExportError(f"cannot write here: {exc.strerror}", location=SourceLocation(str(path))) from None
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        handle = os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline=newline)
        with handle as stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
