"""The thermal panel: the model's predicted drift, its recent curve, the feed-forward."""

from __future__ import annotations

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import Vertical
from textual.widgets import Sparkline, Static

from setupfix.tui.widgets.plain import plain
from setupfix.views.analysis import DriftView
from setupfix.views.correction import signed

__all__ = ["ThermalPanel"]


class ThermalPanel(Vertical):
    """Drift now, the recent curve, and what it adds to the recommendation."""

    def compose(self) -> ComposeResult:
        yield Static("", id="thermal-status")
        yield Sparkline([], id="thermal-curve")
        yield Static("", id="thermal-feed")

    def not_available(self, reason: str) -> None:
        self.query_one("#thermal-status", Static).update(Text(f"not available: {reason}", style="dim"))
        self.query_one("#thermal-curve", Sparkline).display = False

    def show(self, view: DriftView, *, source: str) -> None:
        unit = view.unit or "(unit not stated)"
        text = Text()
        text.append(f"{view.method} model", style="bold")
        text.append(f" on {source}: {view.samples} samples, target {view.target}\n")
        text.append("predicted drift at the latest sample, relative to the model's reference state ")
        text.append(f"{signed(view.latest)} {unit}", style="bold")
        text.append(f" ({view.latest_time})")
        if view.measured_latest is not None:
            text.append(f"; measured {signed(view.measured_latest)} {unit}")
        low, high = view.recent_range
        text.append(
            f"\nrecent curve, last {len(view.recent)} samples, from {signed(low)} (▁) to {signed(high)} (█) {unit}:"
        )
        for note in view.notes:
            text.append(f"\n⚠ {note}", style="yellow")
        self.query_one("#thermal-status", Static).update(plain(text))
        curve = self.query_one("#thermal-curve", Sparkline)
        curve.display = True
        curve.data = [float(v) for v in view.recent]

    def feed_forward(self, text: str) -> None:
        self.query_one("#thermal-feed", Static).update(plain(text))
