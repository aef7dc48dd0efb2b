"""The export confirmation: the controller format, the target and exactly the text to be written."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import ClassVar

from rich.text import Text
from textual import on
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, ScrollableContainer, Vertical
from textual.screen import ModalScreen
from textual.widgets import Button, Input, Label, Select, Static

from setupfix.core.errors import SetupfixError
from setupfix.tui.screens.confirm import ConfirmScreen

__all__ = ["ExportRequest", "ExportScreen"]


@dataclass(frozen=True)
class ExportRequest:
    """What the operator confirmed: the format, the file and the exact text."""

    controller: str
    path: str
    text: str


class ExportScreen(ModalScreen[ExportRequest | None]):
    """Shows the text ``render(controller)`` returns; ctrl+s (or Write) writes it, escape cancels.

    ``controller`` is the format chosen first (the one last written; default the first of ``controllers``).
    ``rename(path, controller)``, when given, is the file name that follows a newly chosen controller.
    A file that exists is overwritten only when the operator says yes to the question that names it.
    """

    BINDINGS: ClassVar[list[BindingType]] = [Binding("ctrl+s", "write", "Write"), Binding("escape", "cancel", "Cancel")]

    def __init__(
        self,
        controllers: Sequence[str],
        render: Callable[[str], str],
        path: str,
        *,
        rename: Callable[[str, str], str] | None = None,
        controller: str | None = None,
    ) -> None:
        super().__init__()
        self.controllers = list(controllers)
        self.controller = controller if controller in self.controllers else self.controllers[0]
        self.render_text = render
        self.rename = rename
        self.path = rename(path, self.controller) if rename else path
        self.refusal = ""
        self.text = ""  #: exactly what Write writes

    def compose(self) -> ComposeResult:
        with Vertical(id="export-box"):
            yield Label("Export the offsets — this exact text will be written:", id="export-title")
            with Horizontal(id="export-options"):
                yield Select(
                    [(c, c) for c in self.controllers],
                    value=self.controller,
                    allow_blank=False,
                    id="export-controller",
                )
                yield Input(self.path, id="export-path")
            with ScrollableContainer(id="export-scroll"):
                yield Static(Text(self._text(self.controller), no_wrap=True), id="export-text")
            with Horizontal(id="export-buttons"):
                yield Button("Write (ctrl+s)", variant="primary", id="export-write")
                yield Button("Cancel (esc)", id="export-cancel")

    def on_mount(self) -> None:
        self.query_one("#export-controller", Select).focus()

    @on(Select.Changed, "#export-controller")
    def _controller(self, event: Select.Changed) -> None:
        self.query_one("#export-text", Static).update(Text(self._text(str(event.value)), no_wrap=True))
        if self.rename is not None:
            field = self.query_one("#export-path", Input)
            field.value = self.rename(field.value, str(event.value))

    def _text(self, controller: str) -> str:
        """The text to write, or the reason there is none (then Write refuses)."""
        try:
            self.refusal = ""
            self.text = self.render_text(controller)
        except SetupfixError as exc:
            self.refusal, self.text = str(exc), ""
            return f"cannot export: {exc}"
        return self.text

    @on(Button.Pressed, "#export-write")
    def action_write(self) -> None:
        controller = str(self.query_one("#export-controller", Select).value)
        path = self.query_one("#export-path", Input).value.strip()
        if not path:
            self.notify("give a file to write", severity="error")
            return
        if self.refusal:
            self.notify(self.refusal, title="export refused", severity="error")
            return
        request = ExportRequest(controller, path, self.text)
        target = Path(path)  # as the write takes it
        if target.is_file() and not target.is_symlink():  # anything else that exists is refused by the write
            self.app.push_screen(
                ConfirmScreen(f"{path} exists. Overwrite it with this {controller} export?", yes="Overwrite (y)"),
                partial(self._overwrite, request),
            )
            return
        self.dismiss(request)

    def _overwrite(self, request: ExportRequest, yes: bool | None) -> None:
        if yes:
            self.dismiss(request)
        else:
            self.notify(f"{request.path} kept: not overwritten", timeout=4)

    @on(Button.Pressed, "#export-cancel")
    def action_cancel(self) -> None:
        self.dismiss(None)
