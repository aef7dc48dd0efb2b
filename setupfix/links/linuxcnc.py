"""The ``linuxcnc`` link: a running LinuxCNC's work offsets and tool table, through its Python module.

The link file names the instance's INI (``[link] ini``); the registers are LinuxCNC's own: the
work systems ``G54`` … ``G59.3`` with ``X``, ``Y``, ``Z`` and the XY rotation ``R`` (degrees), and
the tools by number, ``H<n>`` (or ``T<n>``) ``length`` and ``D<n>`` (or ``T<n>``) ``radius``; a model's
work rotation ``C`` (about the spindle) is ``R``.  LinuxCNC takes any value and keeps six decimals in
its files: ``[link] increment`` says the grid the values are written on (e.g. ``0.000001``).
Writes are MDI ``G10 L2 P<n> X Y Z R`` and ``G10 L1 P<t> Z R`` (``G10 L10``/``L11`` set an offset
from the current position, a touch-off, not a value: not used); reads come from ``stat``, each
work system selected in turn because ``stat`` shows only the active one.  Values are in the INI's
``[TRAJ] LINEAR_UNITS`` whatever ``[link] unit`` says ("units follow the INI").

The interlock is the control's own state: E-stop or off, not homed, a program running or paused,
an MDI command running: :meth:`LinuxcncLink.interlocked` is true and nothing is written.

The module ``linuxcnc`` is compiled against the control's libraries, so a helper process
(:mod:`setupfix.links.linuxcnc_agent`, run from its source) talks to the control.  Its
environment comes from three variables, all optional:

``SETUPFIX_LINUXCNC_ROOT``
    An unpacked ``linuxcnc-uspace`` tree (``dpkg-deb -x``): its ``usr/lib/python3/dist-packages``
    and libraries are used.  Unset: the installed LinuxCNC.
``SETUPFIX_LINUXCNC_PYTHON``
    The Python that runs the helper (default: this one; the module needs the version it was built for).
``SETUPFIX_LINUXCNC_ENTER``
    A command prefix (split as a shell would) that runs the helper where the control's shared
    memory is, e.g. ``nsenter …`` for a simulated control in its own namespaces.

LinuxCNC keeps the work offsets in its parameter file, written when it shuts down: an offset
written and then lost in a crash of the control is not held after the restart.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import selectors
import shlex
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from types import TracebackType
from typing import IO, Any

from setupfix.core.errors import SourceLocation
from setupfix.links.base import LENGTH, RADIUS, Component
from setupfix.links.config import LinkConfig
from setupfix.links.errors import (
    LinkConfigError,
    LinkDenied,
    LinkError,
    LinkLost,
    LinkRefused,
    LinkUnreachable,
)

__all__ = ["LinuxcncLink", "open_linuxcnc", "SYSTEMS", "parse_register", "word", "agent_command"]

#: LinuxCNC's work systems, number 1 … 9.
SYSTEMS = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")
#: The components of a work system.
WKS_AXES = ("X", "Y", "Z", "R")
_TOOL = re.compile(r"^([HDT])(\d+)$", re.IGNORECASE)
#: Seconds the helper may take to start and find the control.
START_TIMEOUT = 20.0


def parse_register(component: Component) -> tuple[str, int] | None:
    """``("wks", n)`` or ``("tool", n)`` for a component LinuxCNC has, None for any other.

    ``G54.X`` → ``("wks", 1)``; ``G54.C`` (the model's rotation about the spindle) is LinuxCNC's ``R``;
    ``H5 length``, ``D5 radius``, ``T5 length|radius`` → ``("tool", 5)``.
    """
    name = component.register.strip().upper()
    if name in SYSTEMS:
        return ("wks", SYSTEMS.index(name) + 1) if component.axis in (*WKS_AXES, "C") else None
    m = _TOOL.match(name)
    if m is None or int(m.group(2)) <= 0:
        return None
    letter = m.group(1).upper()
    fits = {"H": (LENGTH,), "D": (RADIUS,), "T": (LENGTH, RADIUS)}[letter]
    return ("tool", int(m.group(2))) if component.axis in fits else None


def word(component: Component) -> str:
    """The G10 word of a component: its axis, ``R`` for a work system's rotation ``C`` (about the spindle:
    LinuxCNC's XY rotation), ``length``/``radius`` for a tool."""
    return "R" if component.axis == "C" else component.axis


def agent_command(environ: Mapping[str, str] | None = None) -> tuple[list[str], dict[str, str]]:
    """The helper's command line and environment, from the ``SETUPFIX_LINUXCNC_*`` variables."""
    env = dict(os.environ if environ is None else environ)
    root = env.get("SETUPFIX_LINUXCNC_ROOT", "").strip()
    python = env.get("SETUPFIX_LINUXCNC_PYTHON", "").strip() or sys.executable
    enter = shlex.split(env.get("SETUPFIX_LINUXCNC_ENTER", ""))
    modules = ""
    if root:
        base = Path(root)
        modules = str(base / "usr" / "lib" / "python3" / "dist-packages")
        libs = [str(base / "usr" / "lib"), *sorted(str(p) for p in (base / "usr" / "lib").glob("*-linux-gnu"))]
        env["LD_LIBRARY_PATH"] = os.pathsep.join(filter(None, [*libs, env.get("LD_LIBRARY_PATH", "")]))
    source = Path(__file__).with_name("linuxcnc_agent.py").read_text(encoding="utf-8")
    return [*enter, python, "-c", source, modules], env


class LinuxcncLink:
    """An open link to one running LinuxCNC (see the module docstring); a context manager."""

    def __init__(self, config: LinkConfig, *, environ: Mapping[str, str] | None = None) -> None:
        if not config.ini:
            raise LinkConfigError(
                "a linuxcnc link needs [link] ini", location=SourceLocation(config.path, key="link.ini")
            )
        if not Path(config.ini).is_file():
            raise LinkConfigError(
                f"no such INI file: {config.ini}", location=SourceLocation(config.path, key="link.ini")
            )
        self.config = config
        self.name = f"LinuxCNC {config.ini} ({config.path})"
        self.increment = config.increment
        self.timeout = config.timeout
        self.interlock_reason: str | None = None
        command, env = agent_command(environ)
        self._errors: IO[bytes] = tempfile.TemporaryFile()  # noqa: SIM115 - open as long as the helper runs
        try:
            self._process = subprocess.Popen(
                command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._errors, env=env
            )
        except OSError as exc:
            self._errors.close()
            raise LinkUnreachable(f"{self.name}: cannot start the LinuxCNC helper ({exc})") from None
        try:
            hello = self._ask({"op": "hello", "ini": config.ini}, START_TIMEOUT, lost=LinkUnreachable)
        except LinkError:
            self.close()
            raise
        self.unit: str = str(hello["unit"])
        self.machine: str | None = config.machine or (str(hello["machine"]) if hello.get("machine") else None)

    # -- the helper's answers --------------------------------------------------------------
    def _ask(self, request: dict[str, Any], timeout: float, *, lost: type[LinkError] = LinkLost) -> dict[str, Any]:
        """One request, its answer; ``lost`` raised when the helper is gone or silent."""
        process = self._process
        assert process.stdin is not None and process.stdout is not None
        try:
            process.stdin.write((json.dumps(request) + "\n").encode())
            process.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            raise lost(f"{self.name}: the LinuxCNC helper is gone{self._why()}") from None
        line = b""
        deadline = time.monotonic() + timeout
        with selectors.DefaultSelector() as sel:
            sel.register(process.stdout, selectors.EVENT_READ)
            while not line.endswith(b"\n"):
                left = deadline - time.monotonic()
                if left <= 0 or not sel.select(left):
                    process.kill()
                    raise lost(f"{self.name}: no answer from LinuxCNC within {timeout:g} s")
                chunk = os.read(process.stdout.fileno(), 65536)
                if not chunk:
                    raise lost(f"{self.name}: the LinuxCNC helper stopped{self._why()}")
                line += chunk
        answer: dict[str, Any] = json.loads(line)
        if answer.get("ok"):
            return answer
        kind, message = answer.get("kind"), f"{self.name}: {answer.get('message')}"
        if kind == "unreachable":
            raise LinkUnreachable(message)
        if kind == "lost":
            raise LinkLost(f"{message} (the control stopped answering)")
        if kind == "busy":
            raise LinkRefused(f"{message}: nothing written")
        if kind == "unknown":
            raise LinkConfigError(
                f"{answer.get('message')} (LinuxCNC {self.config.ini})",
                location=SourceLocation(self.config.path, key="link.ini"),
            )
        done = answer.get("done")
        raise LinkDenied(message if done is None else f"{message} ({done} register(s) before it written)")

    def _why(self) -> str:
        """The helper's last words (its stderr's last line), for a message."""
        try:
            self._process.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            return ""
        self._errors.seek(0)
        lines = [ln for ln in self._errors.read().decode(errors="replace").splitlines() if ln.strip()]
        return f" (status {self._process.returncode}{': ' + lines[-1].strip() if lines else ''})"

    # -- the Link interface ----------------------------------------------------------------
    def components(self) -> tuple[Component, ...]:
        """Every work system's X, Y, Z, R and every tool's length (``H<n>``) and radius (``D<n>``)."""
        tools = self._ask({"op": "table"}, self.timeout)["tools"]
        wks = [Component(s, a) for s in SYSTEMS for a in WKS_AXES]
        return (*wks, *(c for n in tools for c in (Component(f"H{n}", LENGTH), Component(f"D{n}", RADIUS))))

    def _kinds(self, components: Iterable[Component]) -> dict[Component, tuple[str, int]]:
        found = {c: parse_register(c) for c in components}
        bad = [f"{c.register} {c.axis}" if c.tool else f"{c.register}.{c.axis}" for c, k in found.items() if k is None]
        if bad:
            raise LinkConfigError(
                f"LinuxCNC ({self.config.ini}) has no register component {', '.join(bad)}"
                " (work systems G54…G59.3 with X, Y, Z, R; tools H<n> length, D<n> radius, T<n> either)",
                location=SourceLocation(self.config.path, key="link.ini"),
            )
        return {c: k for c, k in found.items() if k is not None}

    def read(self, components: Iterable[Component]) -> dict[Component, float]:
        """The values the control holds now (INI unit; the rotation in degrees).

        Raises
        ------
        LinkConfigError
            A component LinuxCNC does not have, or a tool not in its table (all named).
        LinkRefused
            The control is busy (a work system can be read only from MDI).
        LinkLost
        """
        kinds = self._kinds(components)
        systems = sorted({n for k, n in kinds.values() if k == "wks"})
        tools = sorted({n for k, n in kinds.values() if k == "tool"})
        answer = self._ask({"op": "read", "systems": systems, "tools": tools}, self.timeout * (1 + len(systems)))
        out: dict[Component, float] = {}
        for comp, (kind, n) in kinds.items():
            if kind == "wks":
                out[comp] = float(answer["systems"][str(n)][WKS_AXES.index(word(comp))])
            else:
                out[comp] = float(answer["tools"][str(n)][0 if comp.axis == LENGTH else 1])
        return out

    def write(self, values: Mapping[Component, float]) -> None:
        """MDI ``G10`` lines, one per register, in the order the values first name it.

        Raises
        ------
        LinkRefused
            The control is busy (nothing written).
        LinkDenied
            The control refused a line (the ones before it are written).
        LinkLost
            The control or the helper stopped mid-way.
        """
        kinds = self._kinds(values)
        items: dict[tuple[str, int], dict[str, float]] = {}
        for comp, value in values.items():
            items.setdefault(kinds[comp], {})[word(comp)] = float(value)
        request = {"op": "write", "items": [[k, n, v] for (k, n), v in items.items()]}
        self._ask(request, self.timeout * (1 + len(items)))

    def interlocked(self) -> bool:
        """True when the control refuses offset writes now; :attr:`interlock_reason` says why."""
        self.interlock_reason = self._ask({"op": "state"}, self.timeout)["busy"]
        return self.interlock_reason is not None

    def close(self) -> None:
        """End the helper (it leaves the control as it was) and free its pipes."""
        process = getattr(self, "_process", None)
        if process is not None:
            if process.stdin is not None:
                with contextlib.suppress(OSError):
                    process.stdin.close()
            try:
                process.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            if process.stdout is not None:
                process.stdout.close()
        self._errors.close()

    def __enter__(self) -> LinuxcncLink:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()


def open_linuxcnc(config: LinkConfig) -> LinuxcncLink:
    """The opener :data:`setupfix.links.LINKS` names for ``protocol = "linuxcnc"``."""
    return LinuxcncLink(config)
