"""``machine read`` and ``machine write``: the control's offsets read, and a plan written with the guarded sequence.

One use case for every door (the CLI, batch, the TUI's "send to machine"):

- :func:`read_control` reads every mapped component (or the model's) → :class:`ControlRead`;
  :func:`current_from_link` turns a read into the :class:`~setupfix.usecases.requests.CurrentOffsets`
  of ``correct --link`` (model unit) with the snapshot the plan records;
- :func:`load_plan` reads a plan file (``correct --json`` made with ``--link``), :func:`plan_of`
  makes one from a corrected cycle;
- :func:`plan_write` reads the control and gives the dry-run diff (:class:`WritePlan`);
- :func:`apply_write` runs the guarded sequence of ``../shared/spec/machine-link.md`` on it:
  re-read and refuse a stale table, refuse on the interlock or a limit, write at the control's
  increment and unit, read back within half an increment, roll back and name every component
  on a mismatch or a lost connection;
- :func:`write_to_control` is the whole command: plan, dry run or apply, and the audit record
  (every attempt, an unreachable control and a refusal included) when a store is given.

Values of the control are in the control's unit (``Link.unit``); a rotation in degrees.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from setupfix.core.atomic import write_text
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import length_factor
from setupfix.links.base import Component, Link
from setupfix.links.errors import (
    EXIT_REFUSED,
    EXIT_UNCONFIRMED,
    EXIT_UNREACHABLE,
    LinkConfigError,
    LinkError,
    LinkUnreachable,
)
from setupfix.links.mapping import decimals_of, model_components, round_to_increment, to_control, to_model
from setupfix.links.snapshot import ControlSnapshot
from setupfix.model import ProcessModel
from setupfix.store import Store
from setupfix.store.link_audit import LinkAttempt, LinkComponentRecord
from setupfix.usecases.requests import CurrentOffsets, CycleCorrection

__all__ = [
    "ControlRead",
    "read_control",
    "current_from_link",
    "write_current_csv",
    "Plan",
    "load_plan",
    "plan_of",
    "ComponentWrite",
    "WritePlan",
    "WriteOutcome",
    "plan_write",
    "apply_write",
    "write_to_control",
    "OUTCOME_STATUS",
]

#: Exit status of each outcome (``machine-link.md``, "Exit status").
OUTCOME_STATUS: dict[str, int] = {
    "dry_run": 0,
    "applied": 0,
    "refused": EXIT_REFUSED,
    "rolled_back": EXIT_UNCONFIRMED,
    "unconfirmed": EXIT_UNCONFIRMED,
    "unreachable": EXIT_UNREACHABLE,
}


def _within(a: float, b: float, increment: float) -> bool:
    """|a − b| ≤ increment / 2 (with a float tolerance of 1e-9 increment)."""
    return abs(a - b) <= increment * (0.5 + 1e-9)


# -- reading ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ControlRead:
    """What ``machine read`` read: the link, its unit, and every component's value (control unit)."""

    snapshot: ControlSnapshot
    ids: tuple[tuple[Component, str], ...] = ()  # the model's register ID of each component (with --model)

    def to_json(self) -> dict[str, Any]:
        s = self.snapshot
        ids = dict(self.ids)
        return {
            "machine": s.machine,
            "link": s.link,
            "unit": s.unit,
            "increment": s.increment,
            "components": [
                {"register": c.register, "axis": c.axis, "value": v, "unit": "deg" if c.rotation else s.unit}
                | ({"id": ids[c]} if c in ids else {})
                for c, v in s.values
            ],
        }


