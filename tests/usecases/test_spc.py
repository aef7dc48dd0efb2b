"""``spc`` on a stored series: numbers equal an independent computation, planted rule violations are found."""

from __future__ import annotations

import itertools
import math
import statistics
from pathlib import Path

import numpy as np
import pytest

from setupfix.core.errors import MatchError, ParameterError, ParseError, StoreError
from setupfix.store import open_store
from setupfix.usecases.history import ImportRequest, import_history
from setupfix.usecases.spc_report import SpcRequest, format_spc, spc_json, spc_report

#: A clean stretch (deviations, mm): no Nelson rule fires on it or across its joins.
CLEAN = [0.003, -0.005, 0.004, 0.0045, -0.002, 0.001, -0.0055]
LIMITS = (-0.02, 0.02)


def planted() -> tuple[list[float], dict[int, list[tuple[int, int]]]]:
    """60 parts: 21 clean baseline parts, a rule-1 spike at 28, a rule-2 run at 35-43, clean after."""
    x = CLEAN * 4  # 0..27
    where = {1: [(28, 28)], 2: [(36, 44)]}
    x += [0.05]  # 28: rule 1 (far beyond 3σ of the baseline, and out of tolerance)
    x += CLEAN  # 29..35
    x += [0.002, 0.006, 0.003, 0.005, 0.0025, 0.007, 0.004, 0.0035, 0.0065]  # 36..44: nine above
    x += [-0.003] + CLEAN * 2  # 45..59
    return x, where


def write_report(folder: Path, name: str, series: dict[str, list[float]], start: int = 0, hours: float = 1.0) -> Path:
    lines = ["characteristic,nominal,actual,lower,upper,part,timestamp"]
    n = len(next(iter(series.values())))
    for i in range(n):
        t = np.datetime64("2026-03-02T06:00:00") + np.timedelta64(int((start + i) * hours * 3600), "s")
        for char, values in series.items():
            lines.append(f"{char},10,{10 + values[i]!r},{LIMITS[0]},{LIMITS[1]},p{start + i:03d},{t}")
    path = folder / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.fixture
def store_path(tmp_path: Path) -> Path:
    x, _ = planted()
    clean = (CLEAN * 9)[:60]
    write_report(tmp_path, "a.csv", {"D1": x[:30], "D2": clean[:30]})
    write_report(tmp_path, "b.csv", {"D1": x[30:], "D2": clean[30:]}, start=30)
    (tmp_path / "corrections.csv").write_text(
        "timestamp,register,delta\n2026-03-03T05:30:00,W1,0.01\n", encoding="utf-8"
    )
    db = tmp_path / "h.db"
    with open_store(db) as store:
        import_history(
            store,
            ImportRequest(
                reports=(tmp_path / "a.csv", tmp_path / "b.csv"), corrections=(tmp_path / "corrections.csv",)
            ),
        )
    return db


def direct(values: list[float], lsl: float, usl: float) -> dict[str, float]:
    mean = statistics.fmean(values)
    within = statistics.fmean(abs(b - a) for a, b in itertools.pairwise(values)) / 1.128
    overall = statistics.stdev(values)
    return {
        "mean": mean,
        "cp": (usl - lsl) / (6 * within),
        "cpk": min(usl - mean, mean - lsl) / (3 * within),
        "pp": (usl - lsl) / (6 * overall),
        "ppk": min(usl - mean, mean - lsl) / (3 * overall),
    }


def test_capability_equals_an_independent_computation_and_rules_are_where_planted(store_path: Path) -> None:
    x, where = planted()
    with open_store(store_path) as store:
        out = spc_report(store, SpcRequest())
    d1, d2 = out.dimensions
    assert (d1.name, d2.name) == ("D1", "D2")
    assert d1.values == pytest.approx(x, abs=1e-12)
    assert d1.parts == tuple(f"p{i:03d}" for i in range(60))
    expect = direct(x, *LIMITS)
    for key, value in expect.items():
        assert getattr(d1.capability, key) == pytest.approx(value, rel=1e-9), key
    assert d1.capability.out_of_tolerance == 1  # the spike
    got = {r: [(v.first, v.last) for v in d1.violations if v.rule == r] for r in (1, 2, 3, 4)}
    assert got == {1: where[1], 2: where[2], 3: [], 4: []}
    assert d1.violations[0].parts == ("p028",)
    assert d2.violations == ()
    base = x[:20]
    assert d1.limits.center == pytest.approx(statistics.fmean(base), rel=1e-12)


def test_each_stored_correction_splits_the_series(store_path: Path) -> None:
    x, _ = planted()
    with open_store(store_path) as store:
        out = spc_report(store, SpcRequest(dimensions=("d1",)))
    (effect,) = out.dimensions[0].splits
    # the correction at 05:30 on day two: parts 0..23 before (06:00 … 05:00), 24..59 after
    assert (effect.time, effect.source, effect.at) == ("2026-03-03T05:30:00", "correction", 24)
    assert effect.before.cpk == pytest.approx(direct(x[:24], *LIMITS)["cpk"], rel=1e-9)
    assert effect.after.cpk == pytest.approx(direct(x[24:], *LIMITS)["cpk"], rel=1e-9)
    assert (effect.before.n, effect.after.n) == (24, 36)


