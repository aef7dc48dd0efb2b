"""The process that talks to a running LinuxCNC for :mod:`setupfix.links.linuxcnc`.

LinuxCNC's Python module (``linuxcnc``) is a compiled extension tied to the control's own
libraries and shared memory, so it runs in a process of its own, next to the control: started by
the link with the control's environment (``LD_LIBRARY_PATH``/``PYTHONPATH`` of an unpacked tree,
or inside the namespaces of a simulated control), it reads one JSON request per line on stdin and
answers one JSON line on stdout.  It imports nothing from setupfix (it may run from its source
text alone) and never moves an axis: it does not reset an E-stop, switch the machine on or home.

Requests (``op``) and answers (``ok`` true, or false with ``kind`` and ``message``):

- ``hello`` with ``ini``: ``unit`` (``"mm"`` or ``"inch"``, the INI's ``[TRAJ] LINEAR_UNITS``)
  and ``machine`` (``[EMC] MACHINE``).  ``kind`` ``"unreachable"`` when the module is missing or
  no control answers.
- ``state``: ``busy`` (None, or why the control refuses offset writes now: E-stop or off, not
  homed, a program running or paused, an MDI command running).
- ``table``: ``tools``, the tool numbers in the control's tool table.
- ``read`` with ``systems`` (1…9 for G54…G59.3) and ``tools`` (numbers): ``systems`` maps each
  to ``[x, y, z, r]`` (machine unit, degrees), ``tools`` each to ``[length, radius]``.  Reading a
  work system selects it in turn (``stat`` shows only the active one); the active system, the
  program units and the task mode are restored afterwards.
- ``write`` with ``items``, each ``["wks", n, {"X": …, "R": …}]`` (``G10 L2 Pn``) or ``["tool",
  n, {"length": …, "radius": …}]`` (``G10 L1 Pn Z R``), in the machine unit: sent in order under
  ``G20``/``G21`` as the INI's unit says; ``done`` counts the items written.  ``kind`` ``"busy"``
  (nothing written) or ``"denied"`` (the control's error message; the items before it written).

Kinds of failure: ``unreachable``, ``busy``, ``denied``, ``lost`` (the control stopped answering: a
command or a status change not seen within :data:`STEP_TIMEOUT`), ``unknown`` (a tool not in the table, a
system out of range), ``bad`` (a request this agent does not understand).
"""

from __future__ import annotations

import importlib
import json
import sys
import time
from collections.abc import Callable
from typing import Any

#: G-code of work system n (1…9).
SYSTEMS = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")
#: Seconds one MDI command or mode switch may take.
STEP_TIMEOUT = 5.0


class Failure(Exception):
    """A request that cannot be answered: ``kind`` says which failure (see the module docstring)."""

    def __init__(self, kind: str, message: str, **extra: Any) -> None:
        super().__init__(message)
        self.kind = kind
        self.extra = extra