def read_control(link: Link, model: ProcessModel | None = None) -> ControlRead:
    """Read every component the link maps, or only the model's correctable ones (in the model's order).

    Raises
    ------
    LinkConfigError
        A model component the link does not map (all named; nothing read).
    LinkUnreachable, LinkLost, LinkDenied, LinkError
    """
    if model is None:
        comps = list(link.components())
        ids: tuple[tuple[Component, str], ...] = ()
    else:
        by_id = model_components(model)
        comps = list(dict.fromkeys(by_id.values()))
        ids = tuple((c, rid) for rid, c in by_id.items())
    values = link.read(comps)
    snapshot = ControlSnapshot.of(link.name, link.unit, link.increment, {c: values[c] for c in comps}, link.machine)
    return ControlRead(snapshot, ids)


def current_from_link(link: Link, model: ProcessModel) -> CurrentOffsets:
    """The model's current offsets read from the control (model unit), holding the snapshot for the plan."""
    read = read_control(link, model)
    values = read.snapshot.as_dict
    current = {rid: to_model(values[c], c, model.unit, link.unit) for rid, c in model_components(model).items()}
    return CurrentOffsets.of(current, link.name, read.snapshot)


def _number(value: float, digits: int) -> str:
    text = f"{value:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def write_current_csv(read: ControlRead, model: ProcessModel, path: str | Path) -> None:
    """The read values as a ``--current`` CSV (``cli-json.md``, "Current offsets"): the model's registers,
    the model's unit; ``register,value`` for a one-axis model, ``register,axis,value`` for a multi-axis one.

    Raises
    ------
    LinkConfigError
        The read holds no value for a correctable register of the model.
    """
    values = read.snapshot.as_dict
    unit = read.snapshot.unit
    digits = decimals_of(read.snapshot.increment) + (4 if unit != model.unit else 0)
    lines = ["register,axis,value" if model.multi_axis else "register,value"]
    for reg in model.registers:
        if reg.fixed:
            continue
        comp = model_components(model)[reg.id]
        if comp not in values:
            raise LinkConfigError(f"no value of {comp} was read (model register {reg.id})")
        text = _number(to_model(values[comp], comp, model.unit, unit), digits)
        if model.multi_axis:
            axis = reg.component if reg.kind == "wks" and reg.component else ""
            lines.append(f"{reg.register},{axis},{text}")
        else:
            lines.append(f"{reg.register},{text}")
    write_text(path, "\n".join(lines) + "\n")


# -- the plan ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Plan:
    """A decision to write: the corrections (model ID → change, model unit), its verdict, and the
    control's values it was made with (None when it was made without a link)."""

    source: str
    sha256: str
    verdict: str
    solved: bool
    corrections: tuple[tuple[str, float], ...]
    made_with: ControlSnapshot | None
    draft: bool = False
    alarm: str = ""

    @property
    def refusal(self) -> str | None:
        """Why this plan is never written, or None (``apply`` verdict of a finished solve, not a draft)."""
        if self.draft:
            return "the model is a draft (remove [process] draft once edited): nothing is written"
        if not self.solved:
            return "the solve was stopped with nothing proven to recommend: nothing is written"
        if self.verdict != "apply":
            return f"the verdict is {self.verdict!r}, not 'apply': nothing is written"
        return None


