"""What the app is started with (:class:`Inputs`) and what it holds: the base class of the app's state.

:class:`AppState` keeps the report opened, the cycle on screen, the station filter and sort, and answers the
questions every part of the app asks of them (the cycle on screen, its unit, where its series comes from).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from textual.app import App
from textual.notifications import SeverityLevel

from setupfix.inputs.stores import StoreRef
from setupfix.tui.session import FolderWatch, OpenedReport
from setupfix.usecases.compare import Comparison
from setupfix.usecases.requests import CycleCorrection, CycleOptions, ReadOptions

__all__ = ["Inputs", "AppState"]


@dataclass(frozen=True)
class Inputs:
    """What the command line gave (paths as typed)."""

    model: Path | None = None
    report: Path | None = None
    db: str | None = None  #: history store: a file or a postgresql:// URL
    machine: str | None = None  #: ``--machine`` (default: the model's ``[process] machine``)
    operator: str | None = None  #: ``--operator`` (default: the login name)
    current: Path | None = None
    thermal: Path | None = None
    temperatures: Path | None = None
    process: Path | None = None  #: process log the diagnosis joins per part (``--process``)
    factors: tuple[str, ...] = ()  #: declared design factors of the diagnosis (``--factors``)
    at: str | None = None  #: time of the correction for the feed-forward (default: the log's last sample)
    thermal_dead_band: float | None = None
    read: ReadOptions = field(default_factory=ReadOptions)  #: the reader's options, as ``correct`` takes them
    cycles: CycleOptions = field(default_factory=CycleOptions)  #: stations, parts per cycle, strictness
    optimizer: str = "exact"
    objective: str | None = None  #: the exact optimiser's objective (leximin or paper; None: its default)
    seed: int = 0
    trials: int = 12
    offsets: str = "offsets.csv"
    poll_seconds: float = 2.0

    @property
    def store(self) -> StoreRef | None:
        """The history store with its machine and operator (None without ``--db``)."""
        return None if self.db is None else StoreRef(self.db, self.machine, self.operator)


class AppState(App[None]):
    """The app's state and its accessors; :class:`~setupfix.tui.app.SetupfixApp` builds on it."""

    def __init__(self, inputs: Inputs | None = None) -> None:
        super().__init__()
        self.inputs = inputs or Inputs()
        self.model_path = self.inputs.model
        self.report_path: Path | None = None
        self.optimizer = self.inputs.optimizer
        self.opened: OpenedReport | None = None
        self.part_index = 0
        self.station: str | None = None
        self.sort_key: str | None = None
        self.comparison: Comparison | None = None
        self.folder_watch: FolderWatch | None = None
        self.problem = ""
        self._wide = False
        self._short = False
        self.current_problem = ""  #: why --current does not fit the model opened ("" when it fits or is not given)

    def _feed_text(self) -> str:
        """The cycle's thermal feed-forward (part of its corrections and of the exported offsets)."""
        c = self._current()
        if c is None or c.thermal is None:
            return ""
        return c.thermal.line() + "; added to the exported offsets"

    def notify(
        self,
        message: str,
        *,
        title: str = "",
        severity: SeverityLevel = "information",
        timeout: float | None = None,
        markup: bool = False,
    ) -> None:
        """A toast; its text (names of files, reports, dimensions) is literal, not markup."""
        super().notify(message, title=title, severity=severity, timeout=timeout, markup=markup)

    def _current(self) -> CycleCorrection | None:
        if self.opened is None or not self.opened.corrections:
            return None
        return self.opened.corrections[self.part_index]

    def _unit(self) -> str:
        return self.opened.model.unit if self.opened is not None else "mm"

    def _series_source(self) -> str:
        """The history store when given, else the watched folder or the report's folder."""
        if self.inputs.db is not None:
            return str(self.inputs.db)
        if self.folder_watch is not None:
            return str(self.folder_watch.folder)
        return str(self.report_path.parent) if self.report_path is not None else ""
