"""Moved: the temperature-log reader is :mod:`parsers.temperature` (kept here for callers not yet switched)."""

from __future__ import annotations

from parsers.temperature import TemperatureLog, read_temperature_log

__all__ = ["TemperatureLog", "read_temperature_log"]
