"""Issue 37 item 3: many processes opening one EMPTY PostgreSQL database at once all get the store.

The issue's case was eight ``batch --store`` runs; the variant here is ten processes of four machines
released together (a file they wait for) on new, empty databases, each opening the store and storing one
report of its own -- the creation, the check for other tables and the migrations are serialised, so none
sees a half-made schema and every one stores its report.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}

OPEN = """
import sys, time
from pathlib import Path
import pandas as pd
from setupfix.store import open_store
url, go, k = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3])
while not go.exists():
    time.sleep(0.001)
with open_store(url, machine=f"M{k % 4}") as store:
    table = pd.DataFrame({"characteristic": ["D1"], "deviation": [0.001 * k], "part": [f"p{k}"]})
    store.add_report(f"report {k}".encode(), f"r{k}.csv", "canonical", table)
print("stored", k)
"""

N = 10


@pytest.mark.slow
@pytest.mark.parametrize("attempt", range(3))
def test_processes_creating_one_server_store_at_once_all_succeed(tmp_path: Path, pg_url: str, attempt: int) -> None:
    from setupfix.store import open_store

    go = tmp_path / "go"
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", OPEN, pg_url, str(go), str(k)],
            env=ENV,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for k in range(N)
    ]
    time.sleep(1.5)  # every process has imported setupfix and waits for the start
    go.touch()
    outs = [p.communicate(timeout=120) for p in procs]
    failed = [(k, err.strip().splitlines()[-1:]) for k, (_, err) in enumerate(outs) if procs[k].returncode]
    assert failed == [], failed
    assert sorted(out.strip() for out, _ in outs) == sorted(f"stored {k}" for k in range(N))
    with open_store(pg_url) as store:
        assert store.count("report") == N and store.count("measurement") == N
        assert {m.machine: m.reports for m in store.machines()} == {f"M{m}": 3 - (m > 1) for m in range(4)}
