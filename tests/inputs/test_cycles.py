"""Fixture cycles: consecutive parts of a long report grouped into loads, stations per position."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from conftest import GUIDE_PINS

from setupfix.core.errors import MatchError
from setupfix.inputs.cycles import cycle_name, load_parts, model_groups
from setupfix.model import ProcessModel
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleOptions


def long_report(
    tmp_path: Path,
    cycles: Sequence[int] = (1, 2, 3),
    station_order: Sequence[str] = ("P1", "P2", "P3", "P4"),
    extra: Sequence[Sequence[str]] = (),
) -> Path:
    """One part per workpiece (A1, A2, …), no station column: as a CMM writes a long run."""
    out = tmp_path / "long.csv"
    n = 0
    with open(out, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["characteristic", "nominal", "actual", "deviation", "lower", "upper", "part"])
        for c in cycles:
            with open(GUIDE_PINS / f"cycle_{c:02d}.csv", newline="", encoding="utf-8") as src:
                rows = list(csv.DictReader(src))
            for station in station_order:
                n += 1
                for r in rows:
                    if r["station"] == station:
                        name = r["characteristic"].split(" ", 1)[1]  # "D4": the station is the position
                        writer.writerow(
                            [name, r["nominal"], r["actual"], r["deviation"], r["lower"], r["upper"], f"A{n}"]
                        )
        for row in extra:
            writer.writerow(row)
    return out


@pytest.fixture
def short_names(guide_pins_model: ProcessModel) -> ProcessModel:
    """The guide-pins model with the station-less names the long report uses (aliases "D1" … "D7")."""
    from dataclasses import replace

    dims = tuple(replace(d, aliases=(d.name.split(" ")[1],)) for d in guide_pins_model.dimensions)
    return replace(guide_pins_model, dimensions=dims)


def test_parts_per_cycle_groups_loads_named_by_their_parts(tmp_path: Path, short_names: ProcessModel) -> None:
    path = long_report(tmp_path)
    parts = load_parts(short_names, path, parts_per_cycle=4)
    assert [p.part for p in parts] == ["A1+A2+A3+A4", "A5+A6+A7+A8", "A9+A10+A11+A12"]
    for c, part in enumerate(parts, start=1):
        (ref,) = load_parts(short_names, GUIDE_PINS / f"cycle_{c:02d}.csv")
        np.testing.assert_allclose(part.deviation, ref.deviation, atol=1e-12)
    results = correct_report(CorrectRequest(short_names, cycles=CycleOptions(parts_per_cycle=4)), path).cycles
    (ref_cycle,) = correct_report(CorrectRequest(short_names), GUIDE_PINS / "cycle_02.csv").cycles
    assert results[1].corrections == pytest.approx(ref_cycle.corrections)


def test_parts_per_cycle_with_stations_in_load_order(tmp_path: Path, short_names: ProcessModel) -> None:
    path = long_report(tmp_path, cycles=(1,), station_order=("P2", "P1", "P4", "P3"))
    (part,) = load_parts(short_names, path, parts_per_cycle=4, stations=["P2", "P1", "P4", "P3"])
    (ref,) = load_parts(short_names, GUIDE_PINS / "cycle_01.csv")
    np.testing.assert_allclose(part.deviation, ref.deviation, atol=1e-12)
    # positions taken as the model's groups in order would mix the stations up: different deviations
    (wrong,) = load_parts(short_names, path, parts_per_cycle=4)
    assert not np.allclose(wrong.deviation, ref.deviation)


def test_subset_of_stations_per_load_and_incomplete_last_load(tmp_path: Path, short_names: ProcessModel) -> None:
    path = long_report(tmp_path, cycles=(1, 2), station_order=("P1", "P2"))
    parts = load_parts(short_names, path, parts_per_cycle=2, stations=["P1", "P2"])
    assert [p.part for p in parts] == ["A1+A2", "A3+A4"]
    assert all(p.measured.sum() == 14 for p in parts)
    assert any("does not measure" in str(n) and "stations P3, P4" in str(n) for n in parts[0].notes)
    three = long_report(tmp_path, cycles=(1,), station_order=("P1", "P2", "P3"))
    parts = load_parts(short_names, three, parts_per_cycle=2, stations=["P1", "P2"])
    assert [p.part for p in parts] == ["A1+A2", "A3"]
    assert any("the last cycle A3 holds 1 of 2 parts" in str(n) for n in parts[-1].notes)


def test_part_measured_twice_keeps_the_later_measurement(tmp_path: Path, short_names: ProcessModel) -> None:
    path = long_report(tmp_path, cycles=(1,), extra=[["D4", "30.0", "30.0500", "0.0500", "-0.1", "0.1", "A2"]])
    (part,) = load_parts(short_names, path, parts_per_cycle=4)
    i = [d.id for d in short_names.dimensions].index("P2D4")
    assert part.deviation[i] == pytest.approx(0.05)
    (note,) = [str(n) for n in part.notes if "measured twice" in str(n)]
    assert "P2D4 (D4)" in note and "the later measurement here is used" in note


def test_refusals(tmp_path: Path, short_names: ProcessModel) -> None:
    path = long_report(tmp_path, cycles=(1,))
    with pytest.raises(MatchError, match="cannot tell the stations of 3 parts per cycle: the model has 4 groups"):
        load_parts(short_names, path, parts_per_cycle=3)
    with pytest.raises(MatchError, match="2 stations given for cycles of 4 parts"):
        load_parts(short_names, path, parts_per_cycle=4, stations=["P1", "P2"])
    with pytest.raises(MatchError, match="station 'P9'"):
        load_parts(short_names, path, parts_per_cycle=2, stations=["P1", "P9"])
    with pytest.raises(MatchError, match="names several dimensions"):
        load_parts(short_names, path)


def test_helpers(guide_pins_model: ProcessModel) -> None:
    assert model_groups(guide_pins_model) == ["P1", "P2", "P3", "P4"]
    assert cycle_name(["A7", "A8"]) == "A7+A8" and cycle_name([""]) == "(report)"


def test_cli_parts_per_cycle_json_and_station_column(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from setupfix.cli import main

    path = tmp_path / "full.csv"
    lines = (GUIDE_PINS / "cycle_01.csv").read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    col, st = header.index("part"), header.index("station")
    out = [",".join(h for k, h in enumerate(header) if k != st)]
    for line in lines[1:]:
        cells = line.split(",")
        cells[col] = "A" + cells[st][1:]  # one part per workpiece: A1 … A4, no station column
        out.append(",".join(c for k, c in enumerate(cells) if k != st))
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    assert main(["correct", "--model", str(GUIDE_PINS / "model.toml"), "--json", str(path)]) == 0
    assert len(json.loads(capsys.readouterr().out)["parts"]) == 4
    assert (
        main(["correct", "--model", str(GUIDE_PINS / "model.toml"), "--parts-per-cycle", "4", "--json", str(path)]) == 0
    )
    obj = json.loads(capsys.readouterr().out)
    assert obj["part"] == "A1+A2+A3+A4" and obj["dimensions"][7]["station"] == "P2"
    assert main(["correct", "--model", str(GUIDE_PINS / "model.toml"), "--parts-per-cycle", "0", str(path)]) == 2
    assert "must be in [1, 10000]" in capsys.readouterr().err
