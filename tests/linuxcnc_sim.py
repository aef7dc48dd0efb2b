"""A simulated LinuxCNC for the tests: a real control, headless and unprivileged, in a temporary folder.

The tree is the one ``.ci/run`` unpacks for rs274 (``linuxcnc-uspace`` and
``libboost-python1.74.0``, ``dpkg-deb -x``, never installed): ``SETUPFIX_LINUXCNC_ROOT`` names it,
else the cache folder of :mod:`rs274`.  Absent, a test is skipped with the reason; under ``CI``
it fails instead.  So it is when the box forbids user namespaces or overlay mounts.

How it runs (``../shared/research/machine-link.md``; nothing of LinuxCNC is patched): a user,
mount, IPC and PID namespace of its own (``unshare --user --map-root-user --mount --ipc --pid``),
inside it the unpacked ``usr`` and ``etc`` laid over ``/usr`` and ``/etc`` (overlay mounts), a
private ``/tmp`` (LinuxCNC's lock file and fixed shared-memory keys stay private, so two
simulations may run at once), the run folder carried over it, then a second user namespace
mapping uid 1000 because ``rtapi_app`` refuses uid 0.  ``linuxcnc -r sim.ini`` starts with:

- trivkins X Y Z, a HAL file of this module (:data:`HAL`: the motion loop-backs, the E-stop and
  tool-change loop-backs), homing in place (search velocity 0);
- a DISPLAY that is a small script: it says it is up (``display.ready``) and waits for
  ``display.stop``; when it ends LinuxCNC shuts down and writes its parameter file;
- its own TOOL_TABLE and PARAMETER_FILE in the run folder, HOME the run folder (the tool table is
  shared through ``$HOME/.tool.mmap``).

The link's helper reaches the control through ``SETUPFIX_LINUXCNC_ENTER`` (``nsenter`` into the
namespaces, ``HOME`` set): :meth:`Sim.environ` gives the variables for a link opened in this
process or a ``setupfix`` child process.  The "operator" steps a test needs (E-stop reset, machine
on, home; start or stop a program) run through the same door, with LinuxCNC's Python module.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType

import pytest

__all__ = ["linuxcnc_root", "namespaces_usable", "Sim", "HAL", "sim_or_skip"]

#: Where ``.ci/run`` unpacks LinuxCNC (the rs274 step) when ``SETUPFIX_LINUXCNC_ROOT`` is not set.
CACHE = Path.home() / ".cache" / "setupfix-ci" / "rs274" / "root"

#: The first namespace: a user (uid 0 mapped to the caller), mount, IPC and PID namespace of its own.
NAMESPACES = ("unshare", "--user", "--map-root-user", "--mount", "--ipc", "--pid", "--fork", "--mount-proc")

#: The HAL file: motion's position commands looped back as feedback, E-stop and tool change looped back.
HAL = """\
loadrt [KINS]KINEMATICS
loadrt [EMCMOT]EMCMOT base_period_nsec=[EMCMOT]BASE_PERIOD servo_period_nsec=[EMCMOT]SERVO_PERIOD \\
    num_joints=[KINS]JOINTS
addf motion-command-handler servo-thread
addf motion-controller servo-thread
net x-pos joint.0.motor-pos-cmd => joint.0.motor-pos-fb
net y-pos joint.1.motor-pos-cmd => joint.1.motor-pos-fb
net z-pos joint.2.motor-pos-cmd => joint.2.motor-pos-fb
net estop-loop iocontrol.0.user-enable-out iocontrol.0.emc-enable-in
net tool-prep-loop iocontrol.0.tool-prepare iocontrol.0.tool-prepared
net tool-change-loop iocontrol.0.tool-change iocontrol.0.tool-changed
"""

#: The DISPLAY program: up, then waiting for the stop file next to it.
DISPLAY = """\
import os, sys, time
here = os.path.dirname(os.path.abspath(sys.argv[0]))
open(os.path.join(here, "display.ready"), "w").close()
while not os.path.exists(os.path.join(here, "display.stop")):
    time.sleep(0.05)