def test_given_splits_and_a_time_window(store_path: Path) -> None:
    x, _ = planted()
    with open_store(store_path) as store:
        out = spc_report(
            store,
            SpcRequest(
                dimensions=("D1",),
                since="2026-03-02T16:00:00",
                until="2026-03-04T12:00:00",
                splits=("2026-03-03T00:00:00", "2026-03-03T10:00:00"),
            ),
        )
    d = out.dimensions[0]
    assert d.parts[0] == "p010" and d.parts[-1] == "p054"
    first, second = d.splits
    window = x[10:55]
    # first split at part 18: before = since .. split, after = split .. next split (part 28)
    assert first.before.n == 8 and first.after.n == 10
    assert first.after.mean == pytest.approx(statistics.fmean(window[8:18]), rel=1e-12)
    assert second.before.n == 10 and second.after.n == len(window) - 18


def test_another_machines_handle_sees_none_of_the_series(store_path: Path) -> None:
    with (
        open_store(store_path, machine="M1") as store,
        pytest.raises(StoreError, match="no measurements stored for machine 'M1'"),
    ):
        spc_report(store, SpcRequest())


def test_refusals(store_path: Path) -> None:
    with open_store(store_path) as store:
        with pytest.raises(MatchError, match=r"no stored characteristic 'D9'.*stored: D1, D2"):
            spc_report(store, SpcRequest(dimensions=("D9",)))
        with pytest.raises(ParameterError, match="between --since and --until"):
            spc_report(store, SpcRequest(since="2030-01-01T00:00:00"))
        with pytest.raises(ParseError, match=r"--split: timestamp 'yesterday' is not ISO 8601"):
            spc_report(store, SpcRequest(splits=("yesterday",)))
        with pytest.raises(ParameterError, match="baseline"):
            spc_report(store, SpcRequest(baseline=1))


def test_text_and_json_say_the_same(store_path: Path) -> None:
    with open_store(store_path) as store:
        out = spc_report(store, SpcRequest())
    js = spc_json(out)
    d1 = js["dimensions"][0]
    assert d1["cpk"] == pytest.approx(out.dimensions[0].capability.cpk, abs=1e-9)
    assert [v["rule"] for v in d1["violations"]] == [1, 2]
    assert d1["violations"][1]["parts"][0] == "p036" and len(d1["violations"][1]["parts"]) == 9
    assert js["dimensions"][1]["violations"] == []
    assert all(v is None or math.isfinite(v) for v in d1["values"])
    text = format_spc(out)
    assert "D1: rule 1 (one point beyond 3σ): p028" in text
    assert "D1: rule 2 (nine points in a row on one side of the centre line): p036 … p044 (9 parts)" in text
    assert "D2: rule" not in text


def test_reference_only_rows_are_left_out(tmp_path: Path) -> None:
    rows = ["characteristic,nominal,actual,lower,upper,part,timestamp,reference"]
    rows += [f"D1,5,{5 + 0.001 * (i % 3)},-0.01,0.01,p{i},2026-01-01T0{i}:00:00,false" for i in range(6)]
    rows.append("D1,5,5.009,-0.01,0.01,master,2026-01-01T09:00:00,true")
    (tmp_path / "r.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    db = tmp_path / "h.db"
    with open_store(db) as store:
        import_history(store, ImportRequest(reports=(tmp_path / "r.csv",)))
        assert store.measurements()["reference"].sum() == 1
        (d,) = spc_report(store, SpcRequest()).dimensions
    assert d.parts == tuple(f"p{i}" for i in range(6))


def test_a_part_stored_twice_counts_once_and_parts_sharing_a_name_all_count(tmp_path: Path) -> None:
    def report(name: str, day: int, crlf: bool = False) -> Path:
        rows = ["characteristic,nominal,actual,lower,upper,part,timestamp"]
        rows += [f"D1,5,{5 + 0.001 * ((i + day) % 3)},-0.01,0.01,cycle {i},2026-01-0{day}T0{i}:00:00" for i in range(4)]
        path = tmp_path / name
        path.write_bytes(("\r\n" if crlf else "\n").join(rows).encode() + b"\n")
        return path

    db = tmp_path / "h.db"
    with open_store(db) as store:  # day 1, the same report again with other bytes, day 2 with the same part names
        import_history(
            store, ImportRequest(reports=(report("a.csv", 1), report("a_crlf.csv", 1, crlf=True), report("b.csv", 2)))
        )
        out = spc_report(store, SpcRequest())
    (d,) = out.dimensions
    assert d.parts == tuple(f"cycle {i}" for i in range(4)) * 2
    assert [n.message for n in out.notes] == [
        "4 value(s) of parts stored more than once: counted once",
        "D1: 8 part(s), fewer than the baseline of 20: the limits come from all of them",
    ]
