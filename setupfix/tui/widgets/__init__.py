"""Widgets of the operator's screen; each lays out rows from :mod:`setupfix.views.correction` or
:mod:`setupfix.views.analysis`, and the tab widgets post what the operator asks for as messages."""

from __future__ import annotations

from setupfix.tui.widgets.compare import ComparePanel
from setupfix.tui.widgets.correction import TALL, WIDE, CorrectionTab
from setupfix.tui.widgets.dimensions import DimensionTable
from setupfix.tui.widgets.history import HistoryPanel
from setupfix.tui.widgets.mismatch import MatchPanel, MatchTable
from setupfix.tui.widgets.registers import RegisterTable
from setupfix.tui.widgets.summary import SummaryBar
from setupfix.tui.widgets.thermal import ThermalPanel

__all__ = [
    "ComparePanel",
    "CorrectionTab",
    "DimensionTable",
    "HistoryPanel",
    "MatchPanel",
    "MatchTable",
    "RegisterTable",
    "SummaryBar",
    "ThermalPanel",
    "WIDE",
    "TALL",
]
