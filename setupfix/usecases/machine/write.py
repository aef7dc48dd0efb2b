"""``machine write``: the dry-run diff, the guarded sequence of ``machine-link.md``, the audit record."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from setupfix.core.errors import ParameterError, SetupfixError
from setupfix.core.units import length_factor
from setupfix.inputs.stores import StoreRef
from setupfix.links.base import Component, Link
from setupfix.links.errors import (
    EXIT_REFUSED,
    EXIT_UNCONFIRMED,
    EXIT_UNREACHABLE,
    LinkConfigError,
    LinkError,
    LinkLost,
    LinkUnreachable,
)
from setupfix.links.mapping import decimals_of, model_components, round_to_increment, to_control, to_model
from setupfix.model import ProcessModel
from setupfix.store import Store
from setupfix.store.link_audit import LinkAttempt, LinkComponentRecord
from setupfix.usecases.machine.plan import Plan

__all__ = [
    "ComponentWrite",
    "WritePlan",
    "WriteOutcome",
    "plan_write",
    "apply_write",
    "write_to_control",
    "OUTCOME_STATUS",
    "Retry",
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


def apply_write(model: ProcessModel, wp: WritePlan, link: Link, *, retry: Retry | None = None) -> WriteOutcome:
    """The guarded sequence of ``machine-link.md`` on a dry-run diff (nothing is ever written twice).

    1. refuse a plan that is not ``apply`` (draft model, stopped solve, hold, reject);
    2. re-read every component; refuse if any moved since the plan was made (stale);
    3. refuse if the interlock is set, or a change breaks a register's limit;
    4. write every component, one register at a time (new value at the increment, control unit);
    5. read back: every value within half an increment of what was written → ``applied``;
       otherwise (or a connection lost, or a node refused) write back the values read in 2,
       read them back: ``rolled_back``, or ``unconfirmed`` ("CHECK THE CONTROL") if that fails.

    An unreachable control at step 2 is ``unreachable``; every other link error before step 4 a
    refusal with its message.  Never raises a :class:`LinkError`.
    """
    retry = retry or Retry()
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
    failure = ""
    back: dict[Component, float] = {}
    sent: set[Component] = set()
    for group in _by_register(rows):  # one register at a time: what was sent before a failure is known
        try:
            link.write(group)
        except LinkError as exc:
            failure = f"the write failed: {exc}"
            break
        sent.update(group)
    if not failure:
        try:
            back = link.read(comps)
        except LinkError as exc:
            failure = f"the read-back failed: {exc}"
    written_rows = [
        replace(r, written=r.new if r.component in sent else None, read_back=back.get(r.component)) for r in rows
    ]
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
    return _roll_back(checked, link, now, written_rows, failure, retry)


@dataclass(frozen=True)
class Retry:
    """How often a roll-back tries again when the connection is gone (the control may come back).

    Raises
    ------
    ParameterError
        ``attempts`` < 1 or > 100, ``pause_s`` < 0 or > 60.
    """

    attempts: int = 3
    pause_s: float = 2.0

    def __post_init__(self) -> None:
        if not 1 <= self.attempts <= 100:
            raise ParameterError(f"roll-back: attempts must be an int in [1, 100], got {self.attempts}")
        if not 0.0 <= self.pause_s <= 60.0:
            raise ParameterError(f"roll-back: pause_s must be in [0, 60] s, got {self.pause_s}")


def _restore(link: Link, before: Mapping[Component, float]) -> tuple[dict[Component, float], dict[Component, float]]:
    """Read, write back what moved, read again: (values found before the roll-back, values after)."""
    comps = list(before)
    found = link.read(comps)
    moved = {c: before[c] for c in comps if not _within(found[c], before[c], link.increment)}
    if moved:
        link.write(moved)
    return found, link.read(comps)


def _by_register(rows: Sequence[ComponentWrite]) -> list[dict[Component, float]]:
    """The new values grouped by register, in the model's order (a register's components written together)."""
    groups: dict[str, dict[Component, float]] = {}
    for r in rows:
        if r.new is not None:
            groups.setdefault(r.component.register, {})[r.component] = r.new
    return list(groups.values())


def _roll_back(
    wp: WritePlan,
    link: Link,
    before: Mapping[Component, float],
    rows: list[ComponentWrite],
    failure: str,
    retry: Retry,
) -> WriteOutcome:
    """Put back the values read before the write and name every component's state.

    The control is read first and only the components that moved are written back (a read-only
    node or an ignored write left its value as it was), then everything is read again.  A lost or
    unreachable control is tried again ``retry.attempts`` times, ``retry.pause_s`` apart.
    """
    error: LinkError | None = None
    for attempt in range(retry.attempts):
        try:
            found, restored = _restore(link, before)
        except (LinkUnreachable, LinkLost) as exc:
            error = exc
            if attempt + 1 < retry.attempts:
                time.sleep(retry.pause_s)
            continue
        except LinkError as exc:
            error = exc
            break
        rows = [r if r.read_back is not None else replace(r, read_back=found.get(r.component)) for r in rows]
        final = []
        for r in rows:
            value = restored.get(r.component)
            ok = value is not None and _within(value, before[r.component], link.increment)
            final.append(replace(r, restored=value, outcome="rolled_back" if ok else "not_restored"))
        states = "; ".join(_state(r) for r in final)
        if all(r.outcome == "rolled_back" for r in final):
            return _outcome(wp, "rolled_back", f"not confirmed, rolled back: {failure}; {states}", final)
        return _outcome(wp, "unconfirmed", f"CHECK THE CONTROL: {failure}; the roll-back did not hold; {states}", final)
    final = [replace(r, outcome="unknown") for r in rows]
    states = "; ".join(_state(r) for r in final)
    return _outcome(
        wp, "unconfirmed", f"CHECK THE CONTROL: {failure}; the roll-back failed too ({error}); {states}", final
    )


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
    retry: Retry | None = None,
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
            result = apply_write(model, wp, link, retry=retry)
        else:
            note = f"; the table changed since the plan: {', '.join(map(str, wp.stale))}" if wp.stale else ""
            why = f"; {plan.refusal}" if plan.refusal else ""
            result = _outcome(wp, "dry_run", f"dry run: nothing written{why}{note}", wp.rows, dry_run=True)
    if store is not None:
        store.add_link_attempt(result.attempt())
    return result


def report_plan(
    model: ProcessModel,
    report: str | Path,
    link: Link,
    *,
    part: str | None = None,
    apply: bool = False,
    store: StoreRef | None = None,
) -> Plan:
    """``machine write REPORT``: the control read, the report corrected with those values, its plan.

    The report must give one part (``part`` picks it).  A read that fails (the control unreachable,
    or refusing while a program runs) is recorded in ``store``'s audit like every other attempt, then
    raised (the store is opened only then: a bad report creates no store); a link-file error is bad
    input and is raised unrecorded.
    """
    from parsers.names import visible_name
    from setupfix.usecases.correct import correct_report, load_request
    from setupfix.usecases.machine.plan import plan_of
    from setupfix.usecases.machine.reading import current_from_link
    from setupfix.usecases.requests import CycleOptions

    try:
        current = current_from_link(link, model)
    except LinkConfigError:
        raise
    except LinkError:
        if store is not None:
            unread = Plan(str(report), "", "unknown", False, (), None)
            with store.open(existing=False) as opened:
                write_to_control(model, unread, link, apply=apply, store=opened)
        raise
    outcome = correct_report(load_request(model, cycles=CycleOptions(part=part), current=current), report)
    if len(outcome.cycles) != 1:
        raise SetupfixError(
            f"{visible_name(str(report))}: {len(outcome.cycles)} parts: one part is written (give --part ID)"
        )
    return plan_of(outcome.cycles[0], current, str(report))
