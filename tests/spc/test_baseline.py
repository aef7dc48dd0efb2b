"""The baseline check: splits inside the baseline, its own rule breaks, the first stable window (brute force)."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from spc_examples import closed_loop_store

from setupfix.spc import MAX_WINDOWS, MIN_PARTS, baseline_check, capability, chart_limits, first_stable_window, nelson
from setupfix.store import open_store
from setupfix.usecases.spc_report import SpcRequest, format_spc, spc_json, spc_report


def _brute_first_stable(x: np.ndarray, size: int, splits: list[int]) -> int | None:
    """Every start in turn: no split strictly inside, no Nelson rule on the window's own limits."""
    for s in range(0, len(x) - size + 1):
        if any(s < a < s + size for a in splits):
            continue
        w = x[s : s + size]
        lim = chart_limits(w, size)
        if not nelson(w, lim.center, lim.sigma):
            return s
    return None


@pytest.mark.parametrize("seed", range(40))
def test_first_stable_window_equals_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(10, 120))
    x = np.cumsum(rng.normal(0, 1, n)) * rng.choice([0.0, 0.3, 1.0]) + rng.normal(0, 1, n)
    x[rng.integers(0, n, int(rng.integers(0, 4)))] += 8.0  # outliers: rule 1
    size = int(rng.integers(3, 25))
    splits = sorted({int(a) for a in rng.integers(1, n, int(rng.integers(0, 6)))})
    start, tried = first_stable_window(x, size, splits)
    assert start == _brute_first_stable(x, size, splits)
    assert tried <= MAX_WINDOWS
    check = baseline_check(x, size, splits)
    assert check.splits_inside == tuple(a for a in splits if 0 < a < min(size, n))
    lim = chart_limits(x[:size], size)
    assert check.violations == tuple(nelson(x[: min(size, n)], lim.center, lim.sigma))
    assert check.first_stable == (0 if check.stable else start)
    edges = [0, *splits, n]
    assert check.longest_free == max(b - a for a, b in itertools.pairwise(edges))


def test_too_few_parts_below_the_stated_number() -> None:
    x = np.linspace(-0.01, 0.01, MIN_PARTS)
    assert not capability(x, -0.1, 0.1).too_few
    assert capability(x[:-1], -0.1, 0.1).too_few


def test_closed_loop_baseline_spans_three_corrections_and_breaks_rule_1(tmp_path: Path) -> None:
    """The issue's case: a 20-part baseline across three corrections that itself breaks rule 1."""
    with open_store(closed_loop_store(tmp_path)) as store:
        outcome = spc_report(store, SpcRequest(dimensions=("P1 D1",)))
        short = spc_report(store, SpcRequest(dimensions=("P1 D1",), baseline=5))
    d = outcome.dimensions[0]
    assert d.baseline is not None and not d.baseline.stable
    assert d.baseline.splits_inside == (6, 11, 16)  # corrections before cycles 7, 12 and 17
    assert 1 in {v.rule for v in d.baseline.violations}
    assert d.baseline.first_stable is None and d.baseline.longest_free < 20
    warning = next(str(n) for n in outcome.notes if "baseline" in str(n))
    assert "spans 3 correction(s)" in warning and "rule 1" in warning and "no stable window of 20" in warning
    doc = spc_json(outcome)
    check = doc["dimensions"][0]["baseline_check"]
    assert [s["part"] for s in check["splits_inside"]] == ["cycle 007", "cycle 012", "cycle 017"]
    assert check["stable"] is False and check["first_stable_window"] is None
    assert doc["min_parts"] == MIN_PARTS and "Bissell" in doc["cpk_interval"]
    # every violation in the JSON, none cut off
    assert len(doc["dimensions"][0]["violations"]) == len(d.violations)
    effects = doc["dimensions"][0]["split_effects"]
    assert effects and all(e["after"]["too_few_parts"] for e in effects)
    assert "too few" in format_spc(outcome) and "[" in format_spc(outcome).splitlines()[-3]
    # a shorter baseline: the first window of five parts between corrections that breaks no rule is offered
    s = short.dimensions[0].baseline
    assert s is not None
    x = short.dimensions[0].values
    expected = _brute_first_stable(x, 5, list(s.splits_inside) + [a.at for a in short.dimensions[0].splits])
    assert s.first_stable == (0 if s.stable else expected)
    json.dumps(doc)
