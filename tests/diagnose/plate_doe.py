"""The NIST plate's designed experiment (tool stick-out × spindle speed) analysed apart from the diagnosis.

Shared by ``tests/diagnose/test_plate.py`` and ``bench/diagnose_real.py``.  Two views of the same data:

* **the part as the unit, pre-specified** (:func:`part_means`, :func:`speed_tests`): per part, the mean
  deviation of the dimensions each cutter register alone moves; the 18 parts of the experiment (serials
  19–20 ran at the operator's choice) in the classic 2 × 3 factorial with three parts per cell (nested
  OLS F-tests, Seber & Lee §4.3), and within the nine long stick-out parts the slope on the logged
  spindle speed.  One hypothesis stated before looking: no search, no multiplicity.
* **the diagnosis's own evidence** (:func:`speed_term_pvalues`): the same stick-out × speed term as a
  one-column candidate per register, in the model the diagnosis found, tested per part by the
  cluster-robust test the selection uses (:func:`setupfix.diagnose.inference.cluster_test`).

Checked against statsmodels (OLS, ``anova_lm``, MANOVA) in a scratch analysis: the same p-values.
"""

from __future__ import annotations

from typing import TypedDict

import numpy as np
import scipy.stats

from setupfix.diagnose.fit import effect_columns, observations
from setupfix.diagnose.inference import cluster_test, orth
from setupfix.diagnose.terms import EffectSpec, Layout, Series

LONG = "doe_tool_length=Long"
OPERATOR = "doe_tool_length=Operator"
SPEEDS = ("doe_speed=High", "doe_speed=Medium", "doe_speed=Low")
RPM = "endmill_rpm"


class SpeedTest(TypedDict):
    """One tool register's row of :func:`speed_tests`."""

    register: str
    p_speed: float
    p_interaction: float
    slope: float
    t: float
    p_slope: float
    df_slope: int


def channel(series: Series, name: str) -> np.ndarray:
    return series.temperature[:, series.channels.index(name)]


def part_means(layout: Layout, series: Series) -> tuple[np.ndarray, tuple[str, ...]]:
    """Per part, the mean deviation of the dimensions each tool register alone moves: (n_cycles, n_tools)."""
    C = layout.composite
    out, names = [], []
    for j in layout.tools:
        only = (C[j] != 0) & (np.count_nonzero(C, axis=0) == 1)
        if only.any():
            out.append(np.nanmean(series.deviation[:, only], axis=1))
            names.append(layout.register_ids[j])
    return np.column_stack(out), tuple(names)


def nested_f(y: np.ndarray, small: np.ndarray, big: np.ndarray) -> tuple[float, int, int, float]:
    """F-test of the columns ``big`` adds to ``small`` (both contain the constant): F, df1, df2, p."""

    def rss(A: np.ndarray) -> tuple[float, int]:
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        e = y - A @ coef
        return float(e @ e), int(np.linalg.matrix_rank(A))

    r0, p0 = rss(small)
    r1, p1 = rss(big)
    df1, df2 = p1 - p0, len(y) - p1
    f = ((r0 - r1) / df1) / (r1 / df2)
    return f, df1, df2, float(scipy.stats.f.sf(f, df1, df2))


def speed_tests(layout: Layout, series: Series) -> list[SpeedTest]:
    """Per tool register: the speed in the factorial (any effect of speed, and the stick-out × speed
    interaction), and within the long stick-out the slope on the logged speed [mm per 1000 rpm]."""
    y_all, names = part_means(layout, series)
    doe = channel(series, OPERATOR) == 0
    long = channel(series, LONG)[doe]
    spd = np.column_stack([channel(series, s)[doe] for s in SPEEDS[1:]])  # High the reference level
    one = np.ones(int(doe.sum()))
    stick = np.column_stack([one, long])
    additive = np.column_stack([stick, spd])
    cells = np.column_stack([additive, spd * long[:, None]])
    on = channel(series, LONG) == 1
    rpm = channel(series, RPM)[on] / 1000.0
    out: list[SpeedTest] = []
    for i, name in enumerate(names):
        y = y_all[doe, i]
        p_any = nested_f(y, stick, cells)[3]
        p_int = nested_f(y, additive, cells)[3]
        res = scipy.stats.linregress(rpm, y_all[on, i])
        out.append(
            {
                "register": name,
                "p_speed": p_any,
                "p_interaction": p_int,
                "slope": float(res.slope),
                "t": float(res.slope / res.stderr),
                "p_slope": float(res.pvalue),
                "df_slope": int(on.sum()) - 2,
            }
        )
    return out


def speed_term(series: Series, stick: str) -> tuple[str, np.ndarray]:
    """The stick-out × speed term: the logged speed [rpm] on the parts of the stick-out channel, 0 elsewhere."""
    return f"{RPM} on {stick}", channel(series, stick) * channel(series, RPM)


def speed_term_pvalues(layout: Layout, series: Series, found: tuple[EffectSpec, ...], stick: str) -> dict[str, float]:
    """Per tool register, the per-part p-value of the stick-out × speed term (one column on that register) in
    the model of ``found``: the test the selection accepts a one-column candidate on."""
    obs = observations(layout, series)
    X = np.hstack([obs.base] + [effect_columns(s, layout, series, obs) for s in found])
    Q = orth(X)
    r = obs.z - Q @ (Q.T @ obs.z)
    _, a = speed_term(series, stick)
    out = {}
    for j in layout.tools:
        col = ((a - a.mean())[obs.cycle] * layout.composite[j][obs.dim])[:, None]
        out[layout.register_ids[j]] = float(cluster_test(col - Q @ (Q.T @ col), r, obs.cycle, series.n_cycles)[1][0])
    return out


def residual_rms(
    layout: Layout, series: Series, found: tuple[EffectSpec, ...], stick: str | None = None, per_dimension: bool = False
) -> float:
    """Cell residual RMS of the model of ``found`` [mm]; with ``stick``, plus the stick-out × speed term on
    every tool register (a coefficient each); ``per_dimension``: every dimension its own constant and its
    own coefficients on the stick-out and the stick-out × speed (the per-cutter model on the same channels)."""
    obs = observations(layout, series)
    cols = [obs.base] + [effect_columns(s, layout, series, obs) for s in found]
    if stick is not None:
        _, a = speed_term(series, stick)
        cols += [(a[obs.cycle] * layout.composite[j][obs.dim])[:, None] for j in layout.tools]
    if per_dimension:
        onehot = (obs.dim[:, None] == np.arange(layout.n_dimensions)[None, :]).astype(float)
        cols = [onehot]
        for c in (channel(series, stick or LONG), *(() if stick is None else (speed_term(series, stick)[1],))):
            cols.append(onehot * c[obs.cycle][:, None])
    X = np.hstack(cols)
    Q = orth(X)
    r = obs.z - Q @ (Q.T @ obs.z)
    return float(np.sqrt(r @ r / obs.n))
