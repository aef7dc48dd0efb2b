"""Temperature and process logs (``spec/measurements.md``, "Temperature log"): CSV or ``.xlsx`` → arrays.

Not a CMM report format, so not in the format registry: every command that takes a
temperature log (``thermal``, ``correct --temperatures``, ``diagnose``, ``history
import``) reads it with :func:`read_temperature_log`, the one reader; ``diagnose
--process`` reads a process log with the same reader (``keep_text=True``: categorical
columns kept as text, ``require_time=False``: a ``serial`` column may tie it to the parts).
"""

from __future__ import annotations

from parsers.temperature.reader import TemperatureLog, read_temperature_log

__all__ = ["TemperatureLog", "read_temperature_log"]
