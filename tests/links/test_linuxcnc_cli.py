"""End to end through the real CLI against LinuxCNC in simulation (issue 38, "Done when").

``setupfix machine read`` → ``machine write`` dry run → ``--apply`` with read-back and the audit →
a program running refuses the write → shutdown (LinuxCNC writes its parameter file) → restart →
``machine read`` again: the control still holds what was written.  The model and report are the
README's two-station sample (``sample_reports/controllers``): G54/G55 along Z, tools H5 and H12.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from linuxcnc_sim import Sim

from setupfix.store import open_store

SAMPLE = Path(__file__).resolve().parents[2] / "sample_reports" / "controllers"
#: The control's table at the start: the sample's current.csv (G54/G55 Z, H5/H12 length), mm.
START = {"G54": -412.53, "G55": -412.487, "H5": -0.012, "H12": 0.0035}
#: LinuxCNC's parameter of each work system's Z (#5223 G54, +20 per system).
Z_PARAMETER = {"G54": 5223, "G55": 5243}


def setupfix(sim: Sim, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, **sim.environ()}
    return subprocess.run(
        [sys.executable, "-m", "setupfix", *args], env=env, capture_output=True, text=True, timeout=120
    )


def values(read: dict[str, Any]) -> dict[str, float]:
    """``machine read --json`` → register → value (one component each in this one-axis model)."""
    return {row["register"]: float(row["value"]) for row in read["components"]}


@pytest.mark.slow
def test_read_dry_run_apply_interlock_restart(tmp_path: Path) -> None:
    sim = Sim(tmp_path / "control", "mm", tools={5: (START["H5"], 3.0), 12: (START["H12"], 4.0)})
    link = tmp_path / "link.toml"  # LinuxCNC's files keep six decimals: its increment
    link.write_text(f'[link]\nprotocol = "linuxcnc"\nini = "{sim.ini}"\nmachine = "mill-sim"\nincrement = 0.000001\n')
    model, report, db = SAMPLE / "model.toml", SAMPLE / "report.csv", tmp_path / "history.sqlite"
    with sim:
        sim.operator("mdi", f"G10 L2 P1 Z{START['G54']}")
        sim.operator("mdi", f"G10 L2 P2 Z{START['G55']}")

        done = setupfix(sim, "machine", "read", "--link", str(link), "--model", str(model), "--json")
        assert done.returncode == 0, done.stderr
        assert values(json.loads(done.stdout)) == pytest.approx(START)
        out = tmp_path / "current.csv"
        done = setupfix(sim, "machine", "read", "--link", str(link), "--model", str(model), "--out", str(out))
        assert done.returncode == 0, done.stderr
        read_csv = dict(line.split(",") for line in out.read_text().split()[1:])
        given = dict(line.split(",") for line in (SAMPLE / "current.csv").read_text().split()[1:])
        assert {k: float(v) for k, v in read_csv.items()} == pytest.approx({k: float(v) for k, v in given.items()})

        write = ["machine", "write", str(report), "--link", str(link), "--model", str(model), "--json"]
        dry = setupfix(sim, *write)
        assert dry.returncode == 0, dry.stderr
        plan = json.loads(dry.stdout)
        assert (plan["outcome"], plan["dry_run"], plan["machine"]) == ("dry_run", True, "mill-sim")
        new = {row["register"]: row["new"] for row in plan["components"]}
        assert any(new[r] != START[r] for r in START), "the sample's report asks for a correction"
        for row in plan["components"]:
            assert row["new"] == pytest.approx(row["before"] + row["change"], abs=5e-4)
        again = setupfix(sim, "machine", "read", "--link", str(link), "--model", str(model), "--json")
        assert values(json.loads(again.stdout)) == pytest.approx(START), "a dry run writes nothing"

        applied = setupfix(sim, *write, "--apply", "--db", str(db), "--operator", "anna")
        assert applied.returncode == 0, applied.stderr
        result = json.loads(applied.stdout)
        assert result["outcome"] == "applied"
        for row in result["components"]:
            assert row["written"] == pytest.approx(new[row["register"]], abs=1e-9)
            assert row["read_back"] == pytest.approx(row["written"], abs=5e-4)
        read = setupfix(sim, "machine", "read", "--link", str(link), "--model", str(model), "--json")
        assert values(json.loads(read.stdout)) == pytest.approx(new, abs=1e-9)

        # a plan made with the link (correct --json records the values read), then a program starts:
        # LinuxCNC's own state is the interlock, the write is refused before anything is written (exit 6)
        made = setupfix(sim, "correct", str(report), "--model", str(model), "--link", str(link), "--json")
        assert made.returncode == 0, made.stderr
        plan_file = tmp_path / "plan.json"
        plan_file.write_text(made.stdout)
        sim.run_program("G4 P60\nM2\n")
        try:
            refused = setupfix(
                sim, "machine", "write", "--plan", str(plan_file), "--link", str(link), "--model", str(model),
                "--json", "--apply", "--db", str(db), "--operator", "anna",
            )  # fmt: skip
        finally:
            sim.operator("abort")
        assert refused.returncode == 6, refused.stderr
        assert json.loads(refused.stdout)["outcome"] == "refused"
        assert "a program is running" in refused.stderr
        # a REPORT is corrected with the values read first: refused the same, and recorded all the same
        sim.run_program("G4 P60\nM2\n")
        try:
            busy = setupfix(sim, *write, "--apply", "--db", str(db), "--operator", "anna")
        finally:
            sim.operator("abort")
        assert busy.returncode == 6 and "a program is running" in busy.stderr
        read = setupfix(sim, "machine", "read", "--link", str(link), "--model", str(model), "--json")
        assert values(json.loads(read.stdout)) == pytest.approx(new, abs=1e-9), "nothing written while it ran"

    # shut down: LinuxCNC wrote its parameter file (machine unit, six decimals) and tool table
    held = sim.parameters()
    for register, number in Z_PARAMETER.items():
        assert held[number] == pytest.approx(new[register], abs=1e-6)
    with sim:
        read = setupfix(sim, "machine", "read", "--link", str(link), "--model", str(model), "--json")
        assert read.returncode == 0, read.stderr
        assert values(json.loads(read.stdout)) == pytest.approx(new, abs=1e-6), "held after a restart"

    with open_store(db, machine="mill-sim") as store:
        attempts = store.link_attempts()
    assert [a.outcome for a in attempts] == ["applied", "refused", "refused"]
    assert {a.operator for a in attempts} == {"anna"} and {a.machine for a in attempts} == {"mill-sim"}
    confirmed = {c.register: c for c in attempts[0].components}
    for register, value in new.items():
        c = confirmed[register]
        assert c.outcome == "confirmed"
        assert c.before == pytest.approx(START[register]) and c.written == pytest.approx(value)
    assert all(c.written is None for c in attempts[1].components)
