"""Which history store a command uses, and for whom: a file or a server URL, its machine and operator.

Every command that takes ``--store``/``--db`` builds one :class:`StoreRef` from its options
and the model, and opens the store through it, so the rules are the same on every door:

* the location is ``--db``/``--store`` as given (a file path: the embedded SQLite store; anything
  that looks like a URL: the plant database, read as a URL or refused, never taken for a file);
  where a command needs a store and none is given, ``$SETUPFIX_DB``, else ``setupfix.db``
  beside the model (:func:`store_location`);
* the machine is ``--machine``, else the model's ``[process] machine``, else
  :data:`setupfix.store.DEFAULT_MACHINE`; the operator is ``--operator``, else the login name;
* a command that reads history opens an existing store only: a missing file is an error naming
  it, never a new empty store (a server database is created by ``history import``/``migrate``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from setupfix.core.errors import SourceLocation, StoreError
from setupfix.model import ProcessModel
from setupfix.store import DB_ENV, Store, is_server, open_store, shown_location

__all__ = ["DEFAULT_DB", "StoreRef", "store_location"]

DEFAULT_DB = "setupfix.db"


def store_location(db: str | None, model: str | None = None) -> str:
    """Where the store is: ``--db`` if given, else ``$SETUPFIX_DB``, else ``setupfix.db`` beside the model, else
    in the current folder.  A ``postgresql://`` URL is a server store (:func:`setupfix.store.open_store`)."""
    if db:
        return db
    if os.environ.get(DB_ENV):
        return os.environ[DB_ENV]
    return str((Path(model).parent if model else Path(".")) / DEFAULT_DB)


@dataclass(frozen=True)
class StoreRef:
    """A history store and the machine and operator its records belong to.

    Attributes
    ----------
    location : str
        A file (SQLite) or a ``postgresql://`` URL.
    machine, operator : str, optional
        ``--machine``/``--operator``; ``None``: the model's ``[process] machine`` (see :meth:`for_model`),
        else the store's defaults (``default``, the login name).
    """

    location: str
    machine: str | None = None
    operator: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "location", os.fspath(self.location))  # a path object is kept as its text

    @classmethod
    def of(cls, location: str | os.PathLike[str] | StoreRef) -> StoreRef:
        """``location`` as a reference (a reference is returned as it is)."""
        return location if isinstance(location, StoreRef) else cls(str(location))

    def for_model(self, model: ProcessModel) -> StoreRef:
        """This reference with the model's ``[process] machine`` where no machine was given."""
        if self.machine is not None or model.machine is None:
            return self
        return StoreRef(self.location, model.machine, self.operator)

    @property
    def exists(self) -> bool:
        """Whether the store is there to read: a file that exists (a server database is checked on connecting)."""
        return is_server(self.location) or Path(self.location).is_file()

    def __str__(self) -> str:
        """The location as messages may print it (a URL without its password)."""
        return shown_location(self.location)

    def open(self, *, existing: bool = True) -> Store:
        """Open the store for this machine and operator.

        Raises
        ------
        StoreError
            ``existing`` and the file does not exist (a server database is checked on connecting), or the
            store cannot be opened.
        """
        if existing and not self.exists:
            raise StoreError(
                "no history store here (import reports with 'setupfix history import')",
                location=SourceLocation(self.location),
            )
        return open_store(self.location, machine=self.machine, operator=self.operator)
