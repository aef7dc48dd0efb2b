"""Modal screens: help, file picker, export confirmation, a yes-or-no question, capability."""

from __future__ import annotations

from setupfix.tui.screens.capability import CapabilityScreen
from setupfix.tui.screens.confirm import ConfirmScreen
from setupfix.tui.screens.export import ExportRequest, ExportScreen
from setupfix.tui.screens.help import HelpScreen
from setupfix.tui.screens.open_file import OpenFileScreen

__all__ = ["CapabilityScreen", "ConfirmScreen", "ExportRequest", "ExportScreen", "HelpScreen", "OpenFileScreen"]
