""" "Send to machine": the dry-run diff of the cycle on screen over the screen, and the one line of the result.

The diff is :func:`setupfix.usecases.machine.plan_write`'s, the dry run of ``machine write`` (the
control read, nothing written): per register component the value the control holds, the change and the new value at the
control's increment, in the control's unit.  Send (s) only answers "go on": the controller then asks
a second, explicit question (:class:`~setupfix.tui.screens.confirm.ConfirmScreen`, No focused) before
anything is written.  A plan that is never written (its verdict, a stopped solve, a draft model), a
table changed since the plan, or a control that could not be read leaves only Close.
"""

from __future__ import annotations

from typing import ClassVar

from rich.text import Text
from textual import on
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical
from textual.screen import ModalScreen
from textual.widgets import Button, DataTable, Static

from setupfix.links.mapping import decimals_of
from setupfix.usecases.machine import WriteOutcome, WritePlan

__all__ = ["SendScreen", "diff_rows", "sendable", "outcome_line", "question"]


def _number(value: float | None, digits: int) -> str:
    """``value`` with the control's decimals; never a negative zero."""
    if value is None:
        return ""
    text = f"{value:.{digits}f}"
    return text.lstrip("-") if float(text) == 0 else text


def _signed(value: float | None, digits: int) -> str:
    text = _number(value, digits)
    return "+" + text if value is not None and float(text) > 0 else text


def diff_rows(wp: WritePlan) -> list[tuple[str, str, str, str, str]]:
    """(register, axis, current, change, new) per component of the dry run, with the increment's decimals."""
    digits = decimals_of(wp.increment)
    return [
        (r.component.register, r.component.axis, _number(r.before, digits), _signed(r.change, digits),
         _number(r.new, digits))
        for r in wp.rows
    ]  # fmt: skip


def sendable(wp: WritePlan) -> str | None:
    """None when the plan may be written after the second confirmation; else why not (one line)."""
    if wp.plan.refusal:
        return wp.plan.refusal
    if wp.stale:
        changed = ", ".join(map(str, wp.stale))
        return f"the table changed since the plan ({changed}): open the report again (r) to plan anew"
    if not any(r.change for r in wp.rows):
        return "no change to write: the control holds the planned values"
    return None


def question(wp: WritePlan, operator: str, recorded: bool) -> str:
    """The second confirmation's text: what is written where, by whom."""
    changed = sum(1 for r in wp.rows if r.change)
    audit = "recorded in the history store" if recorded else "NOT recorded (no --db)"
    return (
        f"Write {changed} offset value(s) to {wp.machine or wp.link} now?\n"
        f"Operator {operator}; the attempt is {audit}.\n"
        "The control is read again first: a table changed since the plan, the interlock or a limit refuses."
    )


def outcome_line(result: WriteOutcome, operator: str, increment: float) -> str:
    """The result in one line: what was read back, or the refusal (``machine write``'s message)."""
    where = result.machine or result.link
    if result.outcome == "applied":
        digits = decimals_of(increment)
        back = ", ".join(f"{r.component} {_number(r.read_back, digits)}" for r in result.rows if r.change)
        return f"applied on {where} by {operator}: read back {back or 'no change'} {result.unit}"
    return f"{result.outcome.replace('_', ' ')} on {where} by {operator}: {' '.join(result.message.split())}"


class SendScreen(ModalScreen[bool]):
    """The dry-run diff; Send (s) answers True (then the second question), Cancel/Close (escape) False."""

    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("s", "send", "Send"),
        Binding("escape,n", "cancel", "Cancel"),
    ]
    DEFAULT_CSS = """
    SendScreen { align: center middle; }
    #send-box { width: 78; max-width: 100%; height: auto; max-height: 100%; border: thick $warning;
                background: $surface; padding: 0 1; }
    #send-title, #send-why { height: auto; }
    #send-table { height: auto; max-height: 12; }
    #send-buttons { height: auto; align-horizontal: right; }
    """

    def __init__(self, wp: WritePlan) -> None:
        super().__init__()
        self.wp = wp
        self.why = sendable(wp)

    def compose(self) -> ComposeResult:
        d = self.wp
        where = d.machine or d.link
        with Vertical(id="send-box"):
            yield Static(Text(f"Send to machine {where} ({d.unit}, increment {d.increment:g})"), id="send-title")
            table: DataTable[str | Text] = DataTable(id="send-table", cursor_type="row", zebra_stripes=True)
            table.add_columns("register", "axis", "current", "change", "new")
            for register, axis, *numbers in diff_rows(d):
                table.add_row(register, axis, *(Text(n, justify="right") for n in numbers))
            yield table
            text = f"✗ {self.why}" if self.why else "dry run: nothing written yet. s sends (a second question follows)"
            yield Static(Text(text), id="send-why")
            with Horizontal(id="send-buttons"):
                if self.why is None:
                    yield Button("Send… (s)", variant="warning", id="send-yes")
                yield Button("Close (esc)" if self.why else "Cancel (esc)", variant="primary", id="send-no")

    def on_mount(self) -> None:
        self.query_one("#send-no", Button).focus()

    @on(Button.Pressed, "#send-yes")
    def _yes(self) -> None:
        self.action_send()

    @on(Button.Pressed, "#send-no")
    def _no(self) -> None:
        self.dismiss(False)

    def action_send(self) -> None:
        if self.why is None:
            self.dismiss(True)

    def action_cancel(self) -> None:
        self.dismiss(False)
