"""Published worked examples the SPC tests check against (numbers only), and the samples they use."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GUIDE_PINS = ROOT / "sample_reports" / "guide_pins"
CLOSED_LOOP = ROOT / "sample_reports" / "closed_loop"

#: Montgomery & Runger, Applied Statistics and Probability for Engineers, Table 16-3 (chemical process
#: concentration, 20 individual measurements); published x̄ = 99.1, MR̄ = 2.59, UCL 105.99, LCL 92.21.
CONCENTRATION = [
    102.0,
    94.8,
    98.3,
    98.4,
    102.0,
    98.5,
    99.0,
    97.7,
    100.0,
    98.1,
    101.3,
    98.7,
    101.1,
    98.4,
    97.0,
    96.7,
    100.3,
    101.4,
    97.2,
    101.0,
]


def closed_loop_store(folder: Path) -> Path:
    """A history store of the closed-loop sample (40 cycles of the guide pins, its corrections log)."""
    from setupfix.store import open_store
    from setupfix.usecases.history import ImportRequest, import_history

    db = folder / "loop.db"
    with open_store(db) as store:
        import_history(
            store,
            ImportRequest(reports=(CLOSED_LOOP / "measurements.csv",), corrections=(CLOSED_LOOP / "corrections.csv",)),
        )
    return db


#: SAS/QC User's Guide, PROC CAPABILITY, "Displaying a Confidence Interval for Cpk": amplification of 75
#: telephone amplifiers (dB), LSL 4, USL 6; published Cpk (sample standard deviation) with Bissell's 90 %
#: interval 0.328 to 0.496.
AMPS = [
    4.54,
    4.87,
    4.66,
    4.90,
    4.68,
    5.22,
    4.43,
    5.14,
    3.07,
    4.22,
    5.09,
    3.41,
    5.75,
    5.16,
    3.96,
    5.37,
    5.70,
    4.11,
    4.83,
    4.51,
    4.57,
    4.16,
    5.73,
    3.64,
    5.48,
    4.95,
    4.57,
    4.46,
    4.75,
    5.38,
    5.19,
    4.35,
    4.98,
    4.87,
    3.53,
    4.46,
    4.57,
    4.69,
    5.27,
    4.67,
    5.03,
    4.50,
    5.35,
    4.55,
    4.05,
    6.63,
    5.32,
    5.24,
    5.73,
    5.08,
    5.07,
    5.42,
    5.05,
    5.70,
    4.79,
    4.34,
    5.06,
    4.64,
    4.82,
    3.24,
    4.79,
    4.46,
    3.84,
    5.05,
    5.46,
    4.64,
    6.13,
    4.31,
    4.81,
    4.98,
    4.95,
    5.57,
    4.11,
    4.15,
    5.95,
]
