"""The ``[effects]`` section written as TOML: its text, and a model file's text with the section replaced.

The section is read and validated by :mod:`setupfix.model.effects`; ``diagnose --augment OUT.toml`` writes
the input model unchanged plus the section this module makes.
"""

from __future__ import annotations

import re
from typing import Any

from setupfix.model.effects import EffectsSection

__all__ = ["effects_toml", "with_effects"]


def _value(v: Any) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(float(v)) if isinstance(v, float) else str(v)


def effects_toml(section: EffectsSection) -> str:
    """The ``[effects]`` section as TOML text, documented for the reader of the file."""
    out = [
        "# Effects found by `setupfix diagnose` that the relations above lack. Each adds",
        "# estimate x its covariate to the deviations (drift: hours since origin, or",
        "# 1 - exp(-t/tau); thermal: channel - reference; wear: cycles since the tool's last",
        "# change; scale: nominal; position: the dimension's coordinate (along: on that axis's",
        "# errors only); rotation: radians of a WKS turned about the spindle; relation: the",
        "# register's change on that dimension; group: 1 on the group's dimensions; level: 1",
        "# from `at` hours after origin on; process: channel - reference, from the process log).",
        "# `setupfix correct` adds the drift and wear expected until the next cycle, and maps",
        "# corrections through a relation whose register is named (registers: the ones the",
        "# series could not tell apart; with more than one the weight is not used).",
        "[effects]",
    ]
    if section.origin is not None:
        out.append(f"origin = {_value(section.origin)}")
    if section.cycle_hours is not None:
        out.append(f"cycle_hours = {section.cycle_hours!r}")
    if section.last_hours is not None:
        out.append(f"last_hours = {section.last_hours!r}")
    for e in section.effects:
        out += ["", f"[effects.{e.id}]", f'kind = "{e.kind}"']
        if e.kind == "drift":
            out.append(f'shape = "{e.shape}"')
            if e.tau is not None:
                out.append(f"tau = {e.tau!r}")
        for name in ("channel", "register", "dimension", "axis", "along", "group", "cycle"):
            value = getattr(e, name)
            if value is not None:
                out.append(f"{name} = {_value(value)}")
        if e.registers:
            out.append(f"registers = [{', '.join(_value(r) for r in e.registers)}]")
        if e.kind in ("thermal", "process"):
            out.append(f"reference = {e.reference!r}")
        if e.at is not None:
            out.append(f"at = {e.at!r}")
        if e.span is not None:
            out.append(f"span = {e.span!r}")
        out.append(f"estimate = {e.estimate!r}")
        if e.stderr is not None:
            out.append(f"stderr = {e.stderr!r}")
        out += [f"unit = {_value(e.unit)}", f"target = {_value(e.target)}"]
    return "\n".join(out) + "\n"


_HEADER = re.compile(r"^\s*\[{1,2}\s*([^\]]+?)\s*\]{1,2}\s*(#.*)?$")
_MARK = "# Effects found by `setupfix diagnose`"


def with_effects(model_text: str, section: EffectsSection) -> str:
    """The model file's text with its ``[effects]`` tables replaced by ``section``.

    Every other line is kept as written (comments included); the comment block a
    previous ``--augment`` wrote above ``[effects]`` goes with the old section.
    """
    kept: list[str] = []
    skipping = False
    for line in model_text.splitlines():
        m = _HEADER.match(line)
        if m:
            name = m.group(1).strip().strip('"')
            was = skipping
            skipping = name == "effects" or name.startswith("effects.")
            if skipping and not was:
                block = len(kept)
                while block and kept[block - 1].lstrip().startswith("#"):
                    block -= 1
                marks = [i for i in range(block, len(kept)) if kept[i].startswith(_MARK)]
                if marks:
                    del kept[marks[0] :]
        if not skipping:
            kept.append(line)
    body = "\n".join(kept).rstrip()
    return (body + "\n\n" if body else "") + effects_toml(section)
