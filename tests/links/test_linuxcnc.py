"""The ``linuxcnc`` link against a real LinuxCNC in simulation (:mod:`linuxcnc_sim`), and its refusals.

The simulated control holds its own state: what the link writes is checked by reading it back
through ``stat`` and, independently, in the parameter file and tool table LinuxCNC writes itself.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from linuxcnc_sim import Sim

from setupfix.links import open_link
from setupfix.links.base import LENGTH, RADIUS, Component
from setupfix.links.config import load_link
from setupfix.links.errors import LinkConfigError, LinkLost, LinkRefused, LinkUnreachable
from setupfix.links.linuxcnc import LinuxcncLink, agent_command, parse_register

G54X, G54Y, G54Z, G54R = (Component("G54", a) for a in "XYZR")
G55Z = Component("G55", "Z")
H5, D5 = Component("H5", LENGTH), Component("D5", RADIUS)


def link_file(folder: Path, ini: Path, extra: str = "") -> Path:
    path = folder / "link.toml"
    path.write_text(f'[link]\nprotocol = "linuxcnc"\nini = "{ini}"\nincrement = 0.0001\n{extra}')
    return path


# -- without a control ------------------------------------------------------------------------
def test_registers_are_linuxcncs_own() -> None:
    assert parse_register(G54X) == ("wks", 1)
    assert parse_register(Component("G59.3", "R")) == ("wks", 9)
    assert parse_register(Component("g55", "Z")) == ("wks", 2)
    assert parse_register(H5) == ("tool", 5)
    assert parse_register(D5) == ("tool", 5)
    assert parse_register(Component("T7", RADIUS)) == ("tool", 7)
    # the model's rotation about the spindle is LinuxCNC's XY rotation; a length is no D register, a radius no H
    assert parse_register(Component("G54", "C")) == ("wks", 1)
    assert parse_register(Component("D5", LENGTH)) is None
    assert parse_register(Component("H5", RADIUS)) is None
    assert parse_register(Component("G60", "X")) is None
    assert parse_register(Component("H0", LENGTH)) is None


def test_helper_environment_from_the_variables(tmp_path: Path) -> None:
    (tmp_path / "usr" / "lib" / "x86_64-linux-gnu").mkdir(parents=True)
    env = {"SETUPFIX_LINUXCNC_ROOT": str(tmp_path), "SETUPFIX_LINUXCNC_ENTER": "nsenter -t 12 'env' HOME=/a b"}
    command, child = agent_command(env)
    assert command[:5] == ["nsenter", "-t", "12", "env", "HOME=/a"]
    assert command[-1] == str(tmp_path / "usr" / "lib" / "python3" / "dist-packages")
    assert command[-3] == "-c" and "def main()" in command[-2]
    assert child["LD_LIBRARY_PATH"].split(os.pathsep)[:2] == [
        str(tmp_path / "usr" / "lib"),
        str(tmp_path / "usr" / "lib" / "x86_64-linux-gnu"),
    ]


def test_module_absent_is_one_clear_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "sim.ini").write_text("[TRAJ]\nLINEAR_UNITS = mm\n")
    monkeypatch.setenv("SETUPFIX_LINUXCNC_ROOT", str(tmp_path / "nothing"))
    monkeypatch.delenv("SETUPFIX_LINUXCNC_ENTER", raising=False)
    with pytest.raises(LinkUnreachable) as caught:
        open_link(link_file(tmp_path, tmp_path / "sim.ini"))
    text = str(caught.value)
    assert "Python module cannot be imported" in text and "\n" not in text
    assert caught.value.exit_status == 8


def test_missing_ini_names_file_and_key(tmp_path: Path) -> None:
    with pytest.raises(LinkConfigError) as caught:
        open_link(link_file(tmp_path, tmp_path / "absent.ini"))
    assert "link.ini" in str(caught.value) and "absent.ini" in str(caught.value)


# -- a simulated control ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Sim]:
    with Sim(tmp_path_factory.mktemp("linuxcnc-mm"), "mm") as running:
        yield running


@pytest.fixture
def link(sim: Sim, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[LinuxcncLink]:
    for key, value in sim.environ().items():
        monkeypatch.setenv(key, value)
    opened = open_link(link_file(tmp_path, sim.ini, 'machine = "sim-mm"\n'))
    assert isinstance(opened, LinuxcncLink)
    with opened:
        yield opened


@pytest.mark.slow
def test_reads_the_tool_table_and_work_systems(link: LinuxcncLink) -> None:
    assert (link.unit, link.machine, link.increment) == ("mm", "sim-mm", 0.0001)
    got = link.read([H5, D5, Component("H1", LENGTH), Component("T1", RADIUS)])
    assert got == {H5: 120.0, D5: 5.0, Component("H1", LENGTH): 10.0, Component("T1", RADIUS): 2.0}
    comps = link.components()
    assert len([c for c in comps if not c.tool]) == 9 * 4
    assert {c for c in comps if c.tool} == {Component("H1", LENGTH), Component("D1", RADIUS), H5, D5}


@pytest.mark.slow
def test_writes_and_reads_back_restoring_the_operators_state(sim: Sim, link: LinuxcncLink) -> None:
    sim.operator("mdi", "G56")
    sim.operator("mdi", "G20")  # an operator's program in inch: the link writes in the INI's mm all the same
    values = {G54X: -412.519, G54Y: 3.25, G54R: 1.5, G55Z: -7.0625, H5: 121.2345, D5: 4.9875}
    link.write(values)
    assert link.read(values) == pytest.approx(values, abs=1e-9)
    assert link.read([Component("G54", "C")]) == {Component("G54", "C"): 1.5}  # the rotation about the spindle
    link.write({Component("G55", "C"): -2.25})
    assert link.read([Component("G55", "R")]) == {Component("G55", "R"): -2.25}
    mode, system, units, interp = sim.status()
    assert (system, units, interp) == (3, 1, 1), "the active system (G56) and program units (G20) are restored"
    assert mode == 3  # the operator was in MDI
    # the control's own tool table file (written at once by G10 L1): diameter = 2 × radius
    rows = {line.split()[0]: line for line in (sim.folder / "sim.tbl").read_text().splitlines()}
    assert "D+9.975000" in rows["T5"] and "Z+121.234500" in rows["T5"]


@pytest.mark.slow
def test_components_linuxcnc_lacks_are_all_named(link: LinuxcncLink) -> None:
    with pytest.raises(LinkConfigError) as caught:
        link.read([G54X, Component("G60", "X"), Component("H5", RADIUS)])
    assert "G60.X" in str(caught.value) and "H5 radius" in str(caught.value)
    with pytest.raises(LinkConfigError, match="not in the control's tool table: T9"):
        link.read([Component("H9", LENGTH)])


@pytest.mark.slow
def test_a_running_program_is_the_interlock(sim: Sim, link: LinuxcncLink) -> None:
    before = link.read([G54Z])
    assert not link.interlocked() and link.interlock_reason is None
    sim.run_program("G4 P30\nM2\n")
    try:
        assert link.interlocked()
        assert link.interlock_reason == "a program is running"
        with pytest.raises(LinkRefused, match="a program is running: nothing written"):
            link.write({G54Z: 99.0})
        with pytest.raises(LinkRefused):
            link.read([G54Z])  # a work system is read by selecting it: not while a program runs
    finally:
        sim.operator("abort")
    assert not link.interlocked()
    assert link.read([G54Z]) == before


@pytest.mark.slow
def test_restart_holds_what_was_written_inch(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An inch control: values in inch both ways; after a clean shutdown and a restart they are still held."""
    values = {G54X: 1.2345, G54Y: -0.5, G54Z: 2.0625, G54R: 0.25, H5: 4.75, D5: 0.1875}
    simulation = Sim(tmp_path / "run", "inch", tools={5: (4.0, 0.25)})
    with simulation:
        for key, value in simulation.environ().items():
            monkeypatch.setenv(key, value)
        with open_link(link_file(tmp_path, simulation.ini)) as link:
            assert link.unit == "inch"
            link.write(values)
            assert link.read(values) == pytest.approx(values, abs=1e-9)
    # LinuxCNC wrote its parameter file at shutdown: G54 is #5221 … (X, Y, Z; #5230 the rotation), machine unit
    held = simulation.parameters()
    assert [held[5221], held[5222], held[5223], held[5230]] == pytest.approx([1.2345, -0.5, 2.0625, 0.25])
    with simulation:
        for key, value in simulation.environ().items():
            monkeypatch.setenv(key, value)
        with open_link(load_link(link_file(tmp_path, simulation.ini))) as link:
            assert link.read(values) == pytest.approx(values, abs=1e-9)


@pytest.mark.slow
def test_a_stopped_control_is_unreachable(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    simulation = Sim(tmp_path / "run", "mm")
    with simulation:
        env = simulation.environ()
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    with pytest.raises(LinkUnreachable) as caught:
        open_link(link_file(tmp_path, simulation.ini))
    assert caught.value.exit_status == 8 and "\n" not in str(caught.value)


@pytest.mark.slow
def test_a_control_that_stops_mid_session_is_lost(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """LinuxCNC shut down under an open link: its status memory still reads, but no command is answered."""
    simulation = Sim(tmp_path / "run", "mm")
    with simulation:
        for key, value in simulation.environ().items():
            monkeypatch.setenv(key, value)
        link = open_link(link_file(tmp_path, simulation.ini))
    try:
        with pytest.raises(LinkLost, match="the control stopped answering") as caught:
            link.write({G54Z: 1.0})
        assert caught.value.exit_status == 7
    finally:
        link.close()
    assert simulation.parameters()[5223] == 0.0, "nothing was written"
