"""Temperature logs (``spec/measurements.md``, "Temperature log"): CSV or ``.xlsx`` → arrays.

Not a CMM report format, so not in the format registry: the thermal commands read
these files directly with :func:`read_temperature_log`.
"""

from __future__ import annotations

from parsers.temperature.reader import TemperatureLog, read_temperature_log

__all__ = ["TemperatureLog", "read_temperature_log"]
