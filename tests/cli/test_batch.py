"""`setupfix batch` end to end: exit status, summary, stderr, a killed run leaves no file."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

from setupfix.cli import main

from conftest import GUIDE_PINS, ROOT

MODEL = str(GUIDE_PINS / "model.toml")


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_exit_status_summary_and_bad_file_named(capsys, tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    shutil.copy(GUIDE_PINS / "cycle_01.csv", d / "a.csv")
    code, out, err = run(capsys, "batch", "--model", MODEL, str(d), "--out", str(tmp_path / "o.csv"),
                         "--settle", "0", "--json")
    assert code == 0 and json.loads(out)["verdicts"] == {"apply": 1} and "[1/1]" in err
    (d / "broken.csv").write_text("characteristic,nominal,actual\nP1 D1,25,abc\n")
    code, out, err = run(capsys, "batch", "--model", MODEL, str(d), "--out", str(tmp_path / "o.csv"),
                         "--settle", "0")
    assert code == 4
    assert "1 report(s), 1 part(s): 1 apply, 0 hold, 0 reject" in out and "1 failed" in out
    assert "broken.csv:2: column 'actual'" in err and "Traceback" not in err
    code, _, err = run(capsys, "batch", "--model", MODEL, str(tmp_path / "nope"), "--out", str(tmp_path / "o.csv"))
    assert code == 1 and "is not a folder" in err


def test_killed_run_leaves_no_partial_file(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    for i in range(20):  # distinct contents, so none is skipped as a duplicate
        text = (GUIDE_PINS / "cycle_01.csv").read_text().replace("2026-11-02T08:00:00", f"2026-11-02T08:{i:02d}:00")
        (d / f"r{i:03d}.csv").write_text(text)
    out = tmp_path / "o.csv"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "setupfix", "batch", "--model", MODEL, str(d), "--out", str(out),
                             "--settle", "0"], cwd=ROOT, env=env, stderr=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True)
    assert proc.stderr is not None
    first = proc.stderr.readline()  # the first report is done: the output is being written
    assert first.startswith("[1/20]"), first
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=60)
    assert proc.returncode != 0
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["in"]  # no temporary file left either
