"""What the app is started with (:class:`Inputs`) and what the operator's session holds (:class:`SessionState`).

Both are plain dataclasses, no Textual: the state holds the report opened, the cycle on screen, the station
filter and sort, the last comparison and the folder watched, and answers the questions every part of the app
asks of them (the cycle on screen, its unit, where its series comes from).  Its methods change only
the state; the app pushes the state into the widgets afterwards.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from setupfix.inputs.stores import StoreRef
from setupfix.optimize import OPTIMIZERS
from setupfix.tui.session import FolderWatch, OpenedReport
from setupfix.usecases.compare import Comparison
from setupfix.usecases.requests import CycleCorrection, CycleOptions, ReadOptions
from setupfix.views import correction as view

__all__ = ["Inputs", "SessionState", "SORT_ORDER", "ENGINEER_ACTIONS", "attention_order"]


#: What ``s`` cycles through: None is the model's order.
SORT_ORDER: tuple[str | None, ...] = (None, "margin_after", "deviation", "name", "station")
#: The app's actions an engineer has and an operator does not see (``--engineer``, or ctrl+e in the app).
ENGINEER_ACTIONS = frozenset({"next_optimizer", "compare"})


def attention_order(rows: Sequence[view.DimensionRow]) -> list[view.DimensionRow]:
    """``rows`` as a small screen shows them: what needs the operator first.

    Out of tolerance (measured or predicted) first, then binding or inside the guard band (at a
    limit), then the rest; within each, the least margin after the correction first (model
    order breaks ties).
    """

    def rank(r: view.DimensionRow) -> int:
        if not (r.in_before and r.in_after):
            return 0
        return 1 if r.binding or "guard" in r.flags_ else 2

    return sorted(rows, key=lambda r: (rank(r), r.margin_after))


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
    engineer: bool = False  #: the optimiser choice and the comparison shown (``--engineer``)
    link: Path | None = None  #: ``--link``: the current offsets read from the control, and "send to machine" (w)
    insecure: bool = False  #: ``--insecure``: the link's password over an unencrypted session allowed

    @property
    def store(self) -> StoreRef | None:
        """The history store with its machine and operator (None without ``--db``)."""
        return None if self.db is None else StoreRef(self.db, self.machine, self.operator)


@dataclass
class SessionState:
    """The operator's session: what is opened, what is on screen, how it is filtered and sorted."""

    inputs: Inputs
    model_path: Path | None = None  #: the model opened (``--model``, or the one picked with m)
    report_path: Path | None = None  #: the report opened (picked with o, or the newest of a watched folder)
    optimizer: str = "exact"  #: the optimiser of the next run (p cycles through them)
    opened: OpenedReport | None = None  #: the report as opened by the last run that succeeded
    part_index: int = 0  #: the cycle (part) on screen, an index into ``opened.corrections``
    station: str | None = None  #: the station filter (None: all)
    sort_key: str | None = None  #: the sort of the dimensions (None: the model's order)
    comparison: Comparison | None = None  #: the last comparison of the optimisers
    folder_watch: FolderWatch | None = None  #: the folder watched for new reports
    problem: str = ""  #: why nothing is on screen (no model, no report, a failure), or what is under way
    current_problem: str = ""  #: why --current does not fit the model opened ("" when it fits or is not given)
    engineer: bool = False  #: the optimiser choice and the comparison shown (--engineer, ctrl+e)
    export_controller: str = "csv"  #: the controller format of the next export: the one last written
    export_path: str | None = None  #: the file last written (None: ``inputs.offsets``)
    send_increment: float = 0.001  #: the control's increment of the send under way (its read-back's decimals)
    send_line: str = ""  #: the last "send to machine" in one line: the read-back, or the refusal

    @classmethod
    def start(cls, inputs: Inputs) -> SessionState:
        """The session as the command line opens it (the report itself is opened by the app)."""
        return cls(inputs, model_path=inputs.model, optimizer=inputs.optimizer, engineer=inputs.engineer)

    def allows(self, action: str) -> bool:
        """False for an engineer's action (:data:`ENGINEER_ACTIONS`) in an operator's session, and for
        "send to machine" without a machine link (``--link``)."""
        if action == "send":
            return self.inputs.link is not None
        return self.engineer or action not in ENGINEER_ACTIONS

    def exported(self, controller: str, path: str) -> None:
        """An export was written: the next one offers the same controller and file (and asks before
        overwriting it)."""
        self.export_controller, self.export_path = controller, path

    def current(self) -> CycleCorrection | None:
        """The correction of the cycle on screen (None when nothing is corrected)."""
        if self.opened is None or not self.opened.corrections:
            return None
        return self.opened.corrections[self.part_index]

    def unit(self) -> str:
        """The model's length unit."""
        return self.opened.model.unit if self.opened is not None else "mm"

    def series_source(self) -> str:
        """The history store when given, else the watched folder or the report's folder."""
        if self.inputs.db is not None:
            return str(self.inputs.db)
        if self.folder_watch is not None:
            return str(self.folder_watch.folder)
        return str(self.report_path.parent) if self.report_path is not None else ""

    def feed_text(self) -> str:
        """The cycle's thermal feed-forward (part of its corrections and of the exported offsets)."""
        c = self.current()
        if c is None or c.thermal is None:
            return ""
        return c.thermal.line() + "; added to the exported offsets"

    def next_optimizer(self) -> None:
        """exact → cripso → … → exact (an unknown name starts again at exact)."""
        names = list(OPTIMIZERS)
        self.optimizer = names[(names.index(self.optimizer) + 1) % len(names)] if self.optimizer in names else "exact"

    def next_station(self) -> bool:
        """All stations → the first → … → all; False when nothing is corrected (then unchanged)."""
        c = self.current()
        if c is None:
            return False
        options: list[str | None] = [None, *view.stations(view.dimension_rows(c))]
        self.station = options[(options.index(self.station) + 1) % len(options)] if self.station in options else None
        return True

    def next_sort(self) -> None:
        """The next sort of :data:`SORT_ORDER`."""
        self.sort_key = SORT_ORDER[(SORT_ORDER.index(self.sort_key) + 1) % len(SORT_ORDER)]

    def sort_by(self, key: str) -> None:
        """Sort by the column ``key`` (a header clicked); the same column again: the model's order."""
        self.sort_key = None if self.sort_key == key else key

    def step_part(self, step: int) -> bool:
        """``step`` cycles forward (negative: back), round the report's cycles; False when there is none."""
        if not (self.opened and self.opened.corrections):
            return False
        self.part_index = (self.part_index + step) % len(self.opened.corrections)
        return True

    def jump_part(self, which: str) -> bool:
        """The ``"first"`` or the latest cycle of the report, in report order; False when there is none."""
        if not (self.opened and self.opened.corrections):
            return False
        self.part_index = 0 if which == "first" else len(self.opened.corrections) - 1
        return True

    def report_opened(self, opened: OpenedReport) -> None:
        """``opened`` is on screen now; the cycle on screen kept where the new report has it."""
        self.opened = opened
        self.problem = ""
        self.part_index = min(self.part_index, max(len(opened.corrections) - 1, 0))

    def open_failed(self, text: str) -> None:
        """The report could not be opened: the previous correction goes with it."""
        # showing (and exporting) the previous correction beside a failed report would invite applying stale
        # offsets: it is no longer what the operator asked for
        self.opened = None
        self.problem = f"✗ {text}"
