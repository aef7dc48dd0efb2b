"""The guide-pins cycle 1 in QIF and DMIS reads back exactly as the canonical CSV, and the
checked-in files are what ``write_formats.py`` writes."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import parsers

GUIDE = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"


@pytest.mark.parametrize("suffix", ["qif", "dmo"])
def test_real_format_matches_the_csv(suffix: str) -> None:
    ref = parsers.read_report(GUIDE / "cycle_01.csv").table
    table = parsers.read_report(GUIDE / f"cycle_01.{suffix}").table
    assert parsers.find_format(GUIDE / f"cycle_01.{suffix}").name == {"qif": "qif", "dmo": "dmis"}[suffix]
    for column in ("characteristic", "part", "station", "timestamp"):
        assert table[column].tolist() == ref[column].tolist(), column
    for column in ("nominal", "actual", "deviation", "lower", "upper"):
        assert np.allclose(table[column], ref[column], rtol=0, atol=1e-12), column
    assert (table["unit"] == "mm").all()


def test_checked_in_files_are_the_script_output(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("write_formats", GUIDE / "write_formats.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    rows = module._rows(GUIDE / "cycle_01.csv")
    module.write_qif(rows, tmp_path / "cycle_01.qif")
    module.write_dmo(rows, tmp_path / "cycle_01.dmo")
    for name in ("cycle_01.qif", "cycle_01.dmo"):
        assert (tmp_path / name).read_bytes() == (GUIDE / name).read_bytes(), name
