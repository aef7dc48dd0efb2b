"""The headline: report, optimiser, δ before → after and the bonus, the verdict."""

from __future__ import annotations

from rich.text import Text
from textual.widgets import Static

from setupfix.views.correction import Summary, signed

__all__ = ["SummaryBar"]

#: Verdict → (symbol, style).  The symbol carries the state on a monochrome terminal.
VERDICT_STYLE: dict[str, tuple[str, str]] = {
    "apply": ("✓ APPLY", "bold green"),
    "hold": ("● HOLD", "bold yellow"),
    "reject": ("✗ REJECT", "bold red"),
    "not_solved": ("✗ NOT SOLVED", "bold red"),
}


class SummaryBar(Static):
    """Three lines: where the numbers come from, the error budget, the verdict and notes."""

    def show(self, summary: Summary | None, *, optimizer: str, part: str = "", problem: str = "") -> None:
        """Render ``summary`` (None: nothing opened yet, or ``problem`` says why not)."""
        text = Text(no_wrap=False, overflow="ellipsis")
        if summary is None:
            text.append(problem or "No report open: press o to open one, ? for help.", style="bold")
            text.append(f"\noptimiser {optimizer}")
            self.update(text)
            return
        u = summary.unit
        key = summary.verdict if summary.solved else "not_solved"
        label, style = VERDICT_STYLE.get(key, (key.upper(), "bold"))
        text.append(f" {label} ", style=f"{style} reverse")
        text.append(f" {summary.report}", style="bold")
        text.append(f"  {part or summary.part}  ")
        text.append(f"{summary.optimizer} · {summary.status}", style="italic")
        if summary.bound is not None:
            text.append(f" · LP bound {signed(summary.bound)}")
        text.append("\nδ before ")
        text.append(signed(summary.margin_before), style="bold red" if summary.margin_before < 0 else "bold")
        text.append(" → after ")
        text.append(signed(summary.margin_after), style="bold red" if summary.margin_after < 0 else "bold green")
        text.append(f" {u}   bonus ")
        text.append(signed(summary.bonus), style="bold reverse")
        text.append(f" {u}   ‖x‖ {summary.norm:.4f}")
        if summary.alarm:
            text.append(f"\n✗ {summary.alarm}", style="bold red")
        else:
            text.append("\n" + ("✓ " if summary.in_tolerance else "✗ ") + summary.message)
        if summary.given_up:
            text.append(
                f"\n⚑ given up (NC program or process, not the setup): {', '.join(summary.given_up)}", style="yellow"
            )
        for rule in summary.rules:
            text.append(f"\n• {rule}")
        if problem:
            text.append(f"\n{problem}", style="bold")
        for note in summary.notes:
            text.append(f"\n⚠ {note}", style="yellow")
        self.update(text)
