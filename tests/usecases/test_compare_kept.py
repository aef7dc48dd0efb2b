"""``compare`` when the exact optimum gives dimensions up (issue 22): every f1, bound and gap is over the
dimensions it keeps, so no metaheuristic "beats" it by the margin of a dimension no correction saves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import shared_path

from setupfix.model import load_model
from setupfix.usecases.compare import CompareRequest, compare_report

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def calypso_wide(tmp_path: Path) -> tuple[Path, Path]:
    """The CALYPSO sample (Distanz Z 8mm +1.215 mm on ±0.1) with the reject band widened: a triage case."""
    report = shared_path("cmm-samples", "calypso", "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt")
    text = (ROOT / "sample_reports" / "calypso" / "model.toml").read_text()
    model = tmp_path / "model.toml"
    model.write_text(text.replace("limit = 0.1\n", "limit = 0.1\n\n[safety]\nreject_band = 5.0\n", 1))
    return model, report


@pytest.mark.slow
def test_gaps_and_bound_are_over_the_kept_dimensions(calypso_wide: tuple[Path, Path]) -> None:
    model, report = calypso_wide
    comparison = compare_report(CompareRequest(model, trials=3, seed=1), report)
    e, problem = comparison.exact, comparison.problem
    names = {d.id: d.name for d in load_model(model).dimensions}
    assert [names[d] for d in e.given_up] == ["Distanz Z 8mm"]
    kept = ~np.isin(problem.dimension_ids, e.given_up)
    assert e.status == "optimal"
    assert e.margin_after == pytest.approx(problem.margins(e.x)[kept].min(), abs=1e-12)
    assert e.margin_after > 0 and e.bound is not None and e.bound >= e.margin_after - 1e-12
    assert e.bound - e.margin_after < 0.001  # the kept dimensions' LP bound, not the all-dimension −0.915
    for m in comparison.methods:
        for r in m.results:  # each trial's f1 over the same kept dimensions; its all-dimension f1 kept apart
            assert r.margin_after == pytest.approx(problem.margins(r.x)[kept].min(), abs=1e-12)
            assert r.margin_all == pytest.approx(problem.evaluate(r.x)[0], abs=1e-12)
        assert np.all(m.gaps(e) >= -1e-12), m.optimizer  # no metaheuristic beats the exact optimum
    out = comparison.to_json()
    assert out["exact_margin"] == pytest.approx(e.margin_after, abs=1e-9)
    assert list(out["exact_given_up"]) == list(e.given_up)
    assert out["exact_given_up"][e.given_up[0]] < -1.0  # its margin, reported apart
    assert all(min(r["gaps"]) >= -1e-9 for r in out["results"])