def _sha256_of(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def plan_of(cycle: CycleCorrection, current: CurrentOffsets | None, source: str = "") -> Plan:
    """The plan of one corrected cycle (``machine write REPORT``); its hash is that of its JSON."""
    from setupfix.usecases.contract import cycle_json

    obj = cycle_json(cycle)
    snapshot = current.snapshot if current is not None else None
    if snapshot is not None:
        obj["link"] = snapshot.to_json()
    return Plan(
        source=source or cycle.part.report,
        sha256=_sha256_of(obj),
        verdict=cycle.verdict,
        solved=cycle.solved,
        corrections=tuple(cycle.corrections.items()),
        made_with=snapshot,
        draft=cycle.model.draft,
        alarm=cycle.recommendation.alarm or "",
    )


def load_plan(path: str | Path, model: ProcessModel) -> Plan:
    """A plan file: the ``correct --json`` object of one part, made with ``--link``.

    Raises
    ------
    ParseError
        Naming the file and key: not JSON, several parts (make it with ``--part``), no verdict,
        corrections that are not the model's registers, no ``"link"`` values (made without ``--link``).
    """
    name = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ParseError(f"cannot read the plan: {exc.strerror or exc}", location=SourceLocation(name)) from None
    try:
        obj = json.loads(data)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ParseError(f"not a JSON plan (correct --json): {exc}", location=SourceLocation(name)) from None
    if isinstance(obj, dict) and "parts" in obj:
        parts = obj["parts"]
        if isinstance(parts, list) and len(parts) == 1:
            obj = {**parts[0], **({"link": obj["link"]} if "link" in obj else {})}
        else:
            raise ParseError(
                f"the plan holds {len(parts) if isinstance(parts, list) else 'several'} parts: one part is written",
                location=SourceLocation(name, key="parts"),
                hint="make the plan with correct --part ID",
            )
    if not isinstance(obj, dict):
        raise ParseError("expected the JSON object of correct --json", location=SourceLocation(name))
    verdict = obj.get("verdict")
    if verdict not in ("apply", "hold", "reject"):
        raise ParseError(
            f"expected a verdict apply, hold or reject, found {verdict!r}", location=SourceLocation(name, key="verdict")
        )
    corrections = obj.get("corrections")
    if not isinstance(corrections, dict):
        raise ParseError("expected the corrections by register", location=SourceLocation(name, key="corrections"))
    wanted = set(model_components(model))
    given: dict[str, float] = {}
    for key, value in corrections.items():
        if key not in wanted:
            raise ParseError(
                f"register {key!r} is not a correctable register of the model {model.source}",
                location=SourceLocation(name, key=f"corrections.{key}"),
            )
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise ParseError(
                f"expected a finite number, found {value!r}", location=SourceLocation(name, key=f"corrections.{key}")
            )
        given[key] = float(value)
    missing = sorted(wanted - set(given))
    if missing:
        raise ParseError(
            f"no correction for {', '.join(missing)} of the model", location=SourceLocation(name, key="corrections")
        )
    if "link" not in obj:
        raise ParseError(
            "the plan records no values read from the control: nothing can prove the table unchanged",
            location=SourceLocation(name, key="link"),
            hint="make the plan with correct --link LINK --json",
        )
    snapshot = ControlSnapshot.from_json(obj["link"], SourceLocation(name))
    solved = obj.get("solved", True)
    return Plan(
        source=name,
        sha256=hashlib.sha256(data).hexdigest(),
        verdict=str(verdict),
        solved=bool(solved),
        corrections=tuple((rid, given[rid]) for rid in model_components(model)),
        made_with=snapshot,
        draft=model.draft,
        alarm=str(obj.get("alarm") or ""),
    )


# -- the write -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class ComponentWrite:
    """One component through the sequence (control unit; None where a step was not reached).

    ``outcome``: ``planned``, ``confirmed``, ``rolled_back``, ``not_restored`` or ``unknown``
    (:class:`setupfix.store.link_audit.LinkComponentRecord`).
    """

    id: str
    component: Component
    before: float | None
    change: float | None
    new: float | None
    written: float | None = None
    read_back: float | None = None
    restored: float | None = None
    outcome: str = "planned"

    def to_json(self, unit: str) -> dict[str, Any]:
        return {
            "register": self.component.register,
            "axis": self.component.axis,
            "id": self.id,
            "before": self.before,
            "change": self.change,
            "new": self.new,
            "written": self.written,
            "read_back": self.read_back,
            "restored": self.restored,
            "outcome": self.outcome,
            "unit": "deg" if self.component.rotation else unit,
        }

    def record(self) -> LinkComponentRecord:
        c = self.component
        return LinkComponentRecord(
            c.register, c.axis, self.before, self.change, self.written, self.read_back, self.restored, self.outcome
        )


@dataclass(frozen=True)
class WritePlan:
    """The dry-run diff: per component the value read now, the change and the new value at the increment."""

    plan: Plan
    link: str
    machine: str | None
    unit: str
    increment: float
    rows: tuple[ComponentWrite, ...]
    stale: tuple[Component, ...] = ()

    @property
    def values_now(self) -> dict[Component, float]:
        return {r.component: r.before for r in self.rows if r.before is not None}


@dataclass(frozen=True)
class WriteOutcome:
    """What ``machine write`` did: ``outcome`` (``machine-link.md``), its one-line message, every component."""

    outcome: str
    message: str
    plan_sha256: str
    machine: str | None
    link: str
    unit: str
    rows: tuple[ComponentWrite, ...]
    dry_run: bool

    @property
    def exit_status(self) -> int:
        return OUTCOME_STATUS[self.outcome]

    def to_json(self) -> dict[str, Any]:
        return {
            "machine": self.machine,
            "outcome": self.outcome,
            "dry_run": self.dry_run,
            "plan_sha256": self.plan_sha256,
            "link": self.link,
            "message": self.message,
            "components": [r.to_json(self.unit) for r in self.rows],
        }

    def attempt(self) -> LinkAttempt:
        return LinkAttempt(
            link=self.link,
            plan_sha256=self.plan_sha256,
            outcome=self.outcome,
            message=self.message,
            unit=self.unit,
            components=tuple(r.record() for r in self.rows),
        )


def _rows(
    model: ProcessModel, plan: Plan, link: Link, now: Mapping[Component, float] | None
) -> tuple[ComponentWrite, ...]:
    """Per model register component: before (read now), the change and the new value at the increment."""
    deltas = dict(plan.corrections)
    rows = []
    for rid, comp in model_components(model).items():
        change = to_control(deltas.get(rid, 0.0), comp, model.unit, link.unit)
        if now is None:
            rows.append(ComponentWrite(rid, comp, None, round(change, 12), None))
            continue
        before = now[comp]
        new = round_to_increment(before + change, link.increment)
        rows.append(ComponentWrite(rid, comp, before, round(new - before, decimals_of(link.increment)) + 0.0, new))
    return tuple(rows)


def plan_write(model: ProcessModel, plan: Plan, link: Link) -> WritePlan:
    """Read the control and give the diff the plan would write (nothing written).

    Raises
    ------
    LinkConfigError
        A model component the link does not map.
    LinkUnreachable, LinkLost, LinkDenied, LinkError
    """
    comps = list(dict.fromkeys(model_components(model).values()))
    now = link.read(comps)
    return WritePlan(
        plan,
        link.name,
        _machine(link, model),
        link.unit,
        link.increment,
        _rows(model, plan, link, now),
        _stale(plan, link, now),
    )


def _machine(link: Link, model: ProcessModel) -> str | None:
    return link.machine or model.machine


def _stale(plan: Plan, link: Link, now: Mapping[Component, float]) -> tuple[Component, ...]:
    """The components that moved since the plan was made (more than half the coarser increment)."""
    made = plan.made_with
    if made is None:
        return ()
    then = made.as_dict
    step = max(link.increment, made.increment * length_factor(made.unit, link.unit))
    out = []
    for comp, value in now.items():
        if comp not in then:
            out.append(comp)
            continue
        old = then[comp] if comp.rotation else then[comp] * length_factor(made.unit, link.unit)
        if not _within(value, old, step):
            out.append(comp)
    return tuple(out)


def _limit_breaches(model: ProcessModel, rows: Sequence[ComponentWrite], link: Link) -> list[str]:
    """Components whose change exceeds the register's limit, or whose new wear value its cumulative limit."""
    regs = {r.id: r for r in model.registers}
    out = []
    for row in rows:
        reg = regs[row.id]
        if row.change is None or row.new is None:
            continue
        comp = row.component
        change_model = to_model(row.change, comp, model.unit, link.unit)
        bound = model.rotation_limit if comp.rotation else reg.limit
        tolerance = to_model(link.increment, comp, model.unit, link.unit) / 2 + 1e-12
        if abs(change_model) > bound + tolerance:
            out.append(f"{comp}: change {row.change:g} beyond the register's limit {bound:g} {model.unit}")
            continue
        cumulative = reg.policy.cumulative_limit
        if cumulative is None:
            cumulative = model.safety.cumulative_limit
        if reg.offset == "wear" and cumulative is not None:
            new_model = to_model(row.new, comp, model.unit, link.unit)
            if abs(new_model) > cumulative + tolerance:
                out.append(f"{comp}: wear value {row.new:g} beyond the cumulative limit {cumulative:g} {model.unit}")
    return out


def _outcome(
    wp: WritePlan, outcome: str, message: str, rows: Sequence[ComponentWrite], *, dry_run: bool = False
) -> WriteOutcome:
    return WriteOutcome(outcome, message, wp.plan.sha256, wp.machine, wp.link, wp.unit, tuple(rows), dry_run)


def apply_write(model: ProcessModel, wp: WritePlan, link: Link) -> WriteOutcome:
    """The guarded sequence of ``machine-link.md`` on a dry-run diff (nothing is ever written twice).

    1. refuse a plan that is not ``apply`` (draft model, stopped solve, hold, reject);
    2. re-read every component; refuse if any moved since the plan was made (stale);
    3. refuse if the interlock is set, or a change breaks a register's limit;
    4. write every component (new value at the increment, control unit);
    5. read back: every value within half an increment of what was written → ``applied``;
       otherwise (or a connection lost, or a node refused) write back the values read in 2,
       read them back: ``rolled_back``, or ``unconfirmed`` ("CHECK THE CONTROL") if that fails.

    An unreachable control at step 2 is ``unreachable``; every other link error before step 4 a
    refusal with its message.  Never raises a :class:`LinkError`.
    """
    plan = wp.plan
    why = plan.refusal
    if why is not None:
        return _outcome(wp, "refused", f"refused: {why}", wp.rows)
    comps = [r.component for r in wp.rows]
    try:
        now = link.read(comps)
    except LinkUnreachable as exc:
        return _outcome(wp, "unreachable", f"the control could not be reached: {exc}; nothing written", wp.rows)
    except LinkError as exc:
        return _outcome(wp, "refused", f"refused: the control could not be read: {exc}; nothing written", wp.rows)
    rows = _rows(model, plan, link, now)
    checked = replace(wp, rows=rows)
    stale = _stale(plan, link, now)
    if stale:
        then = plan.made_with.as_dict if plan.made_with is not None else {}
        moved = ", ".join(f"{c} {then.get(c, math.nan):g} → {now[c]:g}" for c in stale)
        return _outcome(
            checked, "refused", f"refused: the table changed since the plan ({moved}); nothing written", rows
        )
    try:
        if link.interlocked():
            return _outcome(
                checked, "refused", "refused: the control's interlock is set (a program runs); nothing written", rows
            )
    except LinkError as exc:
        return _outcome(checked, "refused", f"refused: the interlock could not be read: {exc}; nothing written", rows)
    breaches = _limit_breaches(model, rows, link)
    if breaches:
        return _outcome(checked, "refused", f"refused: {'; '.join(breaches)}; nothing written", rows)
    values = {r.component: r.new for r in rows if r.new is not None}
    failure = ""
    back: dict[Component, float] = {}
    try:
        link.write(values)
    except LinkError as exc:
        failure = f"the write failed: {exc}"
    if not failure:
        try:
            back = link.read(comps)
        except LinkError as exc:
            failure = f"the read-back failed: {exc}"
    written_rows = [replace(r, written=r.new, read_back=back.get(r.component)) for r in rows]
    if not failure:
        wrong = [
            r
            for r in written_rows
            if r.read_back is None or r.new is None or not _within(r.read_back, r.new, link.increment)
        ]
        if not wrong:
            done = [replace(r, outcome="confirmed") for r in written_rows]
            return _outcome(checked, "applied", f"written and read back: {len(done)} component(s)", done)
        failure = "read back differs: " + ", ".join(
            f"{r.component} written {r.new:g} read back {r.read_back:g}" for r in wrong
        )
    return _roll_back(checked, link, now, written_rows, failure)


def _roll_back(
    wp: WritePlan, link: Link, before: Mapping[Component, float], rows: list[ComponentWrite], failure: str
) -> WriteOutcome:
    """Put back the values read before the write and name every component's state.

    The control is read first and only the components that moved are written back (a read-only
    node or an ignored write left its value as it was), then everything is read again.
    """
    comps = list(before)
    try:
        now = link.read(comps)
        rows = [r if r.read_back is not None else replace(r, read_back=now.get(r.component)) for r in rows]
        moved = {c: before[c] for c in comps if not _within(now[c], before[c], link.increment)}
        if moved:
            link.write(moved)
        restored = link.read(comps)
    except LinkError as exc:
        final = [replace(r, outcome="unknown") for r in rows]
        states = "; ".join(_state(r) for r in final)
        return _outcome(
            wp, "unconfirmed", f"CHECK THE CONTROL: {failure}; the roll-back failed too ({exc}); {states}", final
        )
    final = []
    for r in rows:
        value = restored.get(r.component)
        ok = value is not None and _within(value, before[r.component], link.increment)
        final.append(replace(r, restored=value, outcome="rolled_back" if ok else "not_restored"))
    states = "; ".join(_state(r) for r in final)
    if all(r.outcome == "rolled_back" for r in final):
        return _outcome(wp, "rolled_back", f"not confirmed, rolled back: {failure}; {states}", final)
    return _outcome(wp, "unconfirmed", f"CHECK THE CONTROL: {failure}; the roll-back did not hold; {states}", final)


def _state(r: ComponentWrite) -> str:
    def n(v: float | None) -> str:
        return "?" if v is None else f"{v:g}"

    return f"{r.component} before {n(r.before)} written {n(r.written)} read back {n(r.read_back)} now {n(r.restored)}"


def write_to_control(
    model: ProcessModel,
    plan: Plan,
    link: Link,
    *,
    apply: bool = False,
    store: Store | None = None,
) -> WriteOutcome:
    """``machine write``: the dry-run diff, or the guarded sequence with ``apply``; recorded in ``store``.

    Every attempt is recorded when a store is given: a dry run, a refusal, an unreachable control,
    a roll-back.  Never raises a :class:`LinkError` except :class:`LinkConfigError` (an unmapped
    component: bad input, nothing read); a store failure is a :class:`~setupfix.core.errors.StoreError`
    raised after the control was handled (the message of the outcome is then in that error's).
    """
    try:
        wp = plan_write(model, plan, link)
    except LinkConfigError:
        raise
    except LinkError as exc:
        wp = WritePlan(
            plan, link.name, _machine(link, model), link.unit, link.increment, _rows(model, plan, link, None)
        )
        unreachable = isinstance(exc, LinkUnreachable)
        result = _outcome(
            wp,
            "unreachable" if unreachable else "refused",
            f"the control could not be reached: {exc}; nothing written"
            if unreachable
            else f"refused: the control could not be read: {exc}; nothing written",
            wp.rows,
            dry_run=not apply,
        )
    else:
        if apply:
            result = apply_write(model, wp, link)
        else:
            note = f"; the table changed since the plan: {', '.join(map(str, wp.stale))}" if wp.stale else ""
            why = f"; {plan.refusal}" if plan.refusal else ""
            result = _outcome(wp, "dry_run", f"dry run: nothing written{why}{note}", wp.rows, dry_run=True)
    if store is not None:
        store.add_link_attempt(result.attempt())
    return result
