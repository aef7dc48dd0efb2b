"""The architecture's layer contract, checked on the source: each layer imports only those below it."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Layer of each top-level module prefix; a module may import only layers <= its own.
LAYERS = {
    "setupfix.errors": 1,
    "setupfix.units": 1,
    "setupfix.model": 1,
    "setupfix.atomic": 1,
    "setupfix.params": 1,
    "parsers": 2,
    "setupfix.relation": 3,
    "setupfix.objective": 3,
    "setupfix.optimize": 3,
    "setupfix.thermal": 3,
    "setupfix.search": 3,
    "setupfix.simulate": 3,
    "setupfix.offsets": 3,
    "setupfix.plots": 3,
    "setupfix.diagnose": 3,
    "setupfix.safety": 3,
    "setupfix.ewma": 3,
    "setupfix.recommend": 3,
    "setupfix.pose": 3,
    "setupfix.explain": 3,
    "setupfix.zones": 3,
    "setupfix.spc": 3,
    "setupfix.pipeline": 4,
    "setupfix.store": 4,
    "setupfix.cli": 5,
    "setupfix.tui": 5,
    "setupfix.__main__": 5,
}


def layer_of(module: str) -> int | None:
    best = None
    for prefix, layer in LAYERS.items():
        if module == prefix or module.startswith(prefix + "."):
            best = layer
    return best


def modules():
    for package in ("setupfix", "parsers"):
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            name = ".".join(rel.parts).removesuffix(".__init__")
            yield name, path


def imports(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append(node.module)
    return found


@pytest.mark.parametrize(("name", "path"), list(modules()), ids=lambda v: str(v) if isinstance(v, str) else "")
def test_module_imports_only_lower_layers(name, path):
    own = layer_of(name)
    if own is None:
        assert name == "setupfix", f"{name} belongs to no layer: add it to LAYERS"
        return
    for target in imports(path):
        if target.split(".")[0] == "textual":
            assert name.startswith("setupfix.tui"), f"{name} imports textual"
        layer = layer_of(target)
        if layer is not None:
            assert layer <= own, f"{name} (layer {own}) imports {target} (layer {layer})"


def test_cli_and_parsers_do_not_load_textual():
    code = "import sys, setupfix.cli, parsers, setupfix.pipeline.correct; print('textual' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "False"


def test_parsers_is_ours():
    import parsers

    assert Path(parsers.__file__).resolve().parent == ROOT / "parsers"


# Sub-layers of setupfix.pipeline (layer 4).  A module imports only pipeline modules of a lower rank, so no
# use case reaches into another one's module for a helper, and renderers and doors sit on top:
# 0-1 file writers, checks, controller syntaxes, thermal-model files and log columns, report cycles, a
# series' logs as arrays; 2 use cases that need no request (thermal predict, parse, simulate, model
# init/check) and a series' cycles assembled; 3 the feed-forward step, the series reader and thermal
# fit/evaluate; 4 the typed requests and outcomes; 5 the use cases on a
# request (correct, compare) and the one export; 6 use cases that run correct (batch on a folder, the
# diagnosis's next correction);
# 7 renderers (text/JSON, TUI rows); 8 the doors' sessions (TUI session, history store).
PIPELINE_RANKS = {
    "writers": 0,
    "checks": 0,
    "smoothing": 0,
    "stores": 0,
    "controllers": 1,
    "thermal_files": 1,
    "thermal_columns": 1,
    "cycles": 1,
    "scaffold_toml": 1,
    "series_logs": 1,
    "thermal": 2,
    "parse": 2,
    "simulate": 2,
    "scaffold": 2,
    "model": 2,
    "series_assembly": 2,
    "feedforward": 3,
    "series": 3,
    "thermal_fit": 3,
    "batch_output": 3,
    "requests": 4,
    "correct": 5,
    "compare": 5,
    "export": 5,
    "batch_records": 5,
    "spc": 5,
    "dfq": 1,
    "batch": 6,
    "diagnose": 6,
    "present": 7,
    "view": 7,
    "analysis_view": 7,
    "history": 8,
    "session": 8,
    "html_report": 8,
}


def _pipeline_module(module: str) -> str | None:
    parts = module.split(".")
    return parts[2] if len(parts) > 2 and parts[:2] == ["setupfix", "pipeline"] else None


def test_every_pipeline_module_has_a_rank():
    names = {
        p.stem if p.suffix else p.name
        for p in (ROOT / "setupfix" / "pipeline").iterdir()
        if (p.suffix == ".py" and p.stem != "__init__") or (p.is_dir() and (p / "__init__.py").exists())
    }
    assert names == set(PIPELINE_RANKS)


@pytest.mark.parametrize("name", sorted(PIPELINE_RANKS))
def test_pipeline_modules_import_only_lower_ranks(name):
    folder = ROOT / "setupfix" / "pipeline"
    paths = sorted((folder / name).rglob("*.py")) if (folder / name).is_dir() else [folder / f"{name}.py"]
    own = PIPELINE_RANKS[name]
    for path in paths:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom) or not node.module or node.level:
                continue
            targets = (
                [_pipeline_module(node.module)]
                if _pipeline_module(node.module)
                else [a.name for a in node.names]
                if node.module == "setupfix.pipeline"
                else []
            )
            for target in targets:
                if target is None or target == name:
                    continue
                assert target in PIPELINE_RANKS, f"{path.name} imports setupfix.pipeline.{target}: give it a rank"
                rank = PIPELINE_RANKS[target]
                assert rank < own, f"setupfix.pipeline.{name} (rank {own}) imports pipeline.{target} (rank {rank})"