"""

#: The interpreter inside the simulation's namespaces: the real file behind ``sys.executable``, since a
#: virtual environment's link may sit under /tmp, which the namespace replaces (they need only the
#: standard library and LinuxCNC's module).
PYTHON = os.path.realpath(sys.executable)

#: Run inside the first namespace: the overlays, the private /tmp with the run folder carried over, LinuxCNC.
INNER = """\
set -eu
root="$1"; run="$2"
mkdir -p "$run/.overlay/usr" "$run/.overlay/usr.work" "$run/.overlay/etc" "$run/.overlay/etc.work"
mount -t overlay overlay -o "lowerdir=$root/usr:/usr,upperdir=$run/.overlay/usr,workdir=$run/.overlay/usr.work" /usr
mount -t overlay overlay -o "lowerdir=$root/etc:/etc,upperdir=$run/.overlay/etc,workdir=$run/.overlay/etc.work" /etc
mount --bind "$run" /mnt
mount -t tmpfs tmpfs /tmp
mkdir -p "$run"
mount --move /mnt "$run"
export HOME="$run"
cd "$run"
exec unshare --user --map-user=1000 --map-group=1000 linuxcnc -r sim.ini
"""

#: Operator steps, run with LinuxCNC's module next to the control (argv: the step's name, a file).
OPERATOR = """\
import sys, time
import linuxcnc
step = sys.argv[1]
s, c = linuxcnc.stat(), linuxcnc.command()
def done(what):
    if c.wait_complete(10) != 1:
        sys.exit(f"{what}: not done")
if step == "ready":
    c.state(linuxcnc.STATE_ESTOP_RESET); done("E-stop reset")
    c.state(linuxcnc.STATE_ON); done("machine on")
    c.home(-1); done("home")
    for _ in range(400):
        s.poll()
        if all(s.homed[:3]):
            break
        time.sleep(0.025)
    else:
        sys.exit("not homed")
    c.mode(linuxcnc.MODE_MANUAL); done("manual mode")
elif step == "run":
    c.mode(linuxcnc.MODE_AUTO); done("auto mode")
    c.program_open(sys.argv[2]); done("open")
    c.auto(linuxcnc.AUTO_RUN, 0)
    for _ in range(400):
        s.poll()
        if s.interp_state != linuxcnc.INTERP_IDLE:
            break
        time.sleep(0.025)
    else:
        sys.exit("the program did not start")
elif step == "abort":
    c.abort(); done("abort")
    for _ in range(400):
        s.poll()
        if s.interp_state == linuxcnc.INTERP_IDLE:
            break
        time.sleep(0.025)
    c.mode(linuxcnc.MODE_MANUAL); done("manual mode")
elif step == "status":
    s.poll()
    print(s.task_mode, s.g5x_index, s.program_units, s.interp_state)
elif step == "mdi":
    c.mode(linuxcnc.MODE_MDI); done("mdi mode")
    c.mdi(sys.argv[2]); done(sys.argv[2])
