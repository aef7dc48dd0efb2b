"""``--current`` takes the spec's columns only: a comment column, a trailing comma, another delimiter or a quoted
decimal comma can never turn a shop's ``-412,530`` into a value (issue 37 item 12): refused with file and line."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from multi_axis_rows import multi_axis_model

from parsers.current import read_current
from setupfix.cli import main
from setupfix.core.errors import ParseError
from setupfix.model import ProcessModel, load_model

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_reports" / "controllers"
ONE_AXIS = load_model(SAMPLE / "model.toml")
MULTI = multi_axis_model()
#: (register cells before the value, value ID) of every correctable register (component), per model
ONE_ROWS = [(("G54",), "W1"), (("G55",), "W2"), (("H5",), "T5"), (("H12",), "T12")]
MULTI_ROWS = [
    (("G54", "X"), "W1.X"),
    (("G54", "Y"), "W1.Y"),
    (("G54", "Z"), "W1.Z"),
    (("G54", "C"), "W1.C"),
    (("G55", "X"), "W2.X"),
    (("G55", "Y"), "W2.Y"),
    (("G55", "Z"), "W2.Z"),
    (("H5", ""), "T5"),
    (("D5", ""), "T5.R"),
]


@dataclass(frozen=True)
class Variant:
    """How a shop's file differs from the spec's ``register[,axis],value`` (all fields off: the spec's file)."""

    multi: bool
    millis: tuple[int, ...]  # each row's value in thousandths: -412530 is -412.530
    comma_rows: frozenset[int]  # rows whose value is written with a decimal comma
    extra_header: str  # appended to the header: "" (none), ",comment", "," (a trailing comma), ",note,"
    trailing_rows: frozenset[int]  # rows ending with an extra "," (an empty cell)
    quoted: bool  # every cell in double quotes
    delimiter: str  # "," (the spec's) or ";"

    @property
    def clean(self) -> bool:
        return not (self.comma_rows or self.extra_header or self.trailing_rows) and self.delimiter == ","


def _value(millis: int, mark: str) -> str:
    sign = "-" if millis < 0 else ""
    whole, frac = divmod(abs(millis), 1000)
    return f"{sign}{whole}{mark}{frac:03d}"


def _text(v: Variant) -> str:
    rows = MULTI_ROWS if v.multi else ONE_ROWS
    columns = ["register", "axis", "value"] if v.multi else ["register", "value"]

    def line(cells: list[str]) -> str:
        return v.delimiter.join(f'"{c}"' if v.quoted else c for c in cells)

    lines = [line(columns) + v.extra_header]
    for i, ((*keys,), _) in enumerate(rows):
        cells = [*keys, _value(v.millis[i], "," if i in v.comma_rows else ".")]
        lines.append(line(cells) + ("," if i in v.trailing_rows else ""))
    return "\n".join(lines) + "\n"


def _model(v: Variant) -> ProcessModel:
    return MULTI if v.multi else ONE_AXIS


@st.composite
def variants(draw: st.DrawFn) -> Variant:
    multi = draw(st.booleans())
    n = len(MULTI_ROWS if multi else ONE_ROWS)
    # |value| < 100 m (the reader's range); a rotation's 1e5 degrees bound is wider still
    millis = tuple(draw(st.lists(st.integers(-99_999_999, 99_999_999), min_size=n, max_size=n)))
    rows = st.frozensets(st.integers(0, n - 1), max_size=3)
    return Variant(
        multi=multi,
        millis=millis,
        comma_rows=draw(rows),
        extra_header=draw(st.sampled_from(["", "", ",comment", ",", ",note,", ",value"])),
        trailing_rows=draw(rows),
        quoted=draw(st.booleans()),
        delimiter=draw(st.sampled_from([",", ",", ";"])),
    )


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(variants())
@example(  # the case: register,value,comment with G54,-412,530 (read as -412 before)
    Variant(False, (-412530, -412487, -12, 4), frozenset({0}), ",comment", frozenset(), False, ",")
)
@example(  # a trailing-comma header: the value's second half went into the nameless column
    Variant(False, (-412530, -412487, -12, 4), frozenset({0}), ",", frozenset(), False, ",")
)
@example(  # multi-axis, G54,X,-250,123 under a comment column (read as X -250 before)
    Variant(True, (-250123, 120500, -412530, 250, 50000, -500, -412487, -12, 2), frozenset({0}), ",comment",
            frozenset(), False, ",")
)  # fmt: skip
def test_only_the_spec_file_gives_values_every_other_is_refused_with_file_and_line(
    tmp_path: Path, variant: Variant
) -> None:
    path = tmp_path / "c.csv"
    text = _text(variant)
    path.write_text(text)
    rows = MULTI_ROWS if variant.multi else ONE_ROWS
    if variant.clean:
        assert read_current(path, _model(variant)) == {rid: variant.millis[i] / 1000 for i, (_, rid) in enumerate(rows)}
        return
    with pytest.raises(ParseError) as caught:
        read_current(path, _model(variant))
    found = re.match(rf"{re.escape(str(path))}:(\d+): ", str(caught.value))
    assert found, str(caught.value)
    line = int(found[1])
    if variant.extra_header or variant.delimiter != ",":
        assert line == 1  # the header itself is refused: no row is read under it
    else:
        first = min(variant.comma_rows | variant.trailing_rows)
        assert line == first + 2  # the first row that differs from the spec's


@pytest.mark.parametrize("header", ["register,value,comment", "register,value,", "Register,Value,,"])
def test_correct_refuses_a_comment_column_in_current_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], header: str
) -> None:
    """A variant of the issue's case at the door: the header's third column, the rows' third cell a digit group."""
    bad = tmp_path / "c.csv"
    bad.write_text(f"{header}\nG54,-412,530\nG55,-412,487\nH5,-0.012\nH12,0.0035\n")
    out = tmp_path / "o.csv"
    code = main(
        [
            "correct",
            "--model",
            str(SAMPLE / "model.toml"),
            "--current",
            str(bad),
            "--offsets",
            str(out),
            str(SAMPLE / "report.csv"),
        ]
    )
    err = capsys.readouterr().err
    assert code != 0 and err.startswith(f"error: {bad}:1: expected the header 'register,value', found")
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()
