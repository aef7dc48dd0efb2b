"""Station templates: declared once, expanded to exactly the model written table by table."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import GUIDE_PINS

from setupfix.core.errors import ModelError
from setupfix.correction.relation import relation_matrices
from setupfix.model import load_model, model_from_dict

EXPANDED = Path(__file__).parent / "data" / "guide_pins_expanded.toml"


def test_guide_pins_template_equals_the_expanded_model() -> None:
    templated = load_model(GUIDE_PINS / "model.toml")
    expanded = load_model(EXPANDED)
    assert replace(templated, source="") == replace(expanded, source="")
    a, b = relation_matrices(templated), relation_matrices(expanded)
    for name in ("R_MW", "R_WF", "R_TF", "R_FD", "composite"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert (a.registers, a.features, a.dimensions) == (b.registers, b.features, b.dimensions)


def test_generator_writes_both_forms() -> None:
    import importlib.util

    spec = importlib.util.spec_from_file_location("generate", GUIDE_PINS / "generate.py")
    assert spec and spec.loader
    generate = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generate)
    assert generate.model_toml() == (GUIDE_PINS / "model.toml").read_text(encoding="utf-8")
    assert generate.expanded_model_toml() == EXPANDED.read_text(encoding="utf-8")


def doc(**changes: object) -> dict[str, Any]:
    base: dict[str, Any] = {
        "process": {"name": "t"},
        "wks": {"W1": {}, "W2": {}, "W3": {}},
        "tools": {"T1": {}},
        "stations": {"A": {"wks": {"own": "W1"}}, "B": {"wks": {"own": "W2"}}},
        "template": {
            "features": {"F1": {"wks": {"own": 1}, "tools": {"T1": 1}}, "F2": {"wks": {"W3": 1}}},
            "dimensions": {
                "D1": {
                    "name": "{station}-D1",
                    "aliases": ["D1"],
                    "features": {"F1": 1, "F2": -1},
                    "nominal": 5,
                    "lower": -0.1,
                    "upper": 0.1,
                }
            },
        },
    }
    for key, value in changes.items():
        section, _, rest = key.partition("__")
        target = base[section]
        *path, last = rest.split("__")
        for p in path:
            target = target[p]
        if value is None:
            del target[last]
        else:
            target[last] = value
    return base


def test_expansion_names_groups_shared_and_mapped_registers() -> None:
    model = model_from_dict(doc())
    assert [f.id for f in model.features] == ["AF1", "AF2", "BF1", "BF2"]
    assert model.features[2].wks == {"W2": 1.0} and model.features[3].wks == {"W3": 1.0}
    d = model.dimensions[1]
    # the alias as written ("D1") too: a per-part report of station B names it so (issue 23)
    assert (d.id, d.name, d.aliases, d.group, d.features) == (
        "BD1",
        "B-D1",
        ("B D1", "D1"),
        "B",
        {"BF1": 1.0, "BF2": -1.0},
    )


def problems(document: dict[str, Any]) -> list[str]:
    with pytest.raises(ModelError) as info:
        model_from_dict(document, "m.toml")
    return str(info.value).splitlines()


@pytest.mark.parametrize(
    ("changes", "key", "words"),
    [
        ({"stations__B__wks": {}}, "template.features.F1.wks.own", "mapped by station(s) B"),
        ({"stations__B__wks__spare": "W3"}, "stations.B.wks.spare", "used by no template feature"),
        ({"stations__B__wks__own": "W9"}, "template.features.F1.wks.W9", "unknown WKS 'W9'"),
        ({"template__dimensions__D1__group": "X"}, "template.dimensions.D1.group", "remove the key"),
        ({"template__dimensions__D1__lower": 0.2}, "template.dimensions.D1.lower", "must be below upper"),
        ({"template__features__F1__depth": 1}, "template.features.F1.depth", "unknown key"),
        ({"stations__B__wks": "W2"}, "stations.B.wks", "expected a table"),
        ({"template__extra": {}}, "template.extra", "unknown key"),
    ],
)
def test_template_problems_name_the_template_table(changes: dict[str, Any], key: str, words: str) -> None:
    lines = problems(doc(**changes))
    hit = [line for line in lines if f"[{key}]" in line]
    assert hit, lines
    assert hit[0].startswith("m.toml: ") and words in hit[0]


def test_template_id_colliding_with_a_plain_table() -> None:
    d = doc()
    d["features"] = {"AF1": {"wks": {"W1": 1}}}
    (line,) = problems(d)
    assert "[template.features.F1]" in line and "expands to [features.AF1]" in line


def test_template_without_stations() -> None:
    d = doc()
    del d["stations"]
    lines = problems(d)
    assert any("[stations]" in line and "at least one" in line for line in lines)


def test_tools_mapped_per_station() -> None:
    d = doc()
    d["tools"] = {"T1": {}, "T2": {}}
    d["template"]["features"]["F1"]["tools"] = {"cutter": 1}
    d["stations"]["A"]["tools"] = {"cutter": "T1"}
    d["stations"]["B"]["tools"] = {"cutter": "T2"}
    model = model_from_dict(d)
    assert model.features[0].tools == {"T1": 1.0} and model.features[2].tools == {"T2": 1.0}


def _per_part_report(tmp_path: Path, station: str, *, with_station: bool) -> Path:
    """One station's rows of guide-pins cycle 1 as an ordinary per-part report writes them: "D1", not "P2 D1"."""
    import csv

    with open(GUIDE_PINS / "cycle_01.csv", newline="", encoding="utf-8") as f:
        rows = [r for r in csv.DictReader(f) if r["station"] == station]
    path = tmp_path / f"part_{station}.csv"
    with open(path, "w", newline="", encoding="utf-8") as f:
        out = csv.writer(f)
        out.writerow(
            ["characteristic", "nominal", "actual", "lower", "upper", "part"] + (["station"] if with_station else [])
        )
        for r in rows:
            out.writerow(
                [
                    r["characteristic"].removeprefix(f"{station} "),
                    r["nominal"],
                    r["actual"],
                    r["lower"],
                    r["upper"],
                    "serial 17",
                ]
                + ([station] if with_station else [])
            )
    return path


