"""The history panel: the error budget over the last cycles and what the diagnosis found."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import VerticalScroll
from textual.widgets import DataTable, Sparkline, Static

from setupfix.tui.widgets.plain import PlainTable, plain
from setupfix.views.analysis import CycleBudget, DiagnosisView
from setupfix.views.correction import IN, OUT, signed

__all__ = ["HistoryPanel"]

#: Cycles listed in the table (the sparkline shows them all).
LAST_CYCLES = 8


class HistoryPanel(VerticalScroll):
    """Budget per cycle (sparkline and table), then the diagnosis: before/after, effects, walk forward."""

    def compose(self) -> ComposeResult:
        yield Static("", id="history-status")
        yield Sparkline([], id="history-curve")
        yield PlainTable(id="history-cycles", cursor_type="row")
        yield Static("", id="history-diagnosis")
        yield PlainTable(id="history-effects", cursor_type="row")
        yield Static("", id="history-walk")

    def on_mount(self) -> None:
        for wid in ("#history-curve", "#history-cycles", "#history-effects"):
            self.query_one(wid).display = False

    def status(self, text: str | Text) -> None:
        self.query_one("#history-status", Static).update(plain(text))

    def budgets(self, rows: Sequence[CycleBudget], *, unit: str, source: str) -> None:
        """δ of every cycle, oldest first; the table lists the last :data:`LAST_CYCLES`."""
        self.status(Text(f"error budget δ of {len(rows)} cycle(s) as measured, from {source} [{unit}]"))
        curve = self.query_one("#history-curve", Sparkline)
        curve.display = len(rows) > 1
        curve.data = [r.budget for r in rows]
        table = self.query_one("#history-cycles", DataTable)
        table.display = bool(rows)
        table.clear(columns=True)
        for label in ("", "cycle", "time", "δ", "out"):
            table.add_column(label)
        for r in rows[-LAST_CYCLES:]:
            table.add_row(
                Text(IN if r.out_of_tolerance == 0 else OUT),
                r.cycle,
                r.timestamp,
                Text(signed(r.budget), justify="right"),
                str(r.out_of_tolerance),
            )

    def diagnosis(self, view: DiagnosisView, *, source: str) -> None:
        u = view.unit
        self.budgets(view.budgets, unit=u, source=source)
        text = Text()
        text.append(f"diagnosis of {view.cycles} cycle(s): ", style="bold")
        text.append(
            f"residual RMS {view.before[0]:.4f} → {view.after[0]:.4f} {u}, "
            f"max {view.before[1]:.4f} → {view.after[1]:.4f}, "
            f"out of tolerance {view.before[2]} → {view.after[2]}"
        )
        if not view.effects:
            text.append("\nno effect found: the declared model explains the series to its noise")
        self.query_one("#history-diagnosis", Static).update(text)
        table = self.query_one("#history-effects", DataTable)
        table.display = bool(view.effects)
        table.clear(columns=True)
        for label in ("effect", "on", "estimate", "± s.e.", "RMS after"):
            table.add_column(label)
        for e in view.effects:
            table.add_row(
                e.kind + (" (declared)" if e.source == "declared" else ""),
                e.target + (f" (≈ {', '.join(e.alike)})" if e.alike else ""),
                Text(f"{e.estimate:+.4g} {e.unit}", justify="right"),
                f"{e.stderr:.2g}",
                Text(f"{e.rms_after:.4f}", justify="right"),
            )
        walk = Text()
        if view.walk:
            walk.append(
                "walk forward (later cycles: distance to the tolerance centre RMS / mean |·|, "
                "error budget mean / worst):\n"
            )
            centre = {name: (c_rms, c_mean) for name, c_rms, c_mean in view.walk_centre}
            for name, mean, worst, _rms, out in view.walk:
                c_rms, c_mean = centre.get(name, (float("nan"), float("nan")))
                walk.append(
                    f"  {name:<9} centre {c_rms:.4f} / {c_mean:.4f}  budget {signed(mean)} / {signed(worst)}"
                    f"  out {out}\n"
                )
        if view.draft is not None:  # a draft's next correction is no number, not even "none"
            walk.append(f"next correction: {view.draft}", style="bold yellow")
        else:
            walk.append(f"next correction (from {view.next_from}): {view.next_text or 'none'}")
        if view.held:
            walk.append(f"; held at the centre: {', '.join(view.held)}")
        for note in view.notes:
            walk.append(f"\n⚠ {note}", style="yellow")
        self.query_one("#history-walk", Static).update(walk)
