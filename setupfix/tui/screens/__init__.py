"""Modal screens: help, file picker, export confirmation."""

from __future__ import annotations

from setupfix.tui.screens.export import ExportRequest, ExportScreen
from setupfix.tui.screens.help import HelpScreen
from setupfix.tui.screens.open_file import OpenFileScreen

__all__ = ["ExportRequest", "ExportScreen", "HelpScreen", "OpenFileScreen"]
