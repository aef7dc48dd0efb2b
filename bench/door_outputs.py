"""Record what every door prints and writes on every bundled sample, as one SHA-256 per output.

Run before and after a change that must not change behaviour (a move of modules, a formatter):
the manifest (``bench/results/door_outputs.txt``) must come out byte-identical. Each case runs
``setupfix`` as a new process in a scratch folder of its own whose ``sample_reports`` is a link to
the repository's, so every path the tool prints is the same from one run to the next.

    python -m bench.door_outputs                 # write the manifest
    python -m bench.door_outputs --keep DIR      # also keep every output, to diff two runs
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_reports"
RESULT = ROOT / "bench" / "results" / "door_outputs.txt"
CONTROLLERS = ("csv", "fanuc", "haas", "heidenhain", "siemens")
#: Files in sample_reports that are not reports.
NOT_REPORTS = {".md", ".py", ".toml", ".png"}


@dataclass(frozen=True)
class Case:
    """One door run: a name, its command lines (run in order in one scratch folder), files it writes."""

    name: str
    commands: tuple[tuple[str, ...], ...]


def reports() -> list[str]:
    """Every bundled file a reader may be asked to read, relative to the repository."""
    found = []
    for path in sorted(SAMPLES.rglob("*")):
        if path.is_file() and path.suffix.lower() not in NOT_REPORTS and path.name != "current.csv":
            if "thermal" in path.parts or path.name in {"corrections.csv", "temperatures.csv", "truth.json"}:
                continue
            found.append(str(path.relative_to(ROOT)))
    return found


GUIDE = "sample_reports/guide_pins"
XYZ = "sample_reports/two_station_xyz"
CTRL = "sample_reports/controllers"
LOOP = "sample_reports/closed_loop"


def cases() -> Iterator[Case]:
    for i, report in enumerate(reports()):
        yield Case(f"parse-{i:02d}", (("parse", report, "--out", "-"),))
        yield Case(f"model-init-{i:02d}", (("model", "init", report, "-o", "model.toml"),))
    corrections = [
        (
            f"{GUIDE}/model.toml",
            [f"{GUIDE}/cycle_0{k}.csv" for k in range(1, 6)]
            + [f"{GUIDE}/cycle_01.dmo", f"{GUIDE}/cycle_01.qif", "sample_reports/tables/cycle_01_de.csv"],
            None,
        ),
        (f"{XYZ}/model.toml", [f"{XYZ}/cycle_0{k}.csv" for k in range(1, 4)], None),
        (f"{CTRL}/model.toml", [f"{CTRL}/report.csv"], f"{CTRL}/current.csv"),
    ]
    for model, files, current in corrections:
        for report in files:
            tag = f"{Path(model).parent.name}-{Path(report).name}"
            # the multi-axis solves take 1-2 s of the default 2 s: a longer limit keeps a busy box's answer proved
            limit = ("--time-limit", "60") if "two_station" in model else ()
            base = ("correct", "--model", model, report, *limit)
            yield Case(f"correct-text-{tag}", (base,))
            yield Case(f"correct-json-{tag}", ((*base, "--json"),))
            for controller in CONTROLLERS:
                out = ("--controller", controller, "--offsets", "offsets.out")
                yield Case(f"correct-{controller}-{tag}", ((*base, *out),))
                if current:
                    yield Case(f"correct-{controller}-current-{tag}", ((*base, *out, "--current", current),))
    yield Case(
        "correct-columns-shop",
        (
            (
                "correct",
                "--model",
                f"{GUIDE}/model.toml",
                "sample_reports/tables/cycle_01_shop.csv",
                "--columns",
                "sample_reports/tables/cycle_01_shop.columns.toml",
                "--json",
            ),
        ),
    )
    for folder in (GUIDE, XYZ):
        model = f"{folder}/model.toml"
        limit = ("--time-limit", "60") if folder == XYZ else ()
        for controller in CONTROLLERS:
            out = "out.csv" if controller == "csv" else "programs/O1000.nc"
            yield Case(
                f"batch-{controller}-{Path(folder).name}",
                (
                    (
                        "batch",
                        "--model",
                        model,
                        folder,
                        "--out",
                        out,
                        "--controller",
                        controller,
                        "--workers",
                        "1",
                        *limit,
                    ),
                ),
            )
        yield Case(
            f"batch-json-{Path(folder).name}",
            (("batch", "--model", model, folder, "--out", "out.csv", "--json", "--workers", "1", *limit),),
        )
    store = (
        "batch",
        "--model",
        f"{GUIDE}/model.toml",
        GUIDE,
        "--out",
        "out.csv",
        "--store",
        "shop.db",
        "--workers",
        "1",
    )
    yield Case("spc-store", (store, ("spc", "--db", "shop.db"), ("spc", "--db", "shop.db", "--json")))
    yield Case(
        "diagnose-store",
        (
            store,
            ("diagnose", "--db", "shop.db", "--model", f"{GUIDE}/model.toml"),
            ("diagnose", "--db", "shop.db", "--model", f"{GUIDE}/model.toml", "--json"),
        ),
    )
    loop = (
        "diagnose",
        "--model",
        f"{GUIDE}/model.toml",
        f"{LOOP}/measurements.csv",
        "--corrections",
        f"{LOOP}/corrections.csv",
    )
    yield Case("diagnose-loop", (loop, (*loop, "--json")))
    yield Case("diagnose-loop-thermal", ((*loop, "--temperatures", f"{LOOP}/temperatures.csv", "--json"),))
    yield Case(
        "diagnose-sheet-metal",
        (
            (
                "diagnose",
                "--model",
                f"{LOOP}/sheet_metal/model.toml",
                "sample_reports/qif/QIF3_SheetMetal_Results_6_samples.QIF",
                "--alpha",
                "0.05",
                "--json",
            ),
        ),
    )
    for report in (f"{GUIDE}/cycle_01.csv", f"{GUIDE}/cycle_03.csv"):
        base = ("compare", "--model", f"{GUIDE}/model.toml", report, "--trials", "3")
        yield Case(f"compare-{Path(report).name}", (base, (*base, "--json")))


#: Wall times the doors print: a solve's "(exact, optimal, 9 ms)", a batch's "0.4 s (18 reports/s)".
TIMES = re.compile(rb"\d+(\.\d+)? (ms|s)\b|\(\d+ reports/s\)")
#: JSON keys that hold wall times.
TIME_KEYS = re.compile(rb'("[a-z_]*seconds[a-z_]*"|"time_ms"): *(\[[^\]]*\]|[-0-9.e]+)')


def normalised(data: bytes) -> bytes:
    """The output with its wall times blanked: the only part of it that may differ between two runs."""
    data = TIME_KEYS.sub(rb"\1: <t>", data)
    data = TIMES.sub(b"<t>", data)
    # compare's table: the seconds column of each method row (the fourth number from the end)
    return re.sub(
        rb"(?m)^((?:exact|cripso|pso|ga|coa|cs)\s.*\s)\d+\.\d+(\s+-?\d+\.\d+\s+-?\d+\.\d+)$", rb"\1<t>\2", data
    )


def digest(data: bytes) -> str:
    return hashlib.sha256(normalised(data)).hexdigest()[:16]


def run(case: Case, scratch: Path, keep: Path | None) -> list[str]:
    folder = scratch / case.name
    folder.mkdir()
    (folder / "sample_reports").symlink_to(SAMPLES)
    env = {**os.environ, "COLUMNS": "100", "NO_COLOR": "1", "PYTHONHASHSEED": "0"}
    lines = []
    for k, command in enumerate(case.commands):
        done = subprocess.run(
            [sys.executable, "-m", "setupfix", *command],
            cwd=folder,
            env=env,
            capture_output=True,
            timeout=900,
            check=False,
        )
        lines.append(f"{case.name}#{k} rc={done.returncode} stdout={digest(done.stdout)} stderr={digest(done.stderr)}")
        if keep is not None:
            (keep / case.name).mkdir(parents=True, exist_ok=True)
            (keep / case.name / f"{k}.stdout").write_bytes(done.stdout)
            (keep / case.name / f"{k}.stderr").write_bytes(done.stderr)
    for path in sorted(folder.rglob("*")):
        if path.is_file() and not path.is_symlink() and "sample_reports" not in path.relative_to(folder).parts:
            if path.suffix == ".db":
                continue  # a store holds the time it was written; spc and diagnose read it back above
            rel = path.relative_to(folder)
            lines.append(f"{case.name} file {rel} {digest(path.read_bytes())}")
            if keep is not None:
                target = keep / case.name / "files" / rel
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(path, target)
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", type=Path, help="also keep every output in this folder")
    parser.add_argument("--out", type=Path, default=RESULT)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    all_cases = list(cases())
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda c: run(c, Path(tmp), args.keep), all_cases))
    lines = [line for block in results for line in block]
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"{len(all_cases)} cases, {len(lines)} outputs -> {args.out}")


if __name__ == "__main__":
    main()
