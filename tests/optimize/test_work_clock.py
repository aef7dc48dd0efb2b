"""The same answer under any load (issue 37 #4): solver stages end on work, the wall clock only guards.

A solve whose wall clock runs 100× (or 10,000×) fast — what a loaded machine looks like to the
solver — gives the same bytes out of ``correct --json`` as an idle one, or no correction at all
(HOLD, "not solved", the stopped status): never a different correction.
"""

from __future__ import annotations

import contextlib
import io
import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import SAMPLES

from setupfix.cli import main
from setupfix.optimize.exact import work

GUIDE = SAMPLES / "guide_pins"
XYZ = SAMPLES / "two_station_xyz"
CTRL = SAMPLES / "controllers"
CASES: list[tuple[Path, Path, tuple[str, ...]]] = [
    *((GUIDE / "model.toml", GUIDE / f"cycle_0{k}.csv", ()) for k in (1, 3, 4)),
    *((XYZ / "model.toml", XYZ / f"cycle_0{k}.csv", ()) for k in (1, 2, 3)),
    (CTRL / "model.toml", CTRL / "report.csv", ("--current", str(CTRL / "current.csv"))),
]


def _timeless(doc: Any) -> Any:
    """The JSON without its wall times (``seconds``): everything else must not depend on the clock."""
    if isinstance(doc, dict):
        return {k: _timeless(v) for k, v in doc.items() if k != "seconds"}
    if isinstance(doc, list):
        return [_timeless(v) for v in doc]
    return doc


def correct_json(model: Path, report: Path, extra: tuple[str, ...]) -> list[dict[str, Any]]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["correct", "--model", str(model), str(report), "--json", *extra])
    assert code in (0, 6), err.getvalue()
    doc = json.loads(out.getvalue())
    parts: list[dict[str, Any]] = _timeless(doc.get("parts", [doc]))
    return parts


@contextlib.contextmanager
def fast_wall_clock(monkeypatch: pytest.MonkeyPatch, factor: float) -> Iterator[None]:
    """The solver's wall clock (:func:`setupfix.optimize.exact.work.wall_clock`) runs ``factor`` times fast."""
    real = time.perf_counter
    began = real()
    with monkeypatch.context() as m:
        m.setattr(work, "wall_clock", lambda: began + factor * (real() - began))
        yield


def assert_same_or_not_solved(idle: list[dict[str, Any]], loaded: list[dict[str, Any]]) -> bool:
    """Each part: the idle bytes, or a hold with nothing proven; True when some part was held."""
    assert len(idle) == len(loaded)
    held = False
    for want, got in zip(idle, loaded, strict=True):
        if got == want:
            continue
        held = True
        assert got["verdict"] == "hold" and got["solved"] is False, got
        assert got["status"] == "time_limit" and got["stopped"]["reason"] == "time limit", got
        assert not any(got["corrections"].values()), got
    return held


@pytest.mark.slow
def test_a_wall_clock_100_times_fast_gives_the_same_bytes_or_a_hold(monkeypatch: pytest.MonkeyPatch) -> None:
    idle = [correct_json(*case) for case in CASES]
    assert idle == [correct_json(*case) for case in CASES]  # the same bytes run after run
    assert all(p["verdict"] == "apply" and p["status"] == "optimal" for parts in idle for p in parts)
    with fast_wall_clock(monkeypatch, 100.0):
        loaded = [correct_json(*case) for case in CASES]
    for want, got in zip(idle, loaded, strict=True):
        assert_same_or_not_solved(want, got)


@pytest.mark.slow
def test_a_wall_clock_past_the_guard_holds_and_never_applies_another_correction(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """10,000× fast: the 60 s guard is 6 ms of real time, less than any multi-axis solve takes."""
    xyz = [case for case in CASES if case[0].parent == XYZ]
    idle = [correct_json(*case) for case in xyz]
    with fast_wall_clock(monkeypatch, 10_000.0):
        loaded = [correct_json(*case) for case in xyz]
    assert all(assert_same_or_not_solved(want, got) for want, got in zip(idle, loaded, strict=True))
