"""Which files of a folder are reports: the one folder-walk policy of every command.

``parse``, ``batch``, ``diagnose``, ``history import``, ``model init`` and the TUI's
folder watch all list a folder through :func:`list_reports`, so they see the same
reports.  The policy:

* every regular file is a report candidate, whatever its suffix: whether it *is* a
  report is for the readers to say (content sniffing), never for the listing;
* left out by policy, each with its reason in :attr:`Listing.ignored`: hidden files
  and folders (``.name``), Python's ``__pycache__``, files that are never reports (:func:`never_a_report`: a
  process model, notes, scripts, the history store, figures), partial downloads and
  editor files (:data:`PARTIAL_SUFFIXES`), and the series logs, which are returned
  apart in :attr:`Listing.logs` (``corrections.csv``, ``temperatures.csv``);
* symbolic links: a link to a regular file is followed (the report is read under the
  link's name) and said in :attr:`Listing.links`, unless its target is listed below
  the same root anyway (then it is left out, named in ``ignored``: one report is
  never read twice through a link); a link to a folder is never followed (no loops,
  no walking out of the tree) and is named in ``problems``, as is a link that loops
  or points nowhere;
* anything that cannot be listed or looked at — an unreadable sub-folder, a file
  renamed or removed while the folder was listed, a device or pipe — is named with
  its reason in :attr:`Listing.problems`, never silently dropped (a file removed
  after the listing is the reader's to name: ``batch`` makes it a failed line and
  goes on);
* every path in ``problems``, ``ignored`` and ``links`` is printable
  (:func:`parsers.names.visible_name`: a name that is not UTF-8 shows ``\\xff``); the
  paths of ``files`` and ``logs`` are the real ones, to be opened.

Nothing here reads a file's content.
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from parsers.names import visible_name
from parsers.registry import NOT_REPORT_NAMES, never_a_report
from setupfix.core.errors import Note, SourceLocation

__all__ = ["FoundFile", "Listing", "list_reports", "Inputs", "expand_inputs", "PARTIAL_SUFFIXES", "LOG_NAMES"]

#: Files a folder listing leaves out as still being written: partial downloads, editor and lock files.
PARTIAL_SUFFIXES: tuple[str, ...] = (".tmp", ".part", ".partial", ".crdownload", "~", ".swp", ".lock")

#: Folders never searched: Python's byte-code cache (a script kept beside the reports leaves one).
CACHE_FOLDERS: frozenset[str] = frozenset({"__pycache__"})

#: The logs of a series kept beside its reports, by kind (lower-case file names).
LOG_NAMES: dict[str, str] = {"corrections.csv": "corrections", "temperatures.csv": "temperatures"}
assert set(LOG_NAMES) <= set(NOT_REPORT_NAMES)


@dataclass(frozen=True, slots=True)
class FoundFile:
    """A report candidate: its path (as listed, below the root), size [bytes] and mtime [ns]."""

    path: Path
    size: int
    mtime_ns: int


@dataclass(frozen=True, slots=True)
class Listing:
    """What :func:`list_reports` found below one root.

    Attributes
    ----------
    files : tuple of FoundFile
        Report candidates in sorted path order (folders depth-first, names sorted).
    ignored : tuple of (path, reason)
        Files left out by the policy (hidden, never a report, partial).
    problems : tuple of (path, reason)
        Entries that could not be listed or looked at; say them to the user.
    logs : tuple of (kind, path)
        Series logs found (``corrections``/``temperatures``), in listing order.
    links : tuple of (path, target)
        Report candidates reached through a symbolic link (printable), said to the user.
    """

    root: Path
    files: tuple[FoundFile, ...] = ()
    ignored: tuple[tuple[str, str], ...] = ()
    problems: tuple[tuple[str, str], ...] = ()
    logs: tuple[tuple[str, str], ...] = ()
    links: tuple[tuple[str, str], ...] = ()

    def notes(self) -> list[Note]:
        """What to say about the listing: each problem (left out) and each link followed (kind ``"folder"``)."""
        return _notes(self.problems, self.links)

    def log(self, kind: str) -> str | None:
        """The first log of ``kind`` found (``"corrections"`` or ``"temperatures"``), else None."""
        return next((path for k, path in self.logs if k == kind), None)

    @property
    def paths(self) -> list[Path]:
        return [f.path for f in self.files]


def _policy(name: str) -> str | None:
    """Why a file name is left out, or None for a report candidate."""
    if name.startswith("."):
        return "hidden file"
    folded = name.lower()
    if folded in LOG_NAMES:
        return f"the series' {LOG_NAMES[folded]} log, not a report"
    if folded.endswith(PARTIAL_SUFFIXES):
        return "still being written (partial or temporary file)"
    if never_a_report(name):
        return "never a report (model, notes, script, store or figure)"
    return None


def _reason(exc: OSError) -> str:
    if isinstance(exc, FileNotFoundError):
        return "renamed or removed while the folder was listed"
    if isinstance(exc, PermissionError):
        return "permission denied"
    if exc.errno == errno.ELOOP:
        return "symbolic link loop"
    return exc.strerror or str(exc)


def _notes(problems: Sequence[tuple[str, str]], links: Sequence[tuple[str, str]]) -> list[Note]:
    return [Note(f"{reason}; left out", SourceLocation(path), "folder") for path, reason in problems] + [
        Note(f"symbolic link to {target}: read as a report", SourceLocation(path), "folder") for path, target in links
    ]


def _hidden(parts: Sequence[str]) -> bool:
    return any(p.startswith(".") or p in CACHE_FOLDERS for p in parts)


def list_reports(root: str | os.PathLike[str], *, recursive: bool = True) -> Listing:
    """List the report candidates below ``root`` under the module's policy.

    Parameters
    ----------
    root : path
        A folder (a file is not listed: callers take a file as given).
    recursive : bool
        Descend into sub-folders (hidden ones excepted).

    Returns
    -------
    Listing
        Never raises for what it finds inside ``root``; a ``root`` that cannot be
        listed is the first entry of ``problems``.
    """
    base = Path(root)
    files: list[FoundFile] = []
    ignored: list[tuple[str, str]] = []
    problems: list[tuple[str, str]] = []
    logs: list[tuple[str, str]] = []
    links: list[tuple[str, str]] = []
    try:
        real_root = base.resolve()
    except (OSError, RuntimeError):
        real_root = base

    def listed_anyway(target: Path) -> bool:
        """True if ``target`` (a link's resolved file) is listed below the root under its own name."""
        try:
            rel = target.relative_to(real_root)
        except ValueError:
            return False
        return (recursive or len(rel.parts) == 1) and not _hidden(rel.parts[:-1]) and _policy(rel.name) is None

    def visit(folder: Path) -> None:
        try:
            with os.scandir(folder) as it:
                entries = sorted(it, key=lambda e: e.name)
        except OSError as exc:
            problems.append((visible_name(str(folder)), f"cannot list folder: {_reason(exc)}"))
            return
        subfolders: list[Path] = []
        for entry in entries:
            path = folder / entry.name
            shown = visible_name(str(path))
            is_link = is_link_safe(entry)
            try:
                st = os.stat(path)  # follows a link: a linked report is read as a report
            except OSError as exc:
                problems.append((shown, _reason(exc) if not is_link or exc.errno == errno.ELOOP else "broken link"))
                continue
            if stat.S_ISDIR(st.st_mode):
                if entry.name.startswith("."):
                    ignored.append((shown, "hidden folder"))
                elif entry.name in CACHE_FOLDERS:
                    ignored.append((shown, "Python's byte-code cache, not reports"))
                elif is_link:
                    problems.append((shown, "link to a folder: not followed"))
                elif recursive:
                    subfolders.append(path)
                else:
                    ignored.append((shown, "sub-folder (not searched)"))
                continue
            if not stat.S_ISREG(st.st_mode):
                problems.append((shown, "not a regular file"))
                continue
            why = _policy(entry.name)
            if why is None and is_link:
                target = _resolved(path)
                if listed_anyway(target):
                    ignored.append((shown, f"link to {visible_name(str(target))}, which is read under its own name"))
                    continue
                links.append((shown, visible_name(str(target))))
            if why is None:
                files.append(FoundFile(path, st.st_size, st.st_mtime_ns))
            else:
                if entry.name.lower() in LOG_NAMES:
                    logs.append((LOG_NAMES[entry.name.lower()], str(path)))
                ignored.append((shown, why))
        for sub in subfolders:
            visit(sub)

    visit(base)
    return Listing(base, tuple(files), tuple(ignored), tuple(problems), tuple(logs), tuple(links))


def _resolved(path: Path) -> Path:
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return path


def is_link_safe(entry: os.DirEntry[str]) -> bool:
    """``entry.is_symlink()`` that never raises (a file may vanish between the calls)."""
    try:
        return entry.is_symlink()
    except OSError:
        return False


@dataclass(frozen=True, slots=True)
class Inputs:
    """The reports a command's inputs stand for (:func:`expand_inputs`).

    Attributes
    ----------
    files : tuple of (name, from_folder)
        Files named on the command line (and ``-``) as given, in order, each folder's
        candidates in its place (``from_folder`` True).
    problems : tuple of (path, reason)
        What a folder listing could not list or look at: say each to the user.
    ignored : tuple of (path, reason)
        Files of the folders left out by policy.
    logs : tuple of (kind, path)
        Series logs found in the folders.
    empty : tuple of str
        Folders holding no report candidate.
    links : tuple of (path, target)
        Candidates of the folders reached through a symbolic link.
    """

    files: tuple[tuple[str, bool], ...] = ()
    problems: tuple[tuple[str, str], ...] = ()
    ignored: tuple[tuple[str, str], ...] = ()
    logs: tuple[tuple[str, str], ...] = ()
    empty: tuple[str, ...] = ()
    links: tuple[tuple[str, str], ...] = ()

    @property
    def names(self) -> list[str]:
        return [name for name, _ in self.files]

    def log(self, kind: str) -> str | None:
        """The first log of ``kind`` found in a folder, else None."""
        return next((path for k, path in self.logs if k == kind), None)

    def notes(self) -> list[Note]:
        """One note per problem (kind ``"folder"``: the path, the reason, left out) and per link followed."""
        return _notes(self.problems, self.links)

    def warnings(self) -> list[str]:
        """One line per note: ``path: reason; left out`` (``path: symbolic link to …``)."""
        return [str(n) for n in self.notes()]


def expand_inputs(paths: Sequence[str | os.PathLike[str]], *, recursive: bool = True) -> Inputs:
    """Files as given, folders as :func:`list_reports` lists them (the one policy of every command).

    Parameters
    ----------
    paths : sequence of path
        Report files, folders and ``-`` (standard input).  A file is taken as given,
        whatever its name (its reader says whether it is a report); a missing file is
        taken as given too, so that the reader names it.
    recursive : bool
        Folders with their sub-folders (every command's default).
    """
    files: list[tuple[str, bool]] = []
    problems: list[tuple[str, str]] = []
    ignored: list[tuple[str, str]] = []
    logs: list[tuple[str, str]] = []
    empty: list[str] = []
    links: list[tuple[str, str]] = []
    for path in paths:
        name = os.fspath(path)
        if name != "-" and os.path.isdir(name):
            listing = list_reports(name, recursive=recursive)
            files += [(str(f.path), True) for f in listing.files]
            problems += listing.problems
            ignored += listing.ignored
            logs += listing.logs
            links += listing.links
            if not listing.files:
                empty.append(visible_name(name))
        else:
            files.append((name, False))
    return Inputs(tuple(files), tuple(problems), tuple(ignored), tuple(logs), tuple(empty), tuple(links))