class Control:
    """One running LinuxCNC: its ``stat``, ``command`` and ``error_channel``."""

    def __init__(self, ini: str) -> None:
        try:
            self.lc: Any = importlib.import_module("linuxcnc")
        except ImportError as exc:
            raise Failure("unreachable", f"LinuxCNC's Python module cannot be imported ({exc})") from None
        try:
            conf = self.lc.ini(ini)
            units = (conf.find("TRAJ", "LINEAR_UNITS") or "").strip().lower()
            self.machine = (conf.find("EMC", "MACHINE") or "").strip() or None
        except Exception as exc:  # noqa: BLE001 - the module raises its own types for a missing or bad INI
            raise Failure("unreachable", f"cannot read the INI file {ini}: {exc}") from None
        if units in ("mm", "metric"):
            self.unit = "mm"
        elif units in ("inch", "in", "imperial"):
            self.unit = "inch"
        else:
            raise Failure("unreachable", f"the INI file {ini} gives no [TRAJ] LINEAR_UNITS of mm or inch ({units!r})")
        try:
            self.stat = self.lc.stat()
            self.command = self.lc.command()
            self.errors = self.lc.error_channel()
            self.stat.poll()
        except Exception as exc:  # noqa: BLE001 - linuxcnc.error and its kin: no control answers
            raise Failure("unreachable", f"no LinuxCNC answers ({exc})") from None

    # -- state -------------------------------------------------------------------------------
    def busy(self) -> str | None:
        """Why the control refuses offset writes now, or None."""
        lc, s = self.lc, self.stat
        s.poll()
        if s.task_state != lc.STATE_ON:
            return "the machine is off or in E-stop"
        joints = int(getattr(s, "joints", 0) or len(s.homed))
        if not all(s.homed[:joints]):
            return "the machine is not homed (LinuxCNC takes no MDI command before)"
        if s.interp_state == lc.INTERP_PAUSED:
            return "a program is paused"
        if s.interp_state != lc.INTERP_IDLE:
            return "a program is running" if s.task_mode == lc.MODE_AUTO else "an MDI command is running"
        return None

    def drain_errors(self) -> None:
        while self.errors.poll():
            pass

    def check(self, what: str) -> None:
        """Wait for the command sent; raise ``denied`` with the control's message on an error."""
        done = self.command.wait_complete(STEP_TIMEOUT)
        message = self.errors.poll()
        if message:
            raise Failure("denied", f"{what}: the control says {message[1].strip()!r}")
        if done == -1:
            raise Failure("lost", f"{what}: no answer within {STEP_TIMEOUT:g} s")
        if done == self.lc.RCS_ERROR:
            raise Failure("denied", f"{what}: the control reports an error")
        self.until(
            lambda: self.stat.interp_state == self.lc.INTERP_IDLE, f"{what}: the interpreter to come back to idle"
        )

    def until(self, condition: Callable[[], bool], what: str, timeout: float = STEP_TIMEOUT) -> bool:
        """Poll ``stat`` until ``condition`` holds (its status lags the command by a cycle or more).

        False after ``timeout`` seconds when ``what`` is empty, else ``denied`` naming it."""
        deadline = time.monotonic() + timeout
        while True:
            self.stat.poll()
            if condition():
                return True
            if time.monotonic() > deadline:
                if not what:
                    return False
                raise Failure("lost", f"waited {timeout:g} s for {what}")
            time.sleep(0.005)

    def select(self, n: int) -> None:
        """Make work system ``n`` the active one and wait until ``stat`` shows it.

        After an abort the interpreter may already hold ``n`` while ``stat`` still shows the
        system before: the G-code then changes nothing and ``stat`` never follows.  Another
        system first, then ``n``, makes both agree."""
        self.mdi(SYSTEMS[n - 1])
        if self.until(lambda: int(self.stat.g5x_index) == n, "", 0.5):
            return
        self.mdi(SYSTEMS[n % len(SYSTEMS)])
        self.mdi(SYSTEMS[n - 1])
        self.until(lambda: int(self.stat.g5x_index) == n, f"{SYSTEMS[n - 1]} to become the active system")

    def mdi(self, line: str) -> None:
        self.command.mdi(line)
        self.check(line)

    # -- a session in MDI, restored at the end -------------------------------------------------
    def session(self) -> tuple[int, int, int]:
        """Enter MDI (refused when busy); the mode, work system and program units to restore."""
        why = self.busy()
        if why:
            raise Failure("busy", why)
        self.drain_errors()
        s = self.stat
        before = (int(s.task_mode), int(s.g5x_index), int(s.program_units))
        if s.task_mode != self.lc.MODE_MDI:
            self.command.mode(self.lc.MODE_MDI)
            self.check("switch to MDI")
            self.stat.poll()
            if self.stat.task_mode != self.lc.MODE_MDI:
                raise Failure("busy", "the control did not switch to MDI")
        return before

    def restore(self, before: tuple[int, int, int]) -> None:
        mode, system, units = before
        if 1 <= system <= len(SYSTEMS):
            self.select(system)
        self.mdi({1: "G20", 2: "G21"}.get(units, "G21"))
        if mode != self.lc.MODE_MDI:
            self.command.mode(mode)
            self.command.wait_complete(STEP_TIMEOUT)

    # -- reading and writing -----------------------------------------------------------------
    def tools(self) -> dict[int, tuple[float, float]]:
        self.stat.poll()
        return {int(t.id): (float(t.zoffset), float(t.diameter) / 2.0) for t in self.stat.tool_table if int(t.id) > 0}

    def read(self, systems: list[int], tools: list[int]) -> dict[str, Any]:
        table = self.tools()
        missing = [n for n in tools if n not in table]
        if missing:
            raise Failure("unknown", "tool(s) not in the control's tool table: " + ", ".join(f"T{n}" for n in missing))
        bad = [n for n in systems if not 1 <= n <= len(SYSTEMS)]
        if bad:
            raise Failure("unknown", f"work system number(s) out of 1…{len(SYSTEMS)}: {bad}")
        wks: dict[str, list[float]] = {}
        if systems:
            before = self.session()
            try:
                for n in systems:
                    self.select(n)
                    x, y, z = (float(v) for v in self.stat.g5x_offset[:3])
                    wks[str(n)] = [x, y, z, float(self.stat.rotation_xy)]
            finally:
                self.restore(before)
        return {"systems": wks, "tools": {str(n): list(table[n]) for n in tools}}

    def write(self, items: list[Any]) -> dict[str, Any]:
        lines = [self.gcode(item) for item in items]
        before = self.session()
        done = 0
        try:
            self.mdi("G21" if self.unit == "mm" else "G20")
            for line in lines:
                try:
                    self.mdi(line)
                except Failure as exc:
                    exc.extra["done"] = done
                    raise
                done += 1
        finally:
            self.restore(before)
        return {"done": done}

    def gcode(self, item: Any) -> str:
        kind, number, values = item
        number = int(number)
        if kind == "wks" and 1 <= number <= len(SYSTEMS) and set(values) <= {"X", "Y", "Z", "R"}:
            words = " ".join(f"{axis}{float(values[axis]):.6f}" for axis in ("X", "Y", "Z", "R") if axis in values)
            return f"G10 L2 P{number} {words}"
        if kind == "tool" and number > 0 and set(values) <= {"length", "radius"}:
            if number not in self.tools():
                raise Failure("unknown", f"T{number} is not in the control's tool table")
            words = " ".join(
                f"{word}{float(values[key]):.6f}" for key, word in (("length", "Z"), ("radius", "R")) if key in values
            )
            return f"G10 L1 P{number} {words}"
        raise Failure("bad", f"cannot write {item!r}")


