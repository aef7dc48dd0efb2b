"""Where a batch's corrections go: one offsets CSV, or one controller program per cycle.

Both writers take the report's path below the batch folder (``rel``), its offset rows and
its programs, and say at the end whether anything was written (``commit``).  The CSV is
streamed into a temporary file renamed over the target (complete or absent; an existing
output is left as it was when no report gave rows).  Programs go to
:func:`~setupfix.outputs.controllers.program_path` below the output folder, the whole set
(with a manifest, :data:`MANIFEST`, of which report each program was written for) written
into a temporary folder and moved into place at the end, or nothing; they are numbered by
:class:`ProgramNumbers` (distinct in a run).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from parsers.names import visible_name
from setupfix.core.atomic import discard_staging, publish_staged, staging_folder
from setupfix.core.errors import ExportError, SourceLocation
from setupfix.correction.offsets import OffsetRow
from setupfix.outputs.controllers import (
    DERIVED_PROGRAMS,
    PROGRAM_NUMBERS,
    check_program_number,
    derived_program_number,
    program_path,
    program_title,
    render,
)
from setupfix.outputs.writers import atomic_write, check_target, csv_header, csv_lines, write_text

__all__ = ["CsvOut", "ProgramsOut", "ProgramNumbers", "MANIFEST"]


class CsvOut:
    """One offsets CSV, streamed into a temporary file renamed over the target at the end."""

    def __init__(self, target: str | Path) -> None:
        check_target(target)
        self._cm = atomic_write(target)
        self._rows = 0

    def __enter__(self) -> CsvOut:
        self._stream = self._cm.__enter__()
        self._stream.write(csv_header())
        return self

    def add(self, rel: str, rows: Sequence[OffsetRow], programs: Sequence[tuple[str, str]]) -> None:
        """The rows of the report ``rel`` (its programs are not this writer's)."""
        self._stream.write(csv_lines(rows))
        self._rows += len(rows)

    def drop(self, rel: str) -> None:
        """Nothing to remove: the offsets CSV is written whole each run."""

    def commit(self) -> bool:
        return self._rows > 0

    def __exit__(self, *exc: Any) -> None:
        if exc[0] is None and not self._rows:
            # Nothing new: leave an existing output as it was.
            self._cm.__exit__(_NothingWritten, _NothingWritten(), None)
            return
        self._cm.__exit__(*exc)


class _NothingWritten(Exception):
    pass


class ProgramNumbers:
    """The program numbers of one batch run: distinct, in the order the programs are written (file order).

    Without a first number each program gets
    :func:`~setupfix.outputs.controllers.derived_program_number` of its path below the
    output folder, or when an earlier program of the run has it the next free number of
    :data:`~setupfix.outputs.controllers.DERIVED_PROGRAMS` (wrapping round): the same
    folder gives the same numbers run after run.  With ``first`` (``--program-number N``)
    the programs are numbered N, N+1, … in file order.  A format without a program name
    (HEIDENHAIN tables) gets None.
    """

    def __init__(self, controller: str, first: int | None = None) -> None:
        self.controller = controller
        self.first = None if first is None else check_program_number(controller, first)
        self.used: set[int] = set()

    def take(self, name: str) -> int | None:
        """The number of the program ``name`` (its path below the output folder).

        Raises
        ------
        ExportError
            The run has more programs than the format (or the derived range) has numbers.
        """
        if self.controller not in PROGRAM_NUMBERS:
            return None
        if self.first is not None:
            n = self.first + len(self.used)
            try:
                check_program_number(self.controller, n)
            except ExportError as exc:
                raise ExportError(
                    f"{exc.message}: program {len(self.used) + 1} of the run ({visible_name(name)}) "
                    f"numbered from {self.first}; give a lower --program-number (no program written)"
                ) from None
        else:
            low, high = DERIVED_PROGRAMS
            if len(self.used) > high - low:
                raise ExportError(
                    f"{self.controller}: more than {high - low + 1} programs in one run: number them "
                    "with --program-number (or split the folder)"
                )
            n = derived_program_number(name)
            while n in self.used:
                n = low if n == high else n + 1
        self.used.add(n)
        return n


class ProgramsOut:
    """One controller program per corrected cycle at :func:`~setupfix.outputs.controllers.program_path`.

    The whole set is written or nothing: every program (and the manifest) goes into a
    temporary folder on the output's file system (:func:`~setupfix.core.atomic.staging_folder`)
    and is moved into place only when the run ends without an error
    (:func:`~setupfix.core.atomic.publish_staged`); a program the format cannot hold (a number
    past the format's last, a register it cannot express), a full disk or an interruption
    leave the output folder as it was, earlier programs included.

    The folder keeps a manifest (:data:`MANIFEST`: report → the programs written for it), so
    that a report corrected again replaces exactly its own programs: one that no longer
    yields a program (rejected, refused, …) leaves none of an earlier run behind.  Only
    files the manifest names are ever removed or replaced: a file of a program's name that
    the manifest does not name (the operator's own, another tool's) is refused, naming it,
    and nothing is written.  Each program is rendered from its cycle's rows with the run's
    number (:class:`ProgramNumbers`; ``program_number`` the first) and the report's path
    below the batch folder as its title; the text a worker rendered is the proof that the
    cycle's rows are expressible, the program differs from it only in its number and title.
    """

    def __init__(
        self, folder: str | Path, controller: str, *, program_number: int | None = None, spindle: str = "Z"
    ) -> None:
        self.folder = Path(folder)
        self.controller = controller
        self.spindle = spindle
        self.numbers = ProgramNumbers(controller, program_number)
        if self.folder.is_symlink() or (self.folder.exists() and not self.folder.is_dir()):
            raise ExportError(
                "with --controller other than csv, --out is a folder for one program per cycle",
                location=SourceLocation(visible_name(str(folder))),
            )
        self.written = 0
        self.manifest = _read_manifest(self.folder / MANIFEST)
        self._ours = {n for names in self.manifest.values() for n in names}  # what earlier runs wrote
        self._owner: dict[str, tuple[str, str]] = {}  # program written in this run → (report, part)
        self._remove: list[str] = []  # programs of earlier runs to remove at the end
        self._changed = False
        self._staging: Path | None = None

    def __enter__(self) -> ProgramsOut:
        self._staging = staging_folder(self.folder)
        return self

    def add(self, rel: str, rows: Sequence[OffsetRow], programs: Sequence[tuple[str, str]]) -> None:
        """The programs (part, text) of the report ``rel``, one per cycle; replaces those of an earlier run.

        Raises
        ------
        ExportError
            A file of a program's name that no run of setupfix wrote, a program number past the
            format's last, a program that cannot be rendered or written (nothing is then published).
        """
        assert self._staging is not None, "ProgramsOut is used in a with block"
        several = len(programs) > 1
        names: list[str] = []
        for part, text in programs:
            name = program_path(rel, part if several else None, self.controller).as_posix()
            if self._owner.setdefault(name, (rel, part)) != (rel, part):  # a report named like another's program
                name = program_path(
                    rel + "~" + _short_hash(rel, part), part if several else None, self.controller
                ).as_posix()
                self._owner[name] = (rel, part)
            self._check_foreign(name)
            own = [r for r in rows if r.part == part]
            text = (
                render(
                    self.controller,
                    own,
                    program_title(rel, part),
                    program_number=self.numbers.take(name),
                    spindle=self.spindle,
                )
                if own
                else text
            )
            target = self._staging / name
            target.parent.mkdir(parents=True, exist_ok=True)
            write_text(target, text)
            names.append(name)
            self.written += 1
        self._replace(rel, names)

    def _check_foreign(self, name: str) -> None:
        """Refuse to replace a file setupfix did not write (not in the manifest)."""
        there = self.folder / name
        if name in self._ours or not (there.exists() or there.is_symlink()):
            return
        raise ExportError(
            "a file of this program's name is there, and no run of setupfix wrote it (it is not in "
            f"{MANIFEST}): nothing written",
            location=SourceLocation(visible_name(str(there))),
            hint="move it away, or give another folder with --out",
        )

    def drop(self, rel: str) -> None:
        """The report yields no program this run: remove those an earlier run wrote for it (at the end)."""
        self._replace(rel, [])

    def _replace(self, rel: str, names: list[str]) -> None:
        for old in self.manifest.get(rel, []):
            if old not in names:
                self._remove.append(old)
        if self.manifest.get(rel, []) != names:
            self._changed = True
        if names:
            self.manifest[rel] = names
        else:
            self.manifest.pop(rel, None)

    def commit(self) -> bool:
        """Whether the run writes programs (they are published when the ``with`` block ends without error)."""
        return self.written > 0

    def __exit__(self, *exc: Any) -> None:
        staging, self._staging = self._staging, None
        if staging is None:
            return
        if exc[0] is not None or (not self._changed and not self.written):
            discard_staging(staging)  # an error, an interruption, or nothing to do: the folder as it was
            return
        try:
            write_text(staging / MANIFEST, json.dumps(self.manifest, indent=1, sort_keys=True) + "\n")
            publish_staged(staging, self.folder, [*self._owner, MANIFEST])
        except BaseException:
            discard_staging(staging)
            raise
        for old in self._remove:
            if old not in self._owner:  # never a program this run wrote (for this or another report)
                _remove_inside(self.folder, old)


#: The programs folder's record of which report each program was written for (hidden, JSON).
MANIFEST = ".setupfix-programs.json"


def _short_hash(*texts: str) -> str:
    return hashlib.sha256(os.fsencode("\0".join(texts))).hexdigest()[:10]


def _read_manifest(path: Path) -> dict[str, list[str]]:
    """The manifest of a programs folder; an absent or damaged one is empty (nothing is then removed)."""
    try:
        found = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    if not isinstance(found, dict):
        return {}
    return {str(k): [str(n) for n in v] for k, v in found.items() if isinstance(v, list)}


def _remove_inside(folder: Path, name: str) -> None:
    """Remove the program ``name`` of an earlier run: a regular file inside ``folder`` only (never a link)."""
    target = folder / name
    try:
        inside = target.parent.resolve().is_relative_to(folder.resolve()) and ".." not in Path(name).parts
        if inside and target.is_file() and not target.is_symlink():
            target.unlink()
    except OSError:
        pass  # gone already, or not ours to remove
