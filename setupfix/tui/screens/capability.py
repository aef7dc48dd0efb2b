"""The capability screen: Cpk per stored characteristic, a sparkline of its individuals chart, its rule flags.

Opened over the main screen with the SPC of the history store
(:func:`setupfix.usecases.spc_report.spc_report`, run in a worker by the caller); the rows come
from :func:`setupfix.usecases.spc_report.capability_rows`, nothing is computed here.
"""

from __future__ import annotations

from typing import ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import DataTable, Static

from setupfix.usecases.spc_report import SpcOutcome, capability_rows

__all__ = ["CapabilityScreen", "COLUMNS"]

#: Column headers of the capability table.
COLUMNS = ("dimension", "n", "Cpk", "Cpk 95 % CI", "Ppk", "out", "individuals (last 30)", "rules", "Cpk at last split")


class CapabilityScreen(ModalScreen[None]):
    """Cpk, its interval, Ppk, parts out of tolerance, sparkline and Nelson-rule flags per characteristic."""

    BINDINGS: ClassVar[list[BindingType]] = [Binding("escape,q,k", "dismiss", "Close")]
    DEFAULT_CSS = """
    CapabilityScreen { align: center middle; }
    #capability-box { width: 95%; height: 90%; border: round $accent; background: $surface; }
    #capability-title { height: auto; padding: 0 1; }
    """

    def __init__(self, outcome: SpcOutcome) -> None:
        super().__init__()
        self.outcome = outcome

    def compose(self) -> ComposeResult:
        with Vertical(id="capability-box"):
            yield Static(
                Text(
                    f"capability — {self.outcome.store}: {len(self.outcome.dimensions)} characteristic(s), "
                    f"limits from the first {self.outcome.baseline} parts (R1…R4: Nelson rules violated)"
                ),
                id="capability-title",
            )
            yield DataTable(id="capability", zebra_stripes=True, cursor_type="row")

    def on_mount(self) -> None:
        table = self.query_one("#capability", DataTable)
        table.add_columns(*COLUMNS)
        for row in capability_rows(self.outcome):
            flagged = row.rules != "—"
            table.add_row(
                Text(row.name),
                str(row.n),
                row.cpk,
                row.interval,
                row.ppk,
                Text(str(row.out), style="bold red" if row.out else ""),
                Text(row.spark),
                Text(row.rules, style="bold red" if flagged else ""),
                row.last_split,
            )

    def action_dismiss(self, result: None = None) -> None:  # type: ignore[override]  # returns nothing
        self.dismiss(None)
