"""A wrong relation: named when the registers' step histories differ, shared when they moved together."""

from __future__ import annotations

import numpy as np
import pytest

from bench.diagnosis import NOISE, guide_pins
from setupfix.diagnose import Diagnoser, Layout, Series, walk_forward
from setupfix.diagnose.forecast import relation_composite
from setupfix.model.effects import EffectsSection
from setupfix.usecases.diagnosis import augmented_section

N = 40


def _series(layout: Layout, applied: np.ndarray, register: str, weight: float, seed: int) -> Series:
    """Closed-loop form y = (s + u) · C' + e with C' = C + weight at (register, first dimension)."""
    rng = np.random.default_rng(seed)
    C = layout.composite.copy()
    C[layout.register_ids.index(register), 0] += weight
    setup = rng.uniform(-0.03, 0.03, C.shape[0])
    dev = (setup + applied) @ C + rng.normal(0, NOISE, (N, C.shape[1]))
    return Series(dev, np.arange(N) / 3.0, applied, np.zeros((N, layout.tools.size)), np.zeros((N, 0)))


def _steps(n_registers: int, seed: int) -> np.ndarray:
    """Corrections in effect: every 5 cycles each register takes its own random step."""
    rng = np.random.default_rng(seed)
    steps = np.zeros((N, n_registers))
    steps[5::5] = rng.choice([-1.0, 1.0], (len(range(5, N, 5)), n_registers)) * rng.uniform(
        0.005, 0.02, (len(range(5, N, 5)), n_registers)
    )
    return np.cumsum(steps, axis=0)


def _free_registers(layout: Layout) -> list[str]:
    """Registers the first dimension does not answer in the model (a missing relation to hide)."""
    return [layout.register_ids[i] for i in np.flatnonzero(layout.composite[:, 0] == 0)]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_distinguishable_histories_name_the_register(seed: int) -> None:
    layout = Layout.from_model(guide_pins())
    reg = _free_registers(layout)[1]
    applied = _steps(layout.n_registers, seed)
    d = Diagnoser(walk=False).run(layout, _series(layout, applied, reg, 0.5, seed))
    assert [(e.kind, e.target) for e in d.effects] == [("relation", f"{layout.dimension_ids[0]} ~ {reg}")]
    e = d.effects[0]
    assert e.registers == (reg,) and e.alike == ()
    assert e.estimate == pytest.approx(0.5, abs=4 * e.stderr)
    # a named relation changes the matrix the next correction is mapped through, at its place only
    delta = d.relation_matrix() - layout.composite
    assert np.flatnonzero(delta).tolist() == [layout.register_ids.index(reg) * layout.n_dimensions]
    # and so does the augmented model file, for `correct`
    np.testing.assert_allclose(
        relation_composite(augmented_section(d, EffectsSection()), layout),
        d.relation_matrix(),
        atol=1e-5 * abs(e.estimate),
    )


@pytest.mark.slow
def test_registers_that_moved_together_are_named_together_and_not_guessed() -> None:
    layout = Layout.from_model(guide_pins())
    a, b = _free_registers(layout)[1:3]
    ia, ib = layout.register_ids.index(a), layout.register_ids.index(b)
    applied = _steps(layout.n_registers, 5)
    applied[:, ib] = applied[:, ia]  # b was always moved with a, by the same amount
    for hidden in (a, b):  # whichever is wrong, the report is the same set
        d = Diagnoser(walk=False).run(layout, _series(layout, applied, hidden, 0.5, 5))
        assert [e.kind for e in d.effects] == ["relation"]
        e = d.effects[0]
        assert e.target.startswith(f"{layout.dimension_ids[0]} ~ ")
        assert {a, b} <= set(e.registers)
        # the data cannot split it: no register other than the ones moved like a is named
        others = set(e.registers) - {a, b}
        assert not others, others
        # and the correction matrix is left as declared: putting the weight on one would be a guess
        np.testing.assert_array_equal(d.relation_matrix(), layout.composite)
        assert any(f"{a} and {b} always moved together" in n for n in d.notes)
        # the augmented model file keeps the set, and `correct` then leaves the weight out
        section = augmented_section(d, EffectsSection())
        (eff,) = section.effects
        assert set(eff.registers) == set(e.registers) and "one of" in eff.target
        np.testing.assert_array_equal(relation_composite(section, layout), layout.composite)


@pytest.mark.slow
def test_a_named_relation_is_used_by_the_augmented_walk(monkeypatch: pytest.MonkeyPatch) -> None:
    """The augmented controller maps its recommendation through the relation found: it does better."""
    layout = Layout.from_model(guide_pins())
    reg = _free_registers(layout)[1]
    applied = _steps(layout.n_registers, 3)
    series = _series(layout, applied, reg, 1.0, 3)
    C_true = layout.composite.copy()
    C_true[layout.register_ids.index(reg), 0] += 1.0
    walk = walk_forward(layout, series, score_composite=C_true)
    b = walk.budgets
    assert b["augmented"].rms < min(b["declared"].rms, b["ewma"].rms)
    assert b["augmented"].mean_budget > max(b["declared"].mean_budget, b["ewma"].mean_budget)
    # the gain is the relation's: mapped through the declared matrix the same fit does worse than declared
    monkeypatch.setattr("setupfix.diagnose.walk.RELATION_T", np.inf)
    blind = walk_forward(layout, series, score_composite=C_true).budgets
    assert blind["augmented"].mean_budget < b["augmented"].mean_budget
