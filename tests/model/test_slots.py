"""Controller slots of registers (issue 21, item 3): two registers of one slot refuse the model.

The slot function is checked against the programs themselves: every pair of register
spellings below is rendered by every controller, and the loader refuses the pair
exactly when some controller family would write both to one address.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest
from model.test_loader import SPEC_EXAMPLE

from setupfix.core.errors import ExportError, ModelError
from setupfix.correction.offsets import OffsetRow
from setupfix.model import load_model
from setupfix.model.slots import register_slots
from setupfix.outputs.controllers import render

WKS = [
    ("G54", None),
    ("G054", None),
    ("g 54", None),
    ("G55", None),
    ("G59", None),
    ("G54.1 P1", None),
    ("G54.1P1", None),
    ("G54.1 P01", None),
    ("g54.1 p1", None),
    ("G54.1 P2", None),
    ("G110", None),
    ("G111", None),
    ("G129", None),
    ("G154 P1", None),
    ("G154P1", None),
    ("G154 P02", None),
    ("G154 P20", None),
    ("G500", None),
    ("G505", None),
    ("G57", None),
    ("PRESET 1", None),
    ("PR 1", None),
    ("PRESET #1", None),
    ("PRESET 2", None),
    ("G54", 1),
    ("G55", 1),
    ("G54", 2),
    ("PRESET 1", 2),
    ("Fixture A", None),
    ("fixture  a", None),
]
TOOLS = [
    ("H5", None, None),
    ("H05", None, None),
    ("h 5", None, None),
    ("H6", None, None),
    ("T5", None, None),
    ("T05", None, None),
    ("T5 D1", None, None),
    ("T5D1", None, None),
    ("T05 D01", None, None),
    ("T5 D2", None, None),
    ("T6 D1", None, None),
    ("L1", 5, None),
    ("L2", 5, 1),
    ("H7", 5, None),
    ("T9", None, 1),
    ("T9 D1", None, None),
    ("Spindle", None, None),
    ("SPINDLE", None, None),
]


def address(controller: str, kind: str, name: str, number: int | None, edge: int | None) -> str | None:
    """The offset a one-row program of ``controller`` writes for this register (None: not expressible)."""
    row = OffsetRow(
        report="r",
        part="p",
        id="X",
        register=name,
        kind=kind,
        axis="Z",
        delta=0.001,
        mode="set",
        current=0.0,
        value=0.001,
        number=number,
        edge=edge,
        offset="geometry",
    )
    try:
        text = render(controller, [row])
    except ExportError:
        return None
    if controller in ("fanuc", "haas"):
        m = re.search(r"G10 L(\d+) P(\d+)", text)
        return f"G10 L{m.group(1)} P{m.group(2)}" if m else None
    if controller == "siemens":
        m = re.search(r"^(\$[^=]+)=", text, re.MULTILINE)
        return m.group(1) if m else None
    lines = text.splitlines()
    return f"{lines[0]} row {lines[2].split()[0]}"


FAMILIES = {"G10": ("fanuc", "haas"), "siemens": ("siemens",), "heidenhain": ("heidenhain",)}


def collide(kind: str, a: tuple[str, int | None, int | None], b: tuple[str, int | None, int | None]) -> set[str]:
    """Controller families in which both registers write one address."""
    out = set()
    for family, controllers in FAMILIES.items():
        ours = {address(c, kind, *a) for c in controllers} - {None}
        theirs = {address(c, kind, *b) for c in controllers} - {None}
        if ours & theirs:
            out.add(family)
    return out


def has_edge(name: str, edge: int | None) -> bool:
    return edge is not None or (bool(re.search(r"D\s*\d", name, re.IGNORECASE)) and name.upper().startswith("T"))


@pytest.mark.parametrize(("kind", "registers"), [("wks", WKS), ("tool", [(n, k, e) for n, k, e in TOOLS])])
def test_slots_agree_with_every_controller_program(
    kind: str, registers: list[tuple[str, int | None, int | None]]
) -> None:
    """Shared slot ⟺ some controller family writes both to one address (Heidenhain tool edges excepted)."""
    disagree = []
    for a, b in itertools.combinations(registers, 2):
        a3, b3 = (*a, None)[:3], (*b, None)[:3]
        slots = register_slots(kind, *a3) & register_slots(kind, *b3)
        families = collide(kind, a3, b3)
        if families == {"heidenhain"} and kind == "tool" and (has_edge(a3[0], a3[2]) or has_edge(b3[0], b3[2])):
            continue  # two edges of one tool: Siemens keeps them apart, the HEIDENHAIN renderer refuses them
        nowhere = all(
            address(c, kind, *x) is None for c in ("fanuc", "haas", "siemens", "heidenhain") for x in (a3, b3)
        )
        same_name = " ".join(a3[0].split()).upper() == " ".join(b3[0].split()).upper()
        if bool(slots) != (bool(families) or (nowhere and same_name)):
            disagree.append((a3, b3, sorted(slots), sorted(families)))
    assert not disagree, disagree


@pytest.mark.parametrize(
    ("kind", "first", "second"),
    [
        ("wks", 'register = "G54.1P1"', 'register = "G54.1 P1"'),
        ("wks", 'register = "G54.1 P1"', 'register = "G54.1 P01"'),
        ("wks", 'register = "G110"', 'register = "G154 P1"'),
        ("wks", 'register = "G129"', 'register = "G154P20"'),
        ("wks", 'register = "G54"', 'register = "G054"'),
        ("wks", 'register = "PRESET 3"', 'register = "G55"\nnumber = 3'),
        ("wks", 'register = "G54"\nnumber = 1', 'register = "G55"\nnumber = 1'),
        ("tools", 'register = "H5"', 'register = "H05"'),
        ("tools", 'register = "H7"', 'register = "h 07"'),  # a length in "D7" is refused (test_register_letters)
        ("tools", 'register = "H5"', 'register = "Probe"\nnumber = 5'),
        ("tools", 'register = "T5 D1"', 'register = "T05D01"'),
        ("tools", 'register = "T5"\nedge = 1', 'register = "T5 D1"'),
        ("tools", 'register = "H1"\nnumber = 8', 'register = "H2"\nnumber = 8'),
    ],
)
def test_two_registers_of_one_slot_refuse_the_model_naming_both(
    tmp_path: Path, kind: str, first: str, second: str
) -> None:
    if kind == "wks":
        text = SPEC_EXAMPLE.replace('[wks.W1]\nregister = "G54"', f"[wks.W1]\n{first}").replace(
            '[wks.W5]\nregister = "G58"', f"[wks.W5]\n{second}"
        )
        ids = ("W1", "W5")
    else:
        text = SPEC_EXAMPLE.replace('register = "H5"', first).replace('register = "H23"', second)
        ids = ("T5", "T23")
    assert text.count(first.split("\n")[0]) == 1 and text.count(second.split("\n")[0]) == 1
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError) as info:
        load_model(path)
    (line,) = str(info.value).splitlines()
    section = "wks" if kind == "wks" else "tools"
    lines = text.splitlines()
    at_second = lines.index(f"[{section}.{ids[1]}]") + 2  # the register's own line, below its header
    at_first = lines.index(f"[{section}.{ids[0]}]") + 2
    assert line.startswith(f"{path}:{at_second}: [{section}.{ids[1]}.register]: ") and "controller slot" in line
    assert f"also used by {ids[0]} ([{section}.{ids[0]}] line {at_first}, register" in line
    name_a = first.split('"')[1]
    name_b = second.split('"')[1]
    assert repr(name_a) in line and repr(name_b) in line


@pytest.mark.parametrize(
    ("first", "second"),
    [("G54", "G55"), ("G54.1 P1", "G54.1 P2"), ("G110", "G154 P2"), ("G54", "G54.1 P1"), ("G57", "G505")],
)
def test_distinct_slots_load(tmp_path: Path, first: str, second: str) -> None:
    text = SPEC_EXAMPLE.replace('"G54"', f'"{first}"').replace('"G58"', f'"{second}"')
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    assert [r.register for r in load_model(path).wks] == [first, second]


def test_tool_edges_load_and_heidenhain_refuses_two_rows_of_one_tool(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace('"H5"', '"T5 D1"').replace('"H23"', '"T5 D2"')
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    model = load_model(path)
    rows = [
        OffsetRow(
            report="r",
            part="p",
            id=r.id,
            register=r.register,
            kind="tool",
            axis="Z",
            delta=0.001,
            mode="set",
            current=0.0,
            value=0.001,
        )
        for r in model.tools
    ]
    assert "$TC_DP3[5,1]" in render("siemens", rows) and "$TC_DP3[5,2]" in render("siemens", rows)
    with pytest.raises(ExportError, match="two registers write tool L row 5"):
        render("heidenhain", rows)


@pytest.mark.parametrize(
    ("name", "slot"),
    [
        ("G54.1 P07", "G54.1 P7"),
        ("G115", "G54.1 P6"),
        ("G154 P99", "G54.1 P99"),
        ("H005", "H5"),
        ("T005 D002", "T5 D2"),
        ("PR #4", "PRESET 4"),
    ],
)
def test_canonical_slot_names(name: str, slot: str) -> None:
    kind = "tool" if name[0] in "HT" else "wks"
    assert slot in register_slots(kind, name)


def test_sample_models_still_load() -> None:
    root = Path(__file__).resolve().parents[2] / "sample_reports"
    models = sorted(root.rglob("model*.toml"))
    assert models
    for path in models:
        load_model(path)
