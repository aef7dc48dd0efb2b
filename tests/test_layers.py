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
    "setupfix.errors": 1, "setupfix.units": 1, "setupfix.model": 1, "setupfix.atomic": 1, "setupfix.params": 1,
    "parsers": 2,
    "setupfix.relation": 3, "setupfix.objective": 3, "setupfix.optimize": 3, "setupfix.thermal": 3,
    "setupfix.search": 3, "setupfix.simulate": 3, "setupfix.offsets": 3, "setupfix.plots": 3, "setupfix.diagnose": 3,
    "setupfix.safety": 3, "setupfix.pose": 3,
    "setupfix.pipeline": 4, "setupfix.store": 4,
    "setupfix.cli": 5, "setupfix.tui": 5, "setupfix.__main__": 5,
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
