"""Statistical process control of a measured series (layer 3: arrays in, numbers out, no I/O).

:mod:`setupfix.spc.capability` holds the capability indices (Cp, Cpk, Pp, Ppk with a
confidence interval for Cpk), :mod:`setupfix.spc.charts` the individuals and
moving-range chart limits and the Nelson rules.
"""

from setupfix.spc.capability import (
    D2,
    Capability,
    capability,
    cpk_interval,
    sigma_overall,
    sigma_within,
    split_capability,
)
from setupfix.spc.charts import (
    D4,
    NELSON_RULES,
    ChartLimits,
    Violation,
    chart_limits,
    moving_range,
    nelson,
)

__all__ = [
    "D2",
    "D4",
    "Capability",
    "capability",
    "cpk_interval",
    "sigma_overall",
    "sigma_within",
    "split_capability",
    "NELSON_RULES",
    "ChartLimits",
    "Violation",
    "chart_limits",
    "moving_range",
    "nelson",
]
