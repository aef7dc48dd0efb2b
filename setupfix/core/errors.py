"""One error hierarchy for setupfix, every leaf carrying where the problem is.

Library code raises these; only :mod:`setupfix.cli` (and later the TUI) turns them
into a one-line message and an exit status.  The message form follows pandas'
``path:line: what is wrong`` so an operator can open the file at the place named.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "SourceLocation",
    "SetupfixError",
    "ModelError",
    "ParseError",
    "UnknownFormatError",
    "MatchError",
    "SolverError",
    "NotFittedError",
    "ExportError",
    "StoreError",
    "ParameterError",
    "Note",
    "ParseWarning",
    "ConvergenceWarning",
]


@dataclass(frozen=True, slots=True)
class SourceLocation:
    """Where something was read from.

    Parameters
    ----------
    path : str
        File name as given by the user.
    line : int, optional
        1-based line number in a text file.
    key : str, optional
        Dotted key path in a TOML/JSON document (``dimensions.D4.features.F9``).
    element : str, optional
        XML element id or tag, spreadsheet cell, …
    """

    path: str
    line: int | None = None
    key: str | None = None
    element: str | None = None

    def __str__(self) -> str:
        text = _printable(self.path)
        if self.line is not None:
            text += f":{self.line}"
        if self.key:
            text += f": [{_printable(self.key)}]"
        if self.element:
            text += f": <{_printable(self.element)}>"
        return text


def _printable(text: str) -> str:
    """``text`` with control characters (terminal escape sequences) shown as ``?``."""
    return text if text.isprintable() else "".join(c if c.isprintable() else "?" for c in text)


class SetupfixError(Exception):
    """Root of every error setupfix raises on purpose.

    Parameters
    ----------
    message : str
        What is wrong, one line, without the location.
    location : SourceLocation, optional
        Where it is wrong.
    hint : str, optional
        A likely cause or fix, shown after the message.
    """

    def __init__(
        self,
        message: str,
        *,
        location: SourceLocation | None = None,
        hint: str | None = None,
    ) -> None:
        self.message = message
        self.location = location
        self.hint = hint
        super().__init__(str(self))

    def __str__(self) -> str:
        text = f"{self.location}: {self.message}" if self.location else self.message
        if self.hint:
            text += f" ({self.hint})"
        return text


class ModelError(SetupfixError, ValueError):
    """The process model file is invalid (unknown ID, bad limits, …)."""

    #: Every problem of a file reported in one pass (the message lists them, one a line).
    problems: tuple[ModelError, ...] = ()


class ParseError(SetupfixError, ValueError):
    """A measurement report or data table cannot be read."""


class UnknownFormatError(ParseError):
    """No reader accepts a file."""


class MatchError(SetupfixError, ValueError):
    """Measurements cannot be tied to the process model (no dimension matched, …)."""


class SolverError(SetupfixError, RuntimeError):
    """An optimiser failed in a way no fallback could mend."""


class NotFittedError(SolverError, AttributeError):
    """A model's ``predict`` was called before ``fit`` (sklearn's convention)."""


class ExportError(SetupfixError, OSError):
    """A result file cannot be written."""


class StoreError(SetupfixError):
    """The history store cannot be opened, migrated or written, or an import contradicts it."""


class ParameterError(SetupfixError, ValueError):
    """A hyper-parameter, option or setting is outside its allowed range or set.

    The message names the owner (optimiser, thermal method, command), the parameter,
    the value given and what is allowed, e.g.
    ``PSO: n_particles must be an int in [1, 100000], got -5``.
    """


@dataclass(frozen=True, slots=True)
class Note:
    """A warning returned as data (never through the process-global ``warnings`` state).

    Readers and use cases return their notes with their result, so that work run in
    threads (the TUI, batch workers) keeps its notes apart.

    Parameters
    ----------
    message : str
        What was skipped, assumed or suspicious, one line, without the location.
    location : SourceLocation, optional
        Where (file, line, key, element).
    kind : str
        A short machine-readable category: ``"parse"``, ``"unit"``, ``"match"``,
        ``"mismatch"``, ``"solver"``, ``"thermal"``, ``"safety"``, …
    """

    message: str
    location: SourceLocation | None = None
    kind: str = "warning"

    def __str__(self) -> str:
        return f"{self.location}: {self.message}" if self.location else self.message


class ParseWarning(UserWarning):
    """Something in a report was skipped or assumed; the row or file is named."""


class ConvergenceWarning(UserWarning):
    """An optimiser or fit stopped on its limit rather than on convergence."""
