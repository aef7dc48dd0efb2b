"""A position zone on the operator's screen reads as a CMM prints it: the diameter, beside the margins."""

from __future__ import annotations

from typing import Any

import pytest
from conftest import SAMPLES
from textual.widgets import DataTable
from tui.conftest import MakeApp, run, settle

XYZ = SAMPLES / "two_station_xyz"


def _rows(table: DataTable[Any]) -> dict[str, list[str]]:
    return {str(k.value): [str(c) for c in table.get_row(k)] for k in table.rows}


@pytest.mark.slow
def test_wide_screen_gives_each_zone_its_cmm_diameters(make_app: MakeApp) -> None:
    async def scenario() -> None:
        app = make_app(report=XYZ / "cycle_01.csv", model=XYZ / "model.toml")
        async with app.run_test(size=(200, 48)) as pilot:
            await settle(pilot)
            c = app.state.current()
            assert c is not None
            table = app.query_one("#dimensions", DataTable)
            header = [str(col.label) for col in table.columns.values()]
            assert header[-1] == "position ⌀"
            rows = _rows(table)
            zones = [d for d in c.model.dimensions if d.zone]
            assert zones, "the sample has position zones"
            for d in zones:
                i = c.model.dimensions.index(d)
                measured = 2 * c.part.deviation[i]  # the radial distance → the diameter a CMM prints
                cell = rows[d.id][-1]
                assert cell.startswith(f"⌀{measured:.3f} → ⌀"), (d.id, cell)
                assert cell.endswith(f"of ⌀{2 * d.upper:.3f}")
            plain = [r for r in rows.values() if r[1] not in {d.name for d in zones}]
            assert all(r[-1] == "" for r in plain)
        narrow = make_app(report=XYZ / "cycle_01.csv", model=XYZ / "model.toml")
        async with narrow.run_test(size=(80, 24)) as pilot:  # no room: no column
            await settle(pilot)
            header = [str(col.label) for col in narrow.query_one("#dimensions", DataTable).columns.values()]
            assert "position ⌀" not in header

    run(scenario())
