"""Regenerate the documentation's screenshots of ``setupfix tui`` (Textual's SVG export).

    python docs/tui_screenshots.py

Runs the app headless on the bundled guide-pins sample at a fixed terminal size and
writes ``docs/tui_correction.svg`` (the correction screen).
"""

from __future__ import annotations

import asyncio
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.chdir(ROOT)

from setupfix.tui.app import SetupfixApp  # noqa: E402
from setupfix.tui.state import Inputs  # noqa: E402

MODEL = Path("sample_reports/guide_pins/model.toml")
REPORT = Path("sample_reports/guide_pins/cycle_01.csv")


async def shoot(name: str, keys: tuple[str, ...], size: tuple[int, int]) -> None:
    app = SetupfixApp(Inputs(model=MODEL, report=REPORT))
    async with app.run_test(size=size) as pilot:
        await app.workers.wait_for_complete()
        await pilot.pause()
        for key in keys:
            await pilot.press(key)
            await app.workers.wait_for_complete()
            await pilot.pause()
        app.save_screenshot(filename=f"{name}.svg", path=str(ROOT / "docs"))
        print(f"wrote docs/{name}.svg")


async def main() -> None:
    await shoot("tui_correction", (), (100, 32))


if __name__ == "__main__":
    asyncio.run(main())
