"""Statistical process control of a measured series (layer 3: arrays in, numbers out, no I/O).

:mod:`setupfix.spc.capability` holds the capability indices (Cp, Cpk, Pp, Ppk with a
confidence interval for Cpk), :mod:`setupfix.spc.charts` the individuals and
moving-range chart limits and the Nelson rules, :mod:`setupfix.spc.baseline` whether the
limits' baseline is a stable window and which is the first one that is.
"""

from setupfix.spc.baseline import MAX_WINDOWS, BaselineCheck, baseline_check, first_stable_window
from setupfix.spc.capability import (
    D2,
    MIN_PARTS,
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
    "MAX_WINDOWS",
    "BaselineCheck",
    "baseline_check",
    "first_stable_window",
    "MIN_PARTS",
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
