"""The file picker: a directory tree and a path field."""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

from textual import on
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import DirectoryTree, Input, Label

__all__ = ["OpenFileScreen"]


class OpenFileScreen(ModalScreen[Path | None]):
    """Type a path (Enter opens it) or Tab to the tree and pick a file; escape cancels."""

    BINDINGS: ClassVar[list[BindingType]] = [Binding("escape", "cancel", "Cancel")]

    def __init__(self, title: str, start: Path, *, allow_folder: bool = False) -> None:
        super().__init__()
        self.title_text = title
        # the nearest folder that exists: a tree of a missing folder selects it as a file at once (the last
        # report that could not be read, say), which would close the picker before the operator saw it
        folder = start if start.is_dir() else start.parent
        while not folder.is_dir() and folder != folder.parent:
            folder = folder.parent
        self.start = folder
        self.allow_folder = allow_folder

    def compose(self) -> ComposeResult:
        with Vertical(id="open-box"):
            yield Label(self.title_text, id="open-title")
            yield Input(placeholder="type a path and press Enter, or Tab to the tree", id="open-path")
            yield DirectoryTree(str(self.start), id="open-tree")

    def on_mount(self) -> None:
        self.query_one("#open-path", Input).focus()

    @on(DirectoryTree.FileSelected)
    def _file(self, event: DirectoryTree.FileSelected) -> None:
        self.dismiss(Path(event.path))

    @on(DirectoryTree.DirectorySelected)
    def _folder(self, event: DirectoryTree.DirectorySelected) -> None:
        self.query_one("#open-path", Input).value = str(event.path)

    @on(Input.Submitted, "#open-path")
    def _typed(self, event: Input.Submitted) -> None:
        if event.value.strip():
            self.dismiss(Path(event.value.strip()).expanduser())

    def action_cancel(self) -> None:
        self.dismiss(None)
