"""``replay`` on a stored synthetic series with a known drift.

The series is made here by a closed loop written in this file: a setup error, a known drift per
dimension and noise, corrected after every part by the least-squares centring through the model
with a rule set (gain on the grid towards zero, dead band, dead band as a share, mean of n parts,
parts between moves), the corrections logged between parts.  Then

* the replay of the rule actually used gives back the stored parts bit for bit, and its score
  equals what happened;
* a tighter rule's predicted count out of tolerance equals this file's own loop run with it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from setupfix.correction.relation import relation_matrices
from setupfix.model import load_model
from setupfix.model.safety import Rules
from setupfix.store import open_store
from setupfix.usecases.parse import parse_reports
from setupfix.usecases.replay import ReplayRequest, format_replay, replay_history, replay_json

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "sample_reports" / "guide_pins" / "model.toml"
TEMPLATE = parse_reports([ROOT / "sample_reports" / "guide_pins" / "cycle_01.csv"]).table
START = pd.Timestamp("2026-05-04T06:00:00")


def closed_loop(base: np.ndarray, rules: Rules, *, h: float = 0.001) -> tuple[np.ndarray, list[tuple[int, np.ndarray]]]:
    """This file's own loop: the parts as measured under ``rules``, and (part index, change) after each move."""
    model = load_model(MODEL)
    c = relation_matrices(model).composite
    lower = np.array([d.lower for d in model.dimensions])
    upper = np.array([d.upper for d in model.dimensions])
    mid, width = (lower + upper) / 2, upper - lower
    state = np.zeros(c.shape[0])
    since = np.ones(c.shape[0], dtype=int)
    parts, moves = [], []
    for t in range(base.shape[0]):
        y = base[t] + state @ c if np.any(state) else base[t].copy()
        parts.append(y)
        window = [base[k] + state @ c for k in range(max(0, t - rules.mean_of + 1), t)] + [y]
        mean = np.mean(window, axis=0)
        x = np.round(-((mean - mid) @ np.linalg.pinv(c)) / h) * h + 0.0
        if rules.min_parts > 1:
            x = np.where(since < rules.min_parts, 0.0, x)
        x = np.trunc(rules.gain * x / h + np.sign(x) * 1e-9) * h + 0.0
        band = rules.dead_band if rules.dead_band is not None else 2 * h
        if np.all(np.abs(x) <= band + 1e-12):
            x = np.zeros_like(x)
        if rules.dead_band_share is not None and np.all(np.abs(x @ c) <= rules.dead_band_share * width + 1e-12):
            x = np.zeros_like(x)
        if np.any(x):
            moves.append((t, x.copy()))
        since = np.where(x != 0, 1, since + 1)
        state = state + x
    return np.array(parts), moves


def drifting(n: int, seed: int) -> np.ndarray:
    """Deviations with no correction: a setup error through the model, a known drift and noise [mm]."""
    model = load_model(MODEL)
    c = relation_matrices(model).composite
    rng = np.random.default_rng(seed)
    setup = rng.uniform(-0.03, 0.03, c.shape[0]) @ c
    drift = np.linspace(-0.002, 0.003, c.shape[1])  # per part, known
    return setup[None, :] + np.arange(n)[:, None] * drift[None, :] + rng.normal(0, 0.004, (n, c.shape[1]))


def store_loop(db: Path, parts: np.ndarray, moves: list[tuple[int, np.ndarray]]) -> None:
    model = load_model(MODEL)
    registers = [r.register for r in model.registers]
    dims = [d.name for d in model.dimensions]
    with open_store(db) as store:
        for t, row in enumerate(parts):
            table = TEMPLATE.copy()
            value = dict(zip(dims, row, strict=True))
            table["deviation"] = [value[str(n)] for n in table["characteristic"]]
            table["actual"] = table["nominal"] + table["deviation"]
            table["part"] = table["report"] = f"part {t + 1:03d}"
            table["timestamp"] = (START + pd.Timedelta(hours=t)).isoformat()
            store.add_report(f"loop {t}".encode(), f"p{t}.csv", "canonical", table)
        rows = [
            ((START + pd.Timedelta(hours=t, minutes=30)).isoformat(), registers[j], float(x[j]), "correction")
            for t, x in moves
            for j in np.flatnonzero(x)
        ]
        store.add_corrections(pd.DataFrame(rows, columns=["timestamp", "register", "delta", "event"]))