def answer(control: Control | None, request: dict[str, Any]) -> tuple[Control | None, dict[str, Any]]:
    """One request answered: the control (opened by ``hello``) and the answer."""
    op = request.get("op")
    if op == "hello":
        control = Control(str(request["ini"]))
        return control, {"unit": control.unit, "machine": control.machine}
    if control is None:
        raise Failure("bad", "hello first")
    if op == "state":
        return control, {"busy": control.busy()}
    if op == "table":
        return control, {"tools": sorted(control.tools())}
    if op == "read":
        return control, control.read([int(n) for n in request["systems"]], [int(n) for n in request["tools"]])
    if op == "write":
        return control, control.write(list(request["items"]))
    raise Failure("bad", f"unknown request {op!r}")


def main() -> None:
    """Serve requests from stdin until it closes; ``argv[1]``, if given, is the folder of the ``linuxcnc`` module."""
    if len(sys.argv) > 1 and sys.argv[1]:
        sys.path.append(sys.argv[1])
    control: Control | None = None
    for line in sys.stdin:
        try:
            control, reply = answer(control, json.loads(line))
            reply = {"ok": True, **reply}
        except Failure as exc:
            reply = {"ok": False, "kind": exc.kind, "message": str(exc), **exc.extra}
        except Exception as exc:  # noqa: BLE001 - the agent answers every line: its caller names the failure
            reply = {"ok": False, "kind": "denied", "message": f"{type(exc).__name__}: {exc}"}
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
