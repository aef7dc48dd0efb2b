"""The architecture's contract, checked on the source: the packages show the layers, each imports only below.

Layers, bottom to top (``CONTRIBUTING.md``): 1 plain data and core, 2 the readers, 3 the engine,
4 the store, inputs and outputs, then the use cases, then the views, 5 the doors (CLI and TUI).
A module may import its own package and any package of a lower rank, never one of a higher rank.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Rank of each package.  Layer 4 is ranked within: what is read and written, then the use cases that
#: read and write through them, then the views that render the use cases' results.
RANKS: dict[str, float] = {
    "setupfix.core": 1,
    "setupfix.model": 1,
    "parsers": 2,
    "setupfix.correction": 3,
    "setupfix.optimize": 3,
    "setupfix.search": 3,
    "setupfix.thermal": 3,
    "setupfix.diagnose": 3,
    "setupfix.spc": 3,
    "setupfix.store": 4.0,
    "setupfix.links": 4.0,
    "setupfix.inputs": 4.0,
    "setupfix.outputs": 4.0,
    "setupfix.usecases": 4.1,
    "setupfix.views": 4.2,
    "setupfix.cli": 5,
    "setupfix.tui": 5,
    "setupfix.__main__": 5,
}

#: Packages with no more than this many modules directly in them.
MAX_MODULES = 16


def rank_of(module: str) -> float | None:
    best = None
    for prefix, rank in RANKS.items():
        if module == prefix or module.startswith(prefix + "."):
            best = rank
    return best


def modules() -> Iterator[tuple[str, Path]]:
    for package in ("setupfix", "parsers"):
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            yield ".".join(rel.parts).removesuffix(".__init__"), path


def imports(path: Path) -> list[tuple[str, list[str]]]:
    """Every absolute import of a file (module, names imported from it), lazy ones included."""
    found: list[tuple[str, list[str]]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(a.name, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.module, [a.name for a in node.names]))
    return found


@pytest.mark.parametrize(("name", "path"), list(modules()), ids=lambda v: str(v) if isinstance(v, str) else "")
def test_module_imports_only_lower_layers(name: str, path: Path) -> None:
    own = rank_of(name)
    if own is None:
        assert name == "setupfix", f"{name} belongs to no layer: add its package to RANKS"
        return
    for target, _ in imports(path):
        if target.split(".")[0] == "textual":
            assert name.startswith("setupfix.tui"), f"{name} imports textual"
        rank = rank_of(target)
        if rank is not None:
            assert rank <= own, f"{name} (rank {own}) imports {target} (rank {rank})"


def test_every_package_has_a_rank() -> None:
    packages = {p.parent.name for p in (ROOT / "setupfix").glob("*/__init__.py")}
    assert {f"setupfix.{p}" for p in packages} <= set(RANKS)


@pytest.mark.parametrize("folder", sorted({p.parent for p in (ROOT / "setupfix").rglob("__init__.py")}), ids=str)
def test_packages_hold_few_modules_directly(folder: Path) -> None:
    own = [p for p in folder.glob("*.py") if p.name != "__init__.py"]
    assert len(own) <= MAX_MODULES, f"{folder} holds {len(own)} modules: split it along a seam"


OURS = {"setupfix", "parsers", "bench", "tests"}


def private_imports(path: Path) -> Iterator[str]:
    """Private names (``_x``) a file takes from another module of ours.

    Imports of private modules, private names imported, and private attributes read through a module of
    ours imported under a name (``import setupfix.x as m; m._y``).
    """
    tree = ast.parse(path.read_text(encoding="utf-8"))
    aliases: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in OURS:
                    aliases[a.asname or a.name.split(".")[0]] = a.name
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] not in OURS:
                continue
            if any(p.startswith("_") and not p.startswith("__") for p in node.module.split(".")):
                yield node.module
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__"):
                    yield f"{node.module}.{a.name}"
                else:
                    aliases[a.asname or a.name] = f"{node.module}.{a.name}"
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and not node.value.id[:1].isupper()  # a subclass extending its base's class attribute
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            yield f"{aliases[node.value.id]}.{node.attr}"


SOURCES = sorted(
    p
    for folder in ("setupfix", "parsers", "tests", "bench", "docs")
    for p in (ROOT / folder).rglob("*.py")
    if "golden" not in p.parts
)


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_name_crosses_a_module(path: Path) -> None:
    found = list(private_imports(path))
    assert not found, f"{path.relative_to(ROOT)} imports private names: {found}"


@pytest.mark.slow
def test_cli_and_parsers_do_not_load_textual() -> None:
    code = "import sys, setupfix.cli, parsers, setupfix.usecases.correct; print('textual' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "False"


def test_parsers_is_ours() -> None:
    import parsers

    assert Path(parsers.__file__).resolve().parent == ROOT / "parsers"


def test_the_checks_catch_what_they_forbid(tmp_path: Path) -> None:
    """The checks above fail on a module that breaks them (so a passing run means something)."""
    bad = tmp_path / "bad.py"
    bad.write_text(
        "from setupfix.optimize.exact import _hidden\nfrom setupfix.usecases import correct\n"
        "import setupfix.model.tables as t\nimport numpy as np\nt._KEYS, correct._x, np._priv, correct.ok\n"
    )
    assert list(private_imports(bad)) == [
        "setupfix.optimize.exact._hidden",
        "setupfix.model.tables._KEYS",
        "setupfix.usecases.correct._x",
    ]
    assert rank_of("setupfix.usecases.correct") > rank_of("setupfix.correction.pose")  # type: ignore[operator]
    assert rank_of("setupfix.views.present") > rank_of("setupfix.usecases.batch")  # type: ignore[operator]
