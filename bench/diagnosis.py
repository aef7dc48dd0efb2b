"""The diagnosis benches' data: simulated series on the guide-pins model, and the NIST plate.

* :func:`guide_pins` (the bundled model with feature positions), :func:`topology` (random process
  models), :func:`one_effect` (a clearly detectable hidden effect of each kind) and :func:`simulate`
  (a shop's series with hidden effects): the series ``bench.diagnose_calibration``,
  ``bench.diagnose_closed_loop``, ``bench.diagnose_factors`` and ``bench.diagnose_walk`` diagnose;
* :data:`PLATE`, :data:`PLATE_MODEL`, :data:`PLATE_LOG`: the NIST plate series (a designed experiment,
  tool stick-out × spindle speed) with its model and process log;
* :func:`speed_tests`, :func:`speed_term_pvalues`, :func:`residual_rms`: the plate's designed experiment
  analysed apart from the diagnosis, with the part as the unit and the hypothesis stated in advance
  (nested OLS F-tests of the 2 × 3 factorial, Seber & Lee §4.3; within the long stick-out, the slope on the
  logged spindle speed), and the same stick-out × speed term in the diagnosis's own model;
* :func:`svd_seconds`: the diagnosis benches' reference time.

The diagnosis tests use the same helpers (``from bench.diagnosis import …``): one simulator set-up and
one analysis of the plate's experiment for the tests and the benches.
"""

from __future__ import annotations

import os
import time
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Any, TypedDict, Unpack

import numpy as np
import scipy.stats

from setupfix.diagnose import EffectSpec, HiddenEffect, Layout, Series, ShopSimulator, SimulatedSeries
from setupfix.diagnose.fit import effect_columns, observations
from setupfix.diagnose.inference import cluster_test, orth
from setupfix.diagnose.shop import random_topology
from setupfix.model import ProcessModel, model_from_dict

ROOT = Path(__file__).resolve().parents[1]
#: The shared folder beside the repository (``SETUPFIX_SHARED`` overrides it): real series and logs.
SHARED = Path(os.environ.get("SETUPFIX_SHARED", ROOT.parent / "shared"))
PLATE = ROOT / "sample_reports" / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif"
PLATE_MODEL = ROOT / "tests" / "data" / "nist_plate.toml"
PLATE_LOG = SHARED / "real-series" / "nist-mtc" / "plate_process.csv"

#: The cell noise of the simulated series [mm].
NOISE = 0.002
EXPANDED = ROOT / "tests" / "model" / "data" / "guide_pins_expanded.toml"


def guide_pins_doc(positions: bool = True) -> dict[str, Any]:
    """The bundled guide-pins model; with positions, part p sits at x = 150 (p − 1), feature f at +20 f."""
    doc = tomllib.loads(EXPANDED.read_text(encoding="utf-8"))  # the sample written table by table
    if positions:
        for fid, feat in doc["features"].items():
            p, f = int(fid[1]), int(fid[3:])
            feat["position"] = [150.0 * (p - 1) + 20.0 * f, 40.0 if f in (1, 2, 4) else -40.0, 10.0 * (f % 3)]
    return doc


def guide_pins(positions: bool = True) -> ProcessModel:
    return model_from_dict(guide_pins_doc(positions), source="guide_pins")


def topology(seed: int) -> ProcessModel:
    return model_from_dict(random_topology(seed), source=f"topology {seed}")


def one_effect(layout: Layout, kind: str, scale: float = 1.0) -> HiddenEffect:
    """A clearly detectable effect of ``kind`` on ``layout`` (magnitudes several times the noise)."""
    C = layout.composite
    if kind == "drift":
        return HiddenEffect(EffectSpec("drift"), 0.002 * scale)
    if kind == "saturating":
        return HiddenEffect(EffectSpec("drift", shape="saturating", tau=3.0), 0.02 * scale)
    if kind == "thermal":
        return HiddenEffect(EffectSpec("thermal", channel="spindle", reference=20.0), 0.003 * scale)
    if kind == "wear":
        return HiddenEffect(EffectSpec("wear", register=layout.tool_ids[0]), -0.001 * scale)
    if kind == "scale":
        return HiddenEffect(EffectSpec("scale"), 2e-4 * scale)
    if kind == "position":
        return HiddenEffect(EffectSpec("position", axis="x"), 5e-5 * scale)
    if kind == "group":
        return HiddenEffect(EffectSpec("group", group=sorted({g for g in layout.groups if g})[1]), 0.01 * scale)
    if kind == "relation":
        # a register the first dimension does not answer to in the model: a missing relation
        free = np.flatnonzero(C[:, 0] == 0)
        reg = layout.register_ids[int(free[0])] if free.size else layout.register_ids[0]
        return HiddenEffect(EffectSpec("relation", register=reg, dimension=layout.dimension_ids[0]), 0.5 * scale)
    raise KeyError(kind)


class SimulatorParams(TypedDict, total=False):
    """The keyword parameters of :class:`ShopSimulator` (the seed apart)."""

    n_cycles: int
    noise: float
    setup_error: float
    cycle_minutes: float
    shift_cycles: int
    pause_hours: float
    correct_every: int
    dead_time: float
    gain: float
    tool_change_every: int
    heat: float
    sparse: int
    decimals: int
    process: int
    part_noise: float


def simulate(
    layout: Layout, effects: Iterable[HiddenEffect] = (), seed: int = 0, **params: Unpack[SimulatorParams]
) -> SimulatedSeries:
    """A shop's series on ``layout`` with the hidden ``effects``: 40 cycles, noise :data:`NOISE` unless given."""
    given: SimulatorParams = {"n_cycles": 40, "noise": NOISE, **params}
    return ShopSimulator(seed=seed, **given).run(layout, tuple(effects))


def svd_seconds() -> float:
    """The reference: the best of five SVDs of a 1000 × 300 random matrix [s]."""
    a = np.random.default_rng(0).normal(size=(1000, 300))
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        np.linalg.svd(a, full_matrices=False)
        best = min(best, time.perf_counter() - t0)
    return best


# The plate's designed experiment, analysed apart from the diagnosis.
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
