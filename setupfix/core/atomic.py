"""Atomic file output: a result file is either complete or not there at all.

Every writer in setupfix goes through :func:`atomic_write` (or :func:`write_text` /
:func:`write_bytes`): the target is checked first (:func:`check_target`: ``-`` for
standard output or a regular file, new or existing, nothing else), the content goes
to a temporary file ``.NAME.PID.RANDOM.tmp`` in the target's folder, is flushed to
disk, then renamed over the target (``os.replace`` is atomic on POSIX and Windows
within one file system).

Thread safety: the temporary file is created with ``os.open(..., 0o666)`` so the
kernel applies the umask itself; the process umask is never read or changed (the
former ``os.umask`` toggle raced with other threads creating files).  A process
killed mid-write leaves its temporary file behind; the next write to the same
target removes those whose process is gone.

A set of files (``batch --controller``'s programs) is written whole or not at all:
:func:`staging_folder` gives a temporary folder on the target's file system, the
caller writes every file there, and :func:`publish_staged` moves them into place
only when all are written (checking every destination first); on any failure
:func:`discard_staging` removes the temporary folder and the target is as it was.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
import stat
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from setupfix.core.errors import ExportError, SourceLocation

__all__ = [
    "atomic_write",
    "check_target",
    "write_text",
    "write_bytes",
    "process_started",
    "process_alive",
    "staging_folder",
    "publish_staged",
    "discard_staging",
    "STAGING_PREFIX",
]

#: Temporary files of writes whose process is unknown (other host, older setupfix)
#: older than this are stale (seconds).
STALE_AGE_S = 3600.0

_KINDS = (
    (stat.S_ISLNK, "a symbolic link", "write to the file it points to, or '-' for standard output"),
    (stat.S_ISDIR, "a folder", "give a file name inside it"),
    (stat.S_ISCHR, "a character device", "use '-' for standard output"),
    (stat.S_ISBLK, "a block device", None),
    (stat.S_ISFIFO, "a named pipe (FIFO)", "use '-' and a shell pipe"),
    (stat.S_ISSOCK, "a socket", None),
)


def check_target(target: str | os.PathLike[str]) -> Path | None:
    """Check that ``target`` may be written: ``-`` (standard output) or a regular file.

    A new file in an existing folder or an existing regular file is accepted.  A
    directory, character or block device, FIFO, socket or symbolic link (even one
    pointing to a regular file: ``os.replace`` would replace the link) is refused.

    Returns
    -------
    Path or None
        The target path; ``None`` for standard output.

    Raises
    ------
    ExportError
        Naming the target and what it is.
    """
    if str(target) == "-":
        return None
    path = Path(target)
    where = SourceLocation(str(path))
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise ExportError(f"cannot write here: folder {str(folder)!r} does not exist", location=where) from None
        return path
    except OSError as exc:
        raise ExportError(f"cannot write here: {exc.strerror}", location=where) from None
    for test, kind, hint in _KINDS:
        if test(mode):
            raise ExportError(f"refusing to write: the target is {kind}, not a regular file", location=where, hint=hint)
    return path


def process_started(pid: int) -> str:
    """A mark of when process ``pid`` started ("" when unknown or gone): with the pid, it names one process.

    On Linux the start time in clock ticks since boot (``/proc/PID/stat`` field 22), so a
    pid the system has given to a new process is told apart from the old one; elsewhere "".
    """
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat_line = f.read().decode("ascii", "replace")
    except OSError:
        return ""
    fields = stat_line[stat_line.rfind(")") + 2 :].split()  # after the command name, which may hold spaces
    if len(fields) < 20 or fields[0] == "Z":  # a zombie has ended
        return ""
    return fields[19]


def process_alive(pid: int, started: str = "") -> bool:
    """Whether process ``pid`` runs (and, when ``started`` is given and the system says, is that very process).

    Conservative: True when it cannot be told (another user's process, not POSIX).
    """
    if pid == os.getpid():
        return True
    if os.name != "posix":  # os.kill(pid, 0) would send CTRL_C_EVENT on Windows
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by another user
        pass
    if started and os.path.isdir("/proc/self"):
        return process_started(pid) == started
    return True


def _remove_stale(path: Path) -> None:
    """Remove temporary files of earlier writes to ``path`` whose writer is gone.

    ``.NAME.PID.RANDOM.tmp`` whose PID is not running; any other ``.NAME.*.tmp``
    (an older setupfix, another host) older than :data:`STALE_AGE_S`.  Live writes
    of this or another running process are left alone.
    """
    folder = path.parent if str(path.parent) else Path(".")
    prefix = f".{path.name}."
    ours = re.compile(re.escape(prefix) + r"(\d+)\.[0-9a-f]+\.tmp\Z")
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    now = time.time()
    for entry in entries:
        if not (entry.name.startswith(prefix) and entry.name.endswith(".tmp")):
            continue
        with contextlib.suppress(OSError):
            info = entry.stat(follow_symlinks=False)
            if not stat.S_ISREG(info.st_mode):
                continue
            match = ours.match(entry.name)
            stale = not process_alive(int(match.group(1))) if match else now - info.st_mtime > STALE_AGE_S
            if stale:
                os.unlink(entry.path)


def _create_temp(path: Path) -> tuple[int, Path]:
    folder = path.parent if str(path.parent) else Path(".")
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0) | getattr(os, "O_NOFOLLOW", 0)
    for _ in range(100):
        tmp = folder / f".{path.name}.{os.getpid()}.{secrets.token_hex(6)}.tmp"
        try:
            return os.open(tmp, flags, 0o666), tmp  # the kernel applies the umask
        except FileExistsError:
            continue
        except OSError as exc:
            raise ExportError(f"cannot write here: {exc.strerror}", location=SourceLocation(str(path))) from None
    raise ExportError("cannot create a temporary file", location=SourceLocation(str(path)))


@contextlib.contextmanager
def atomic_write(
    target: str | os.PathLike[str], *, newline: str | None = "", binary: bool = False
) -> Iterator[IO[Any]]:
    """Open a stream whose content replaces ``target`` only on success.

    ``target == "-"`` writes to standard output instead.  ``binary=True`` gives a
    bytes stream (figures).  A new file gets the permissions a plain ``open`` would
    give it (0666 less the umask); an existing file keeps its permission bits.

    Raises
    ------
    ExportError
        If the target is not a regular file (:func:`check_target`), the folder
        does not exist or cannot be written, or the content cannot be written (a full
        disk, a file size limit: named with the target; the old content stays and no
        temporary file is left).
    """
    path = check_target(target)
    if path is None:
        stream = sys.stdout.buffer if binary else sys.stdout
        yield stream
        stream.flush()
        return
    _remove_stale(path)
    fd, tmp = _create_temp(path)
    in_body = False
    try:
        with contextlib.suppress(OSError):
            old = os.stat(path)
            if stat.S_ISREG(old.st_mode):
                os.chmod(fd if os.chmod in os.supports_fd else tmp, stat.S_IMODE(old.st_mode))
        handle = os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline=newline)
        with handle as stream:
            in_body = True
            yield stream
            in_body = False
            stream.flush()
            os.fsync(stream.fileno())
        check_target(path)  # still a regular file (or absent) just before the rename
        os.replace(tmp, path)
    except ExportError:
        _discard(tmp)
        raise
    except OSError as exc:
        _discard(tmp)
        if in_body and exc.errno not in _WRITE_FAILURES:
            raise  # the caller's own error (e.g. reading another file), not this write's
        raise ExportError(
            f"cannot write: {exc.strerror or exc}; nothing written",
            location=SourceLocation(str(path)),
            hint=_WRITE_HINTS.get(exc.errno or 0),
        ) from None
    except BaseException:
        _discard(tmp)
        raise


#: errno values that only a write gives (a full disk, a file size limit, a quota, a read-only file system):
#: raised while the caller writes the stream, they are this write's failure and named with its target.
_WRITE_FAILURES = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS})
_WRITE_HINTS = {
    errno.ENOSPC: "the disk is full: free space and run again",
    errno.EFBIG: "the file is larger than this process may write (ulimit -f) or the file system holds",
    errno.EDQUOT: "the disk quota is used up",
    errno.EROFS: "the file system is mounted read-only",
}


def _discard(tmp: Path) -> None:
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def write_text(target: str | os.PathLike[str], text: str, *, newline: str | None = "") -> None:
    """Write ``text`` (UTF-8) atomically to ``target`` (``-``: standard output)."""
    with atomic_write(target, newline=newline) as stream:
        stream.write(text)


def write_bytes(target: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` atomically to ``target`` (``-``: standard output)."""
    with atomic_write(target, binary=True) as stream:
        stream.write(data)


#: Name prefix of a staging folder inside an existing target folder (``.setupfix-staging.PID.RANDOM.tmp``).
STAGING_PREFIX = ".setupfix-staging"


def _stale_staging(parent: Path, prefix: str) -> None:
    """Remove staging folders ``PREFIX.PID.RANDOM.tmp`` in ``parent`` whose process is gone."""
    pattern = re.compile(re.escape(prefix) + r"\.(\d+)\.[0-9a-f]+\.tmp\Z")
    try:
        entries = list(os.scandir(parent))
    except OSError:
        return
    for entry in entries:
        match = pattern.match(entry.name)
        if match and entry.is_dir(follow_symlinks=False) and not process_alive(int(match.group(1))):
            shutil.rmtree(entry.path, ignore_errors=True)


def staging_folder(target: str | os.PathLike[str]) -> Path:
    """A new, empty temporary folder on the file system of the folder ``target``, for a set of files
    :func:`publish_staged` moves there at the end.

    Inside ``target`` when it is a folder already (hidden: :data:`STAGING_PREFIX`), else beside the
    nearest folder that exists on its path (so that nothing of ``target`` exists before the set is
    complete).  Staging folders of processes that are gone are removed first.

    Raises
    ------
    ExportError
        ``target`` exists and is not a folder, or the temporary folder cannot be created.
    """
    folder = Path(target)
    where = SourceLocation(str(folder))
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        raise ExportError("refusing to write: the target is not a folder", location=where)
    if folder.is_dir():
        parent, prefix = folder, STAGING_PREFIX
    else:
        parent = folder.parent
        while not parent.is_dir() and parent != parent.parent:
            parent = parent.parent
        prefix = f".{folder.name}"
    _stale_staging(parent, prefix)
    for _ in range(100):
        staging = parent / f"{prefix}.{os.getpid()}.{secrets.token_hex(6)}.tmp"
        try:
            staging.mkdir()
            return staging
        except FileExistsError:
            continue
        except OSError as exc:
            raise ExportError(f"cannot write here: {exc.strerror}", location=where) from None
    raise ExportError("cannot create a temporary folder", location=where)


def publish_staged(staging: Path, target: str | os.PathLike[str], names: list[str]) -> None:
    """Move the files ``names`` (``/``-separated paths below ``staging``) into the folder ``target``.

    A ``target`` that does not exist yet becomes the staging folder itself (one rename: the set
    appears whole).  Otherwise every destination is checked first (absent or a regular file, each
    folder on its way a folder: :func:`check_target`), and only then are the files renamed over
    them, so a destination that cannot take its file leaves every destination as it was.  The
    staging folder is removed at the end.

    Raises
    ------
    ExportError
        Naming the destination that cannot be written; the staging folder is left for the
        caller's :func:`discard_staging`.
    """
    folder = Path(target)
    try:
        if not folder.exists() and not folder.is_symlink():
            folder.parent.mkdir(parents=True, exist_ok=True)
            os.rename(staging, folder)
            return
        for name in names:
            destination = folder / name
            for up in reversed(Path(name).parents[:-1]):  # the folders below target on the way
                inner = folder / up
                if inner.is_symlink() or (inner.exists() and not inner.is_dir()):
                    raise ExportError(
                        "refusing to write: the path holds something that is not a folder",
                        location=SourceLocation(str(inner)),
                    )
            if destination.parent.is_dir():
                check_target(destination)
        for name in names:
            destination = folder / name
            destination.parent.mkdir(parents=True, exist_ok=True)
            os.replace(staging / name, destination)
    except OSError as exc:
        raise ExportError(
            f"cannot write: {exc.strerror or exc}",
            location=SourceLocation(str(folder)),
            hint=_WRITE_HINTS.get(exc.errno or 0),
        ) from None
    discard_staging(staging)


def discard_staging(staging: Path) -> None:
    """Remove a staging folder and everything in it (never following a link out of it)."""
    shutil.rmtree(staging, ignore_errors=True)
