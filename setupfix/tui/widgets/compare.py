"""The compare view: every optimiser beside the exact optimum, and their convergence."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from rich.text import Text
from textual.app import ComposeResult
from textual.containers import Vertical, VerticalScroll
from textual.widgets import DataTable, Label, ProgressBar, Sparkline, Static

from setupfix.tui.widgets.plain import PlainTable, plain
from setupfix.views.correction import signed

__all__ = ["ComparePanel"]


class ComparePanel(Vertical):
    """Status and progress, the results table, one sparkline of median f1 per method."""

    def compose(self) -> ComposeResult:
        yield Static("Press c to compare the optimisers on this part (x cancels).", id="compare-status")
        yield ProgressBar(total=None, show_eta=False, id="compare-progress")
        yield PlainTable(id="compare-table", cursor_type="row", zebra_stripes=True)
        yield VerticalScroll(id="compare-curves")

    def on_mount(self) -> None:
        self.query_one(ProgressBar).display = False

    def status(self, text: str) -> None:
        self.query_one("#compare-status", Static).update(plain(text))

    def progress(self, done: int, total: int, method: str) -> None:
        bar = self.query_one(ProgressBar)
        bar.display = True
        bar.update(total=total, progress=done)
        self.status(f"comparing… {done}/{total} runs done ({method}); x cancels")

    def stopped(self, text: str) -> None:
        self.query_one(ProgressBar).display = False
        self.status(text)

    def show(
        self,
        rows: Sequence[Mapping[str, Any]],
        curves: Mapping[str, npt.NDArray[np.float64]],
        *,
        exact_f1: float,
        unit: str,
        heading: str,
    ) -> None:
        """Results table (exact first; skipped methods with their reason) and the curves."""
        self.stopped(heading)
        table = self.query_one("#compare-table", DataTable)
        table.clear(columns=True)
        for label in ("method", "f1 best", "median", "worst", "gap med µm", "gap max µm", "solutions", "ms"):
            table.add_column(label)
        for r in rows:
            if "skipped" in r:
                table.add_row(r["optimizer"], Text(f"not available: {r['skipped']}", style="dim"))
                continue
            table.add_row(
                r["optimizer"],
                *(Text(signed(r[k]), justify="right") for k in ("f1_best", "f1_median", "f1_worst")),
                *(Text(f"{r[k] * 1000:.1f}", justify="right") for k in ("gap_median", "gap_worst")),
                Text(f"{r['evaluations']:.0f}", justify="right"),
                Text(f"{r['seconds'] * 1000:.0f}", justify="right"),
            )
        box = self.query_one("#compare-curves", VerticalScroll)
        box.remove_children()
        widgets: list[Label | Sparkline] = []
        for name, curve in curves.items():
            widgets.append(
                Label(
                    f"{name:<7} median f1 {signed(float(curve[0]))} → {signed(float(curve[-1]))} {unit}"
                    f"  (exact {signed(exact_f1)})"
                )
            )
            widgets.append(Sparkline([float(v) for v in curve], classes="curve"))
        box.mount_all(widgets)
