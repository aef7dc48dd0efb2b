"""Published worked examples the SPC tests check against (numbers only), and the samples they use."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GUIDE_PINS = ROOT / "sample_reports" / "guide_pins"
CLOSED_LOOP = ROOT / "sample_reports" / "closed_loop"

#: Montgomery & Runger, Applied Statistics and Probability for Engineers, Table 16-3 (chemical process
#: concentration, 20 individual measurements); published x̄ = 99.1, MR̄ = 2.59, UCL 105.99, LCL 92.21.
CONCENTRATION = [102.0, 94.8, 98.3, 98.4, 102.0, 98.5, 99.0, 97.7, 100.0, 98.1,
                 101.3, 98.7, 101.1, 98.4, 97.0, 96.7, 100.3, 101.4, 97.2, 101.0]


def closed_loop_store(folder: Path) -> Path:
    """A history store of the closed-loop sample (40 cycles of the guide pins, its corrections log)."""
    from setupfix.pipeline.history import ImportRequest, import_history
    from setupfix.store import open_store

    db = folder / "loop.db"
    with open_store(db) as store:
        import_history(store, ImportRequest(reports=(CLOSED_LOOP / "measurements.csv",),
                                            corrections=(CLOSED_LOOP / "corrections.csv",)))
    return db
