"""Modal screens: help, file picker, export confirmation, capability."""

from __future__ import annotations

from setupfix.tui.screens.capability import CapabilityScreen
from setupfix.tui.screens.export import ExportRequest, ExportScreen
from setupfix.tui.screens.help import HelpScreen
from setupfix.tui.screens.open_file import OpenFileScreen

__all__ = ["CapabilityScreen", "ExportRequest", "ExportScreen", "HelpScreen", "OpenFileScreen"]
