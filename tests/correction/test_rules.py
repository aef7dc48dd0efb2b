"""Rules as a share of the tolerance (issue 40): dead band in %, gain, mean of n, parts between moves.

Each rule through the one use case (``correct_cycle``) on small models, and its pure pieces
against independent computations.
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any

import numpy as np
import pytest

from setupfix.correction.rules import (
    apply_rules,
    mean_of_parts,
    parts_since_change,
    register_share_bands,
    share_bands,
    within_share_band,
)
from setupfix.inputs.smoothing import History
from setupfix.model import PartMeasurement, ProcessModel, model_from_dict
from setupfix.model.safety import Rules
from setupfix.usecases.correct import correct_cycle
from setupfix.usecases.requests import CorrectRequest, CycleCorrection

BASE: dict[str, Any] = {
    "process": {"name": "p", "resolution": 0.001, "limit": 0.1},
    "wks": {"W1": {"register": "G54"}},
    "features": {"F1": {"wks": {"W1": 1}}},
    "dimensions": {"D1": {"features": {"F1": 1}, "nominal": 40.0, "lower": -0.25, "upper": 0.25}},
}


def model(safety: dict[str, Any] | None = None, w1: dict[str, Any] | None = None, **extra: Any) -> ProcessModel:
    d = copy.deepcopy(BASE)
    if safety:
        d["safety"] = safety
    if w1:
        d["wks"]["W1"].update(w1)
    d.update(extra)
    return model_from_dict(d)


def part(dev: float, when: str | None = None, name: str = "p") -> PartMeasurement:
    return PartMeasurement(part=name, report="r", timestamp=when, deviation=np.array([dev]), sources=("",))


def run(m: ProcessModel, p: PartMeasurement, history: History | None = None) -> CycleCorrection:
    return correct_cycle(CorrectRequest(m, history=history), p)


def rules_of(c: CycleCorrection) -> list[str]:
    return [r.rule for r in c.recommendation.rules]


def test_dead_band_of_ten_percent_holds_a_dimension_at_two_percent() -> None:
    # the issue: a dimension at 2 % of its tolerance width (0.010 of 0.5) moved G54 by -0.010
    before = run(model(), part(0.010))
    assert before.recommendation.verdict == "apply" and before.corrections["W1"] == pytest.approx(-0.010)
    c = run(model({"dead_band": "10 %"}), part(0.010))
    assert c.recommendation.verdict == "hold" and c.corrections["W1"] == 0.0
    assert "dead_band" in rules_of(c)
    moved = run(model({"dead_band": "10 %"}), part(0.060))  # 12 % of the width: beyond the band
    assert moved.recommendation.verdict == "apply" and moved.corrections["W1"] == pytest.approx(-0.060)


def test_register_dead_band_as_a_share() -> None:
    held = run(model(w1={"dead_band": "10 %"}), part(0.010))
    assert held.recommendation.verdict == "hold" and "dead_band" in rules_of(held)
    assert run(model(w1={"dead_band": "1 %"}), part(0.010)).recommendation.verdict == "apply"


def test_gain_applies_a_fraction_rounded_towards_zero() -> None:
    c = run(model({"gain": 0.5}), part(0.011))
    assert c.corrections["W1"] == pytest.approx(-0.005) and "gain" in rules_of(c)


def stamp(hour: int) -> str:
    return f"2026-01-01T{hour:02d}:00:00"


def history(m: ProcessModel, devs: list[float], log: tuple[tuple[int, float], ...] = ()) -> History:
    h = History.empty(m).with_parts([part(d, stamp(i + 1), f"p{i}") for i, d in enumerate(devs)])
    if not log:
        return h
    return dataclasses.replace(
        h,
        log_times=np.array([np.datetime64(stamp(t), "ns") for t, _ in log]),
        log_register=np.zeros(len(log), dtype=np.int64),
        log_delta=np.array([d for _, d in log]),
        log_reset=np.zeros(len(log), dtype=bool),
    )


def test_mean_of_three_parts() -> None:
    m = model({"mean_of": 3})
    c = run(m, part(0.020, stamp(9)), history(m, [0.090, 0.030, 0.010]))  # the last two count
    assert c.corrections["W1"] == pytest.approx(-(0.030 + 0.010 + 0.020) / 3, abs=0.0005)
    assert any("mean of this part and the 2 part(s)" in r.message for r in c.recommendation.rules)


def test_mean_moves_earlier_parts_by_the_corrections_since() -> None:
    m = model({"mean_of": 2})
    # part at 1 h measured +0.050; W1 moved by -0.050 at 2 h: as the machine is now, that part is 0.000
    c = run(m, part(0.020, stamp(9)), history(m, [0.050], ((2, -0.050),)))
    assert c.corrections["W1"] == pytest.approx(-0.010)


def test_mean_of_without_a_store_says_so() -> None:
    c = run(model({"mean_of": 3}), part(0.020, stamp(9)))
    assert c.corrections["W1"] == pytest.approx(-0.020)
    assert any("mean_of = 3 needs the history store" in n.message for n in c.notes)


def test_min_parts_holds_a_register_changed_too_recently() -> None:
    m = model({"min_parts": 3})
    recent = history(m, [0.04, 0.03], ((2, -0.01),))  # W1 changed at 2 h: parts at 1 h, 2 h before it
    c = run(m, part(0.030, stamp(9)), recent)
    assert c.corrections["W1"] == 0.0 and "min_parts" in rules_of(c)
    settled = history(m, [0.04, 0.03], ((0, -0.01),))  # changed before both parts: 3 parts with this one
    assert run(m, part(0.030, stamp(9)), settled).corrections["W1"] == pytest.approx(-0.030)


def test_no_conformance_zone_centres_and_says_so() -> None:
    # MPE 300 + L/1 µm leaves D1 (±0.25) no conformance zone: centred on its mid-tolerance, rule named
    m = model(measurement={"mpe": [300.0, 1.0]})
    c = run(m, part(0.080))
    assert "no_conformance_zone" in rules_of(c)
    assert c.corrections["W1"] == pytest.approx(-0.080)


# ---- the pure pieces against independent computations ----


def test_share_bands_and_within() -> None:
    lo, up = np.array([-0.1, 0.0, -np.inf, 0.0]), np.array([0.1, 0.05, 0.2, 0.03])
    zone = np.array([False, False, False, True])
    band = share_bands(lo, up, 0.1, zone)
    assert band.tolist() == pytest.approx([0.02, 0.005, 0.0, 0.006])
    assert within_share_band(np.array([0.02, -0.005, 0.0, 0.0]), band)
    assert not within_share_band(np.array([0.0, 0.0, 1e-6, 0.0]), band)  # one-sided: never held by a share
    assert share_bands(lo, up, None).tolist() == [0.0] * 4


def test_register_share_bands_brute_force() -> None:
    rng = np.random.default_rng(3)
    for _ in range(50):
        c = rng.choice([0.0, 1.0, -1.0, 2.0], size=(3, 4))
        width = rng.uniform(0.01, 0.5, size=4)
        share = rng.uniform(0.01, 0.5, size=3)
        got = register_share_bands(c, width, share)
        for j in range(3):
            reach = [width[q] / abs(c[j, q]) for q in range(4) if c[j, q] != 0]
            assert got[j] == pytest.approx(share[j] * min(reach) if reach else 0.0)


def test_parts_since_change_brute_force() -> None:
    rng = np.random.default_rng(11)
    for _ in range(30):
        times = (
            np.sort(rng.choice(np.arange(100), size=12, replace=False)).astype("datetime64[h]").astype("datetime64[ns]")
        )
        log_t = rng.choice(np.arange(100), size=5).astype("datetime64[h]").astype("datetime64[ns]")
        log_r = rng.integers(-1, 3, size=5)
        now = np.datetime64(int(rng.integers(20, 100)), "h").astype("datetime64[ns]")
        got = parts_since_change(now, times, log_t, log_r, 3)
        for j in range(3):
            changes = [t for t, r in zip(log_t, log_r, strict=True) if r == j and t <= now]
            last = max(changes) if changes else None
            want = sum(1 for t in times if t < now and (last is None or t > last)) + 1
            assert got[j] == want


def test_mean_of_parts_independent() -> None:
    dev = np.array([0.01, np.nan, 0.03])
    earlier = np.array([[0.05, 0.1, np.nan], [0.02, 0.2, 0.01], [0.00, 0.3, 0.02]])
    mean, used = mean_of_parts(dev, earlier, 3)
    assert used == 2
    assert mean[0] == pytest.approx((0.02 + 0.00 + 0.01) / 3)
    assert np.isnan(mean[1])  # not measured now: never averaged in
    assert mean[2] == pytest.approx((0.01 + 0.02 + 0.03) / 3)
    same, none = mean_of_parts(dev, earlier, 1)
    assert none == 0 and np.array_equal(same, dev, equal_nan=True)


def test_apply_rules_order_and_reasons() -> None:
    c = np.array([[1.0, 0.0], [0.0, 1.0]])
    lo, up = np.array([-0.25, -0.05]), np.array([0.25, 0.05])
    x = np.array([-0.010, 0.0])
    assert apply_rules(x, c, lo, up, 0.001, Rules()).x.tolist() == pytest.approx([-0.010, 0.0])
    assert apply_rules(x, c, lo, up, 0.001, Rules(dead_band_share=0.1)).held_by == "dead_band_share"
    assert apply_rules(x, c, lo, up, 0.001, Rules(dead_band=0.02)).held_by == "dead_band"
    g = apply_rules(np.array([-0.011, 0.007]), c, lo, up, 0.001, Rules(gain=0.5))
    assert g.x.tolist() == pytest.approx([-0.005, 0.003]) and g.gained
    # min parts: the first register waited too few parts, the second moves alone
    m = apply_rules(np.array([-0.011, 0.007]), c, lo, up, 0.001, Rules(min_parts=3), np.array([2, 5]))
    assert m.x.tolist() == pytest.approx([0.0, 0.007]) and m.held_by == ""
    held = apply_rules(np.array([-0.011, 0.0]), c, lo, up, 0.001, Rules(min_parts=3), np.array([2, 5]))
    assert held.held_by == "min_parts" and not held.x.any()