def out_of_tolerance(parts: np.ndarray) -> int:
    model = load_model(MODEL)
    lower = np.array([d.lower for d in model.dimensions])
    upper = np.array([d.upper for d in model.dimensions])
    return int(((parts < lower) | (parts > upper)).sum())


USED = Rules(dead_band_share=0.1, gain=0.5, mean_of=3)


@pytest.fixture(scope="module")
def history(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[Path, np.ndarray, np.ndarray, list[tuple[int, np.ndarray]]]:
    base = drifting(80, seed=7)
    parts, moves = closed_loop(base, USED)
    db = tmp_path_factory.mktemp("replay") / "loop.db"
    store_loop(db, parts, moves)
    return db, base, parts, moves


@pytest.mark.slow
def test_the_rule_used_reproduces_the_stored_outcome_exactly(
    history: tuple[Path, np.ndarray, np.ndarray, list[tuple[int, np.ndarray]]],
) -> None:
    db, _, parts, moves = history
    assert 3 <= len(moves) < 80 and out_of_tolerance(parts) > 0  # a loop that corrects, and a drift that escapes
    outcome = replay_history(ReplayRequest(db, MODEL, USED, walk=False))
    assert len(outcome.parts) == 80
    assert np.array_equal(outcome.trace.deviation, outcome.measured, equal_nan=True)  # bit for bit
    assert outcome.replayed == outcome.actual
    assert outcome.actual.out_of_tolerance == out_of_tolerance(parts)
    assert outcome.actual.corrections == sum(t < 79 for t, _ in moves)  # those a later part shows
    doc = replay_json(outcome)
    assert doc["parts"] == 80 and doc["rules"] == {"dead_band": "10 %", "gain": 0.5, "mean_of": 3, "min_parts": 1}
    assert doc["actual"] == doc["replayed"]
    assert "assumes the model" in format_replay(outcome)


@pytest.mark.slow
@pytest.mark.parametrize(
    "tighter",
    [Rules(gain=1.0), Rules(dead_band_share=0.02, gain=0.7, mean_of=2), Rules(gain=0.5, min_parts=3)],
)
def test_a_tighter_rule_matches_an_independent_simulation(
    history: tuple[Path, np.ndarray, np.ndarray, list[tuple[int, np.ndarray]]], tighter: Rules
) -> None:
    db, base, _, _ = history
    expected, moves = closed_loop(base, tighter)
    outcome = replay_history(ReplayRequest(db, MODEL, tighter, walk=False))
    assert outcome.replayed.out_of_tolerance == out_of_tolerance(expected)
    assert outcome.replayed.corrections == sum(t < 79 for t, _ in moves)
    np.testing.assert_allclose(outcome.trace.deviation, expected, rtol=0, atol=1e-12)


@pytest.mark.slow
def test_grid_names_the_best_under_the_stated_criterion(
    history: tuple[Path, np.ndarray, np.ndarray, list[tuple[int, np.ndarray]]],
) -> None:
    db = history[0]
    grid = ((None, 0.1), (0.5, 1.0), (1, 3))
    outcome = replay_history(ReplayRequest(db, MODEL, USED, grid=True, grid_values=grid, walk=False))
    assert len(outcome.grid) == 8 and outcome.best is not None
    ranks = [(g.score.out_of_tolerance, g.score.parts_at_risk, g.score.corrections) for g in outcome.grid]
    assert ranks[outcome.best] == min(ranks)
    doc = replay_json(outcome)
    assert doc["best"] == outcome.grid[outcome.best].rules.to_json() and "fewest" in doc["criterion"]
