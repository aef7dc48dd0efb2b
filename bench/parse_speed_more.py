"""Reading speed of the issue-3 readers: characteristics per second per format.

Each input is a real sample (or, for PC-DMIS, a constructed fixture) repeated until it
holds about ``--rows`` characteristics, written to a temporary folder.  Every reader is
timed (best of ``--repeat``) and set against ``pandas.read_csv`` of the canonical CSV
of the same rows, measured in the same run: the ratio is machine-independent.  Samples
from ``../shared`` are used when present and their formats skipped otherwise.

    python -m bench.parse_speed_more            # writes bench/results/parse_speed_more.txt
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]

import parsers
from parsers.ogp.rtf import rtf_lines

#: ../shared beside the project, or SETUPFIX_SHARED (as for the tests).
SHARED = Path(os.environ.get("SETUPFIX_SHARED", ROOT.parent / "shared")) / "cmm-samples"
SAMPLES = ROOT / "sample_reports"
OUT = ROOT / "bench" / "results" / "parse_speed_more.txt"
#: Formats whose content is a table (one line or object per value); the OGP run table is a
#: paginated printout and counts as a text report.
TABLE_LIKE = {"qdas", "pcdmis-csv", "piweb"}


def _qdas(folder: Path, rows: int) -> Path:
    chars = 10
    head = [f"K0100 {chars}", "K1001/1 BENCH"]
    for i in range(1, chars + 1):
        head += [
            f"K2001/{i} C{i}",
            f"K2002/{i} Char {i}",
            f"K2101/{i} {10 * i}",
            f"K2110/{i} {10 * i - 0.05}",
            f"K2111/{i} {10 * i + 0.05}",
            f"K2142/{i} mm",
        ]
    line = "\x0f".join(
        f"{10 * i + 0.0123:.4f}\x140\x1417.05.2002/05:54:58\x14\x14\x140\x1449\x140\x14\x140"
        for i in range(1, chars + 1)
    )
    path = folder / "bench.dfq"
    path.write_text("\r\n".join(head + [line] * (rows // chars)) + "\r\n")
    return path


def _repeat_lines(source: Path, folder: Path, name: str, copies: int, encoding: str, keep_head: int = 0) -> Path:
    lines = source.read_bytes().decode(encoding).split("\n")
    body = lines[keep_head:]
    path = folder / name
    path.write_bytes("\n".join(lines[:keep_head] + body * copies).encode(encoding))
    return path


def _ogp_step(folder: Path, copies: int) -> Path | None:
    src = SHARED / "ogp_measurex" / "OGP_L0_axial_top_module1_1.rtf.txt"
    if not src.exists():
        return None
    lines = rtf_lines(src.read_bytes().decode("cp1252"))
    path = folder / "ogp_step.txt"
    path.write_text("\n".join(lines * copies))
    return path


def _qvpak(folder: Path, rows: int) -> Path:
    heading = (
        "        Elemento           Atual         Nominal          Desvio        Tol.sup.        Tol.inf."
        "        De./Fora"
    )
    lines = ["", heading]
    for i in range(rows):
        lines += [
            f"Distância: Dist-{i}(ID:{i}) entre Ponto-1(ID:1) e Ponto-2(ID:2)",
            "           DX =        44,158745       44,150000        0,008745        0,010000       -0,010000"
            "              De",
            "",
        ]
    path = folder / "qvpak.txt"
    path.write_bytes("\r\n".join(lines).encode("cp1252"))
    return path


def _piweb(folder: Path, copies: int) -> Path:
    values = json.loads((SAMPLES / "piweb" / "PiWebApi_sample_values.json").read_text(encoding="utf-8-sig"))
    characteristics = SAMPLES / "piweb" / "PiWebApi_sample_characteristics.json"
    (folder / "b_characteristics.json").write_bytes(characteristics.read_bytes())
    path = folder / "b_values.json"
    path.write_text(json.dumps(values * copies))
    return path


def _best(call: Callable[[], object], repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=100_000, help="characteristics per input (approx.)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        inputs: list[tuple[str, str, Path | None]] = [
            ("qdas", "qdas", _qdas(folder, args.rows)),
            (
                "pcdmis",
                "pcdmis",
                _repeat_lines(SAMPLES / "pcdmis" / "bracket_two_parts.txt", folder, "pc.txt", args.rows // 14, "ascii"),
            ),
            (
                "pcdmis-csv",
                "pcdmis-csv",
                _repeat_lines(
                    SAMPLES / "pcdmis" / "bracket_ncgage.csv", folder, "pc.csv", args.rows // 5, "ascii", keep_head=5
                ),
            ),
            ("piweb", "piweb", _piweb(folder, max(1, args.rows // 27_000))),
            ("qvpak", "qvpak", _qvpak(folder, args.rows)),
        ]
        run = SHARED / "ogp_measurex" / "OGP_L123_fixture_sho_multirun.txt"
        inputs.append(
            (
                "ogp run table",
                "ogp",
                _repeat_lines(run, folder, "run.txt", args.rows // 429, "ascii") if run.exists() else None,
            )
        )
        inputs.append(("ogp step report", "ogp", _ogp_step(folder, args.rows // 42)))
        kr = SHARED / "korean_cmm_txt" / "KR_45926-4G100_240321_day_1-2-1_OK.cp949.txt"
        inputs.append(
            (
                "korean",
                "korean",
                _repeat_lines(kr, folder, "kr.txt", args.rows // 100, "cp949", keep_head=7) if kr.exists() else None,
            )
        )
        lines = [
            f"$ python -m bench.parse_speed_more --rows {args.rows} --repeat {args.repeat}",
            f"python {sys.version.split()[0]}, pandas {pd.__version__}; best of {args.repeat}; "
            "ratio = reader time / pandas.read_csv time of the canonical CSV of the same rows",
            "",
            f"{'format':<16} {'chars':>8} {'seconds':>8} {'chars/s':>10} {'read_csv s':>10} {'ratio':>6}  kind",
        ]
        for label, fmt, path in inputs:
            if path is None:
                lines.append(f"{label:<16} skipped: ../shared sample absent")
                continue
            table = parsers.read_report(path, format=fmt).table
            seconds = _best(functools.partial(parsers.read_report, path, format=fmt), args.repeat)
            csv_path = folder / "ref.csv"
            table.to_csv(csv_path, index=False)
            reference = _best(functools.partial(pd.read_csv, csv_path), args.repeat)
            kind = "table-like" if label in TABLE_LIKE else "text report"
            lines.append(
                f"{label:<16} {len(table):>8} {seconds:>8.3f} {len(table) / seconds:>10,.0f} "
                f"{reference:>10.3f} {seconds / reference:>6.1f}  {kind}"
            )
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
