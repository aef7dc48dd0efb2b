"""LinuxCNC's standalone G-code interpreter ``rs274`` for the tests: an interpreter no one here wrote.

``.ci/run`` fetches it when missing (``apt-get download linuxcnc-uspace libboost-python1.74.0``,
unpacked with ``dpkg-deb -x`` into ``~/.cache/setupfix-ci/rs274/root``, nothing installed) and
sets ``SETUPFIX_RS274`` to ``…/root/usr/bin/rs274``; without the variable the tests look in that
cache folder.  Absent, a test is skipped with the reason — under ``CI`` it fails instead.

What it needs (found by trying): a tool table (``-t``, an empty file will do: without one it
stops with status 1 and prints nothing) and a parameter file (``-v``: it reads the offsets from
it and writes them back at the end, so each run gets a fresh copy); ``-g`` runs the whole file.
Its libraries are in the unpacked ``usr/lib`` and ``usr/lib/<multiarch>`` (``LD_LIBRARY_PATH``,
set here for the child process only).  It keeps the work offsets (parameters 5221 + 20·(n−1) +
axis, X = 0) in inches whatever ``G20``/``G21`` says, so :func:`read_back` reads them as
``#<n> = [#5221 * 25.4]`` in a millimetre program; ``(debug, …)`` prints six decimals.  It reads
``G10 L2`` as Fanuc does in absolute mode (``G90``) only: see :mod:`g10` for what it does not check.

Macro programs (``fanuc-macro``): rs274 numbers its work offsets as Fanuc does (``#5221`` … ``#5346``
for G54…G59), so :func:`read_parameters` reads what ``#5221=[#5221+0.012]`` left there, raw (no unit
scaling: an assignment writes the number as it stands).  It holds parameters ``#1`` … ``#5601`` only:
``#7001…`` (G54.1), ``#10001…``/``#12001…`` (tools above H200, radii) are out of its range, and
``#2001…`` are plain parameters there (no tool meaning).  Fanuc's one-line guard
``IF [#n EQ v] THEN #3000=k (TEXT)`` is not its syntax: :func:`linuxcnc_macro` rewrites it as an
``o``-word ``if`` with ``(abort, TEXT)``, which stops the run with an error.
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

__all__ = ["rs274_path", "run_rs274", "read_back", "read_parameters", "linuxcnc_macro", "AXIS_INDEX", "MAX_PARAMETER"]

#: Where ``.ci/run`` unpacks LinuxCNC when ``SETUPFIX_RS274`` is not set.
CACHE = Path.home() / ".cache" / "setupfix-ci" / "rs274" / "root" / "usr" / "bin" / "rs274"
#: The highest parameter number rs274 holds.
MAX_PARAMETER = 5601
#: Axis word → offset of its parameter after the coordinate system's first (5221 = G54 X).
AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}


def rs274_path() -> Path:
    """The ``rs274`` binary; skips the test (fails it under ``CI``) when it is absent."""
    named = os.environ.get("SETUPFIX_RS274")
    path = Path(named) if named else CACHE
    if path.is_file() and os.access(path, os.X_OK):
        return path
    why = (
        f"LinuxCNC rs274 not found at {path} ({'SETUPFIX_RS274=' + named if named else 'SETUPFIX_RS274 unset'}): "
        "run .ci/run once, or set SETUPFIX_RS274 to an unpacked linuxcnc-uspace's usr/bin/rs274"
    )
    if os.environ.get("CI"):
        pytest.fail(why)
    pytest.skip(why)


def _libraries(binary: Path) -> str:
    lib = binary.resolve().parent.parent / "lib"
    found = [str(lib), *sorted(str(p) for p in lib.glob("*-linux-gnu") if p.is_dir())]
    return os.pathsep.join(filter(None, [*found, os.environ.get("LD_LIBRARY_PATH", "")]))


def run_rs274(program: str, folder: Path, parameters: dict[int, float] | None = None) -> list[str]:
    """Run ``program`` in ``folder`` (fresh parameter file, optionally holding ``parameters`` [inch]); the
    texts of its ``(debug, …)`` messages, in order.

    Raises
    ------
    AssertionError
        rs274 reports an error (its message in the assertion).
    """
    binary = rs274_path()
    (folder / "tool.tbl").write_text("")
    (folder / "run.var").write_text("".join(f"{k}\t{v:.6f}\n" for k, v in sorted((parameters or {}).items())))
    (folder / "program.ngc").write_text(program)
    env = {**os.environ, "LD_LIBRARY_PATH": _libraries(binary)}
    done = subprocess.run(
        [str(binary), "-t", "tool.tbl", "-v", "run.var", "-g", "program.ngc"],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, f"rs274 refused the program: {done.stderr.strip() or done.stdout[-2000:]}"
    return re.findall(r'MESSAGE\("(.*)"\)', done.stdout)


def read_back(
    program: str,
    folder: Path,
    offsets: list[tuple[int, str]],
    *,
    inch: bool = False,
    parameters: dict[int, float] | None = None,
) -> dict[tuple[int, str], float]:
    """The work offsets ``offsets`` ((P, axis): ``(1, "X")`` = G54 X) after running ``program`` in rs274.

    The reads are appended before ``M30`` (values in the program's unit: parameters ×25.4 unless ``inch``).
    """
    lines = program.rstrip("\n").split("\n")
    end = lines.index("M30")
    scale = "" if inch else " * 25.4"
    reads = [f"#{100 + i} = [#{5221 + 20 * (p - 1) + AXIS_INDEX[axis]}{scale}]" for i, (p, axis) in enumerate(offsets)]
    debug = "(debug, " + " ".join(f"#{100 + i}" for i in range(len(offsets))) + ")"
    text = "\n".join([*lines[:end], *reads, debug, *lines[end:]]) + "\n"
    messages = run_rs274(text, folder, parameters)
    assert messages, "rs274 printed no debug message"
    values = [float(v) for v in messages[-1].split()]
    return dict(zip(offsets, values, strict=True))


_GUARD = re.compile(r"^IF \[#(\d+) EQ (\d+)\] THEN #3000=\d+ \((.*)\)$", re.M)


def linuxcnc_macro(program: str) -> str:
    """``program`` with Fanuc's one-line guard ``IF [#n EQ v] THEN #3000=k (TEXT)`` as rs274's
    ``o``-word ``if`` that aborts with TEXT (the run then fails, as the alarm stops a Fanuc)."""
    return _GUARD.sub(r"o900 if [#\1 EQ \2]\n(abort, \3)\no900 endif", program)


def read_parameters(
    program: str, folder: Path, numbers: list[int], *, parameters: dict[int, float] | None = None
) -> dict[int, float]:
    """The parameters ``numbers`` (raw, as stored) after running ``program`` in rs274 from ``parameters``.

    The reads are appended before ``M30``.
    """
    lines = program.rstrip("\n").split("\n")
    end = lines.index("M30")
    debug = "(debug, " + " ".join(f"#{n}" for n in numbers) + ")"
    messages = run_rs274("\n".join([*lines[:end], debug, *lines[end:]]) + "\n", folder, parameters)
    assert messages, "rs274 printed no debug message"
    values = [float(v) for v in messages[-1].split()]
    return dict(zip(numbers, values, strict=True))