"""


def _missing(why: str) -> None:
    if os.environ.get("CI"):
        pytest.fail(why)
    pytest.skip(why)


def linuxcnc_root() -> Path:
    """The unpacked LinuxCNC tree; skips the test (fails it under ``CI``) when it is absent."""
    named = os.environ.get("SETUPFIX_LINUXCNC_ROOT")
    root = Path(named) if named else CACHE
    if (root / "usr" / "bin" / "linuxcnc").is_file() and (root / "usr" / "lib" / "python3" / "dist-packages").is_dir():
        return root
    _missing(
        f"LinuxCNC not found at {root} "
        f"({'SETUPFIX_LINUXCNC_ROOT=' + named if named else 'SETUPFIX_LINUXCNC_ROOT unset'})"
        ": run .ci/run once, or set SETUPFIX_LINUXCNC_ROOT to an unpacked linuxcnc-uspace"
    )
    raise AssertionError("unreachable")


def namespaces_usable() -> str | None:
    """None when unprivileged user, mount and overlay namespaces work here; else why not."""
    probe = (
        "d=$(mktemp -d) && mkdir $d/l $d/u $d/w $d/m"
        " && mount -t overlay o -o lowerdir=$d/l,upperdir=$d/u,workdir=$d/w $d/m"
        " && umount $d/m && rm -r $d"
    )
    try:
        done = subprocess.run(
            [
                "unshare",
                "--user",
                "--map-root-user",
                "--mount",
                "--ipc",
                "--pid",
                "--fork",
                "--mount-proc",
                "sh",
                "-c",
                probe,
            ],
            capture_output=True,
            text=True,
            timeout=30,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"unshare cannot run: {exc}"
    if done.returncode != 0:
        return f"user/mount namespaces or overlay mounts are blocked here: {done.stderr.strip()[-300:]}"
    return None


def sim_or_skip() -> Path:
    """The tree, after checking the box can run the simulation (skip, or fail under ``CI``)."""
    root = linuxcnc_root()
    why = namespaces_usable()
    if why:
        _missing(f"LinuxCNC simulation impossible: {why}")
    return root


def ini_text(folder: Path, unit: str) -> str:
    """The INI of a simulated mill: trivkins X Y Z in ``unit`` (``"mm"`` or ``"inch"``)."""
    travel = 500.0 if unit == "mm" else 20.0
    lines = [
        "[EMC]",
        "VERSION = 1.1",
        f"MACHINE = setupfix-sim-{unit}",
        "[DISPLAY]",
        f"DISPLAY = {folder / 'display.py'}",
        "[TASK]",
        "TASK = milltask",
        "CYCLE_TIME = 0.001",
        "[RS274NGC]",
        "PARAMETER_FILE = sim.var",
        "[EMCMOT]",
        "EMCMOT = motmod",
        "COMM_TIMEOUT = 1.0",
        "BASE_PERIOD = 0",
        "SERVO_PERIOD = 1000000",
        "[EMCIO]",
        "EMCIO = io",
        "CYCLE_TIME = 0.100",
        "TOOL_TABLE = sim.tbl",
        "[HAL]",
        "HALFILE = sim.hal",
        "[TRAJ]",
        "COORDINATES = X Y Z",
        f"LINEAR_UNITS = {unit}",
        "ANGULAR_UNITS = degree",
        f"MAX_LINEAR_VELOCITY = {travel / 10:g}",
        "[KINS]",
        "KINEMATICS = trivkins",
        "JOINTS = 3",
    ]
    for joint, axis in enumerate("XYZ"):
        limits = [f"MIN_LIMIT = {-travel:g}", f"MAX_LIMIT = {travel:g}"]
        speed = [f"MAX_VELOCITY = {travel / 10:g}", f"MAX_ACCELERATION = {travel:g}"]
        lines += [f"[AXIS_{axis}]", *speed, *limits]
        lines += [f"[JOINT_{joint}]", "TYPE = LINEAR", "HOME = 0", *speed, *limits]
        lines += ["FERROR = 1", "MIN_FERROR = 0.1", "HOME_SEARCH_VEL = 0", "HOME_LATCH_VEL = 0", "HOME_SEQUENCE = 0"]
    return "\n".join(lines) + "\n"


class Sim:
    """One simulated LinuxCNC in ``folder``; :meth:`start` / :meth:`stop` (a context manager does both).

    Parameters
    ----------
    folder : Path
        The run folder (kept between a stop and the next start: its parameter file and tool
        table carry the offsets over).
    unit : str
        ``"mm"`` or ``"inch"``: the INI's ``[TRAJ] LINEAR_UNITS``.
    tools : mapping of int to (length, radius), optional
        The tool table written when the folder has none yet.
    """

    def __init__(self, folder: Path, unit: str = "mm", tools: Mapping[int, tuple[float, float]] | None = None) -> None:
        self.root = sim_or_skip()
        self.folder = folder
        self.unit = unit
        self.process: subprocess.Popen[bytes] | None = None
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "sim.ini").write_text(ini_text(folder, unit))
        (folder / "sim.hal").write_text(HAL)
        display = folder / "display.py"
        display.write_text(f"#!{PYTHON}\n{DISPLAY}")
        display.chmod(0o755)
        table = folder / "sim.tbl"
        if not table.exists():
            rows = sorted((tools or {1: (10.0, 2.0), 5: (120.0, 5.0)}).items())
            table.write_text("".join(f"T{n} P{n} Z{length:.6f} D{2 * radius:.6f} ;\n" for n, (length, radius) in rows))
        if not (folder / "sim.var").exists():
            (folder / "sim.var").write_text("")

    @property
    def ini(self) -> Path:
        return self.folder / "sim.ini"

    def start(self, timeout: float = 60.0) -> None:
        """Start LinuxCNC and make it ready for MDI (E-stop reset, on, homed, manual mode)."""
        for name in ("display.ready", "display.stop"):
            (self.folder / name).unlink(missing_ok=True)
        inner = self.folder / "inner.sh"
        inner.write_text(INNER)
        log = (self.folder / "linuxcnc.log").open("ab")
        self.process = subprocess.Popen(
            [*NAMESPACES, "sh", str(inner), str(self.root), str(self.folder)],
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
        )
        log.close()
        deadline = time.monotonic() + timeout
        while not (self.folder / "display.ready").exists():
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise AssertionError(f"LinuxCNC did not start:\n{self.log()[-3000:]}")
            time.sleep(0.05)
        self.operator("ready")

    def log(self) -> str:
        path = self.folder / "linuxcnc.log"
        return path.read_text(errors="replace") if path.exists() else ""

    def environ(self) -> dict[str, str]:
        """The ``SETUPFIX_LINUXCNC_*`` variables a link to this control needs."""
        assert self.process is not None, "the simulation is not running"
        enter = ["nsenter", "-t", str(self.process.pid), "--user", "--mount", "--ipc", "--preserve-credentials"]
        enter += [f"--wdns={self.folder}", "env", f"HOME={self.folder}"]
        return {
            "SETUPFIX_LINUXCNC_ROOT": str(self.root),
            "SETUPFIX_LINUXCNC_PYTHON": PYTHON,
            "SETUPFIX_LINUXCNC_ENTER": shlex.join(enter),
        }

    def operator(self, step: str, *args: str) -> str:
        """An operator's step at the control (:data:`OPERATOR`): ``ready``, ``run FILE``, ``abort``, ``mdi LINE``,
        ``status`` (its printed line: the numbers :meth:`status` returns)."""
        env = {**os.environ, **self.environ()}
        enter = shlex.split(env["SETUPFIX_LINUXCNC_ENTER"])
        modules = str(self.root / "usr" / "lib" / "python3" / "dist-packages")
        env["PYTHONPATH"] = modules
        done = subprocess.run(
            [*enter, PYTHON, "-c", OPERATOR, step, *args], env=env, capture_output=True, text=True, timeout=60
        )
        assert done.returncode == 0, f"operator step {step} failed: {done.stderr.strip()[-2000:]}"
        return done.stdout

    def run_program(self, text: str) -> None:
        """Start a program (AUTO, cycle start) and return while it runs."""
        path = self.folder / "program.ngc"
        path.write_text(text)
        self.operator("run", str(path))

    def status(self) -> tuple[int, int, int, int]:
        """Task mode (1 manual, 2 auto, 3 MDI), active work system (1…9), program units (1 inch, 2 mm),
        interpreter state (1 idle)."""
        mode, system, units, interp = (int(v) for v in self.operator("status").split())
        return mode, system, units, interp

    def stop(self, timeout: float = 60.0) -> None:
        """Shut LinuxCNC down cleanly (the DISPLAY ends): it writes its parameter file."""
        if self.process is None:
            return
        (self.folder / "display.stop").touch()
        try:
            self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.process = None

    def parameters(self) -> dict[int, float]:
        """The parameter file: number → value (after a stop it holds the work offsets)."""
        out: dict[int, float] = {}
        for line in (self.folder / "sim.var").read_text().splitlines():
            parts = line.split()
            if len(parts) >= 2 and parts[0].isdigit():
                out[int(parts[0])] = float(parts[1])
        return out

    def __enter__(self) -> Sim:
        self.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.stop()
