"""Issue 37 item 13: a part is identified by what it measured as well as by its name.

Properties of :func:`setupfix.inputs.duplicates.same_measurement` (a copy in another format, with its
name in other case or spacing, written at other decimals, or missing one row, is the same part; one
step of the report's resolution, another time, another name or two rows missing make another part),
and the smoothing history built on it: a copy counts once in the EWMA.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import parsers
from setupfix.inputs.duplicates import (
    COARSEST,
    Content,
    ContentIndex,
    content_of,
    first_copies,
    resolution_of,
    same_measurement,
    time_ns,
)
from setupfix.model import load_model, match_parts
from setupfix.usecases.requests import History

GUIDE = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"

T0 = 1_793_606_400_000_000_000  #: 2026-11-02T08:00:00 [ns]

names = st.text(alphabet="abcXYZ 01_-", min_size=1, max_size=12).filter(lambda s: s.strip() != "")
decimals = st.integers(min_value=3, max_value=6)


@st.composite
def parts(draw: st.DrawFn) -> tuple[str, dict[str, float], int]:
    """A part name, its values written at ``k`` decimals (at least three characteristics), and ``k``."""
    k = draw(decimals)
    n = draw(st.integers(min_value=3, max_value=12))
    steps = draw(st.lists(st.integers(min_value=-(10**k) // 10, max_value=10**k // 10), min_size=n, max_size=n))
    return draw(names), {f"D{i}": round(s * 10.0**-k, k) for i, s in enumerate(steps)}, k


def respaced(name: str, flip: bool) -> str:
    """``name`` in other case and with its blanks doubled (what a second export may write)."""
    out = " ".join(name.split()).replace(" ", "  ")
    return (out.upper() if flip else out.lower()) + " "


@settings(max_examples=100, deadline=None)
@given(parts(), st.booleans(), st.integers(min_value=0, max_value=2), st.data())
def test_a_copy_in_other_case_decimals_and_one_row_short_is_the_same_part(
    part: tuple[str, dict[str, float], int], flip: bool, extra: int, data: st.DataObject
) -> None:
    name, values, k = part
    a = content_of(name, T0, values)
    # the copy: other case and spacing, written with ``extra`` more decimals (a float rounding below
    # the report's step), and one row missing
    noise = data.draw(st.floats(min_value=-0.4, max_value=0.4)) * 10.0**-k
    finer = {c: round(v + (noise if extra else 0.0), k + extra) for c, v in values.items()}
    drop = data.draw(st.sampled_from(sorted(values)))
    b = content_of(respaced(name, flip), T0, {c: v for c, v in finer.items() if c != drop})
    assert same_measurement(a, b) and same_measurement(b, a)
    assert same_measurement(a, a)
    assert first_copies([a, b, a]) == [None, 0, 0]


@settings(max_examples=100, deadline=None)
@given(parts(), st.data())
def test_one_step_of_the_resolution_another_time_or_name_or_two_rows_make_another_part(
    part: tuple[str, dict[str, float], int], data: st.DataObject
) -> None:
    name, values, k = part
    a = content_of(name, T0, values)
    assert a.resolution == pytest.approx(min(COARSEST, resolution_of(list(values.values()))))
    c = data.draw(st.sampled_from(sorted(values)))
    step = max(a.resolution, 10.0**-k)
    sign = data.draw(st.sampled_from([-1.0, 1.0]))
    moved = content_of(name, T0, {**values, c: values[c] + sign * step})
    assert not same_measurement(a, moved) and not same_measurement(moved, a)
    later = content_of(name, T0 + 1_000_000_000, values)  # one second later
    assert not same_measurement(a, later)
    other = data.draw(names)
    assume(" ".join(other.split()).casefold() != " ".join(name.split()).casefold())
    assert not same_measurement(a, content_of(other, T0, values))
    two = data.draw(st.lists(st.sampled_from(sorted(values)), min_size=2, max_size=2, unique=True))
    short = content_of(name, T0, {d: v for d, v in values.items() if d not in two})
    assert not same_measurement(a, short)
    # a part that gives no time is told apart by the rest
    assert same_measurement(a, content_of(name, None, values))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.integers(min_value=-5000, max_value=5000), min_size=1, max_size=20), decimals)
def test_the_resolution_is_the_finest_step_the_values_are_written_at(steps: list[int], k: int) -> None:
    values = [s * 10.0**-k for s in steps]
    got = resolution_of(values)
    assert got <= COARSEST and got >= 10.0**-k * (1 - 1e-9)
    assert all(abs(v / got - round(v / got)) < 1e-6 for v in values)
    assert resolution_of([v - 25.0 + 25.0 for v in values]) == got  # actual − nominal keeps the decimals


def test_a_lone_value_of_an_unnamed_untimed_part_is_no_identity() -> None:
    assert time_ns("2026-11-02T08:00:00") == time_ns(np.datetime64("2026-11-02T08:00:00")) == T0
    assert time_ns(None) is None and time_ns(" ") is None
    a = content_of("", None, {"D1": 0.012})
    assert not same_measurement(a, content_of("", None, {"D1": 0.012}))
    assert not same_measurement(a, content_of("", T0, {"D1": 0.012}))  # one time alone compares nothing
    assert same_measurement(content_of("", T0, {"D1": 0.012}), content_of("", T0, {"D1": 0.012}))
    named = content_of("p1", None, {"D1": 0.012})
    assert same_measurement(named, content_of("P1", None, {"D1": 0.012}))
    assert isinstance(named, Content) and named.label == "p1" and named.name == "p1"


@pytest.fixture
def ewma_model(tmp_path: Path) -> Path:
    path = tmp_path / "m.toml"
    path.write_text((GUIDE / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    return path


def test_a_copy_in_other_case_lacking_a_row_is_not_another_earlier_part_in_the_ewma(
    tmp_path: Path, ewma_model: Path
) -> None:
    """The issue's case (a copy named in other case or spacing, or lacking a row, counted as another
    earlier part), varied: cycle 02 written again as ``CYCLE  02`` with one row less and 6 decimals."""
    model = load_model(ewma_model)
    text = (GUIDE / "cycle_02.csv").read_text().splitlines()
    head = text[0].split(",")
    dev, act, part = head.index("deviation"), head.index("actual"), head.index("part")
    rows = []
    for line in text[2:]:  # the first row left out
        cells = line.split(",")
        cells[part] = "CYCLE  02"
        cells[dev] = f"{float(cells[dev]):.6f}"
        cells[act] = f"{float(cells[act]):.6f}"
        rows.append(",".join(cells))
    copy = tmp_path / "copy.csv"
    copy.write_bytes(("\r\n".join([text[0], *rows]) + "\r\n").encode())
    earlier = [p for i in (1, 2) for p in match_parts(model, parsers.read(GUIDE / f"cycle_0{i}.csv"))]
    again = match_parts(model, parsers.read(copy))
    history = History.empty(model).with_parts(earlier)
    assert history.with_parts(again).keys == history.keys == ("cycle 01", "cycle 02")
    # the estimate of cycle 03 is the same with or without the copy
    (now,) = match_parts(model, parsers.read(GUIDE / "cycle_03.csv"))
    want = history.smooth(model, now, 0.5)
    got = History.empty(model).with_parts([*earlier, *again]).smooth(model, now, 0.5)
    assert got.used == want.used == 2
    np.testing.assert_array_equal(got.deviation, want.deviation)
    # a part measured one step of the report's resolution apart on one dimension is another part
    moved = dataclasses.replace(again[0], deviation=again[0].deviation + np.r_[0.0, 1e-4, np.zeros(26)])
    assert len(history.with_parts([moved]).keys) == 3


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_the_index_finds_exactly_what_comparing_with_every_part_finds(data: st.DataObject) -> None:
    """Brute force: :class:`ContentIndex` matches every part a pairwise search over all parts matches,
    values on and beside the index's cell edges, copies short of a row, with and without times."""
    edge = st.integers(min_value=-30, max_value=30).map(lambda n: round(n * COARSEST, 4))
    near = st.sampled_from([0.0, 0.0001, -0.0001, 0.0004, -0.0004, 0.0005, -0.0005])
    index = ContentIndex()
    held: list[Content] = []
    for _ in range(data.draw(st.integers(min_value=1, max_value=25))):
        copy = data.draw(st.booleans())
        if held and copy:  # a copy of a part held, perturbed within or beyond the rule
            base = data.draw(st.sampled_from(held))
            values = {k: round(v + data.draw(near), 4) for k, v in base.values.items()}
            if len(values) > 2 and data.draw(st.booleans()):
                values.pop(data.draw(st.sampled_from(sorted(values))))
            c = content_of(base.label.upper(), data.draw(st.sampled_from([base.time, None])), values)
        else:
            n = data.draw(st.integers(min_value=1, max_value=5))
            values = {f"D{k}": data.draw(edge) + data.draw(near) for k in range(n)}
            c = content_of(data.draw(st.sampled_from(["a", "b", ""])), data.draw(st.sampled_from([T0, None])), values)
        assert index.matches(c) == [i for i, seen in enumerate(held) if same_measurement(seen, c)]
        index.add(c)
        held.append(c)