@pytest.mark.parametrize("with_station", [True, False])
def test_a_template_matches_a_per_part_report_without_the_station_prefix(tmp_path: Path, with_station: bool) -> None:
    from setupfix.usecases.correct import correct_report
    from setupfix.usecases.requests import CorrectRequest, CycleOptions

    model = load_model(GUIDE_PINS / "model.toml")
    report = _per_part_report(tmp_path, "P2", with_station=with_station)
    cycles = CycleOptions() if with_station else CycleOptions.of(["P2"])
    (cycle,) = correct_report(CorrectRequest(model, cycles=cycles), report).cycles
    matched = [d.id for d, v in zip(model.dimensions, cycle.part.deviation, strict=True) if v == v]
    assert matched == [f"P2D{i}" for i in range(1, 8)] and not cycle.part.unmatched
    # the same numbers as the fixture report's P2 rows (named "P2 D1" …)
    (whole,) = correct_report(CorrectRequest(model), GUIDE_PINS / "cycle_01.csv").cycles
    np.testing.assert_array_equal(cycle.part.deviation[7:14], whole.part.deviation[7:14])


def test_a_per_part_report_without_its_station_is_refused_naming_the_way_to_give_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from setupfix.cli import main

    report = _per_part_report(tmp_path, "P2", with_station=False)
    assert main(["correct", "--model", str(GUIDE_PINS / "model.toml"), str(report)]) != 0
    err = capsys.readouterr().err
    assert "'D1' names several dimensions" in err and "--stations" in err and "model check" not in err
    assert main(["correct", "--model", str(GUIDE_PINS / "model.toml"), "--stations", "P2", str(report)]) == 0


def test_model_check_does_not_send_the_user_to_model_check(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from setupfix.cli import main

    report = tmp_path / "other.csv"
    report.write_text("characteristic,nominal,actual,lower,upper\nBore 1,10,10.01,-0.1,0.1\n", encoding="utf-8")
    assert main(["model", "check", str(GUIDE_PINS / "model.toml"), str(report)]) != 0
    err = capsys.readouterr().err
    assert "no characteristic of part" in err and "model check" not in err
    assert "'P1 D1'" in err and "aliases" in err and "--stations" in err
    # correct's message still points at model check (a different command)
    assert main(["correct", "--model", str(GUIDE_PINS / "model.toml"), str(report)]) != 0
    assert "model check" in capsys.readouterr().err
