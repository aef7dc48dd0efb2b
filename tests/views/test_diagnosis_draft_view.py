"""Issue 37 item 2 in the TUI's history panel: a draft model's diagnosis view carries no next correction as a
number or as "none", but the draft sentence the CLI prints (:func:`setupfix.views.analysis.draft_next`)."""

from __future__ import annotations

from pathlib import Path

from setupfix.model import load_model
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports
from setupfix.views.analysis import diagnosis_view, draft_next

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
REPORTS = tuple(GUIDE / f"cycle_0{i}.csv" for i in range(2, 6))


def test_a_draft_models_view_says_the_draft_and_gives_no_number(tmp_path: Path) -> None:
    text = (GUIDE / "model.toml").read_text()
    draft = tmp_path / "draft.toml"
    draft.write_text(text.replace("[process]\n", "[process]\ndraft = true\n", 1))
    view = diagnosis_view(diagnose_reports(DiagnoseRequest(load_model(draft), REPORTS)))
    assert view.draft is not None and view.draft.startswith("no correction, the model is a draft")
    assert "none" not in view.draft and not any(ch.isdigit() for ch in view.draft.split("—")[0])


def test_a_released_models_view_has_no_draft_sentence() -> None:
    outcome = diagnose_reports(DiagnoseRequest(load_model(GUIDE / "model.toml"), REPORTS))
    assert draft_next(outcome) is None and diagnosis_view(outcome).draft is None


def test_the_views_next_correction_names_the_controller_registers() -> None:
    """Issue 41: the history panel gives the next correction as the operator types it (G54 Z, H5), not model IDs."""
    model = load_model(GUIDE / "model.toml")
    view = diagnosis_view(diagnose_reports(DiagnoseRequest(model, REPORTS)))
    by_id = {r.id: r for r in model.registers}
    assert view.next_correction, "the sample's series moves some register"
    axis = {k: f" {model.axis}" if r.kind == "wks" else "" for k, r in by_id.items()}
    expected = [f"{by_id[k].register}{axis[k]} {v:+.4f}" for k, v in view.next_correction]
    assert view.next_text == ", ".join(expected)
    assert not any(k in view.next_text.split() for k in by_id if k != by_id[k].register)
