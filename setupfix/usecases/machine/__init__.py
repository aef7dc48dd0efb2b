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
- :func:`report_plan` reads the control and corrects a report with those values (``machine write
  REPORT``); a failed read is audited too;
- :func:`write_to_control` is the whole command: plan, dry run or apply, and the audit record
  (every attempt, an unreachable control and a refusal included) when a store is given.

Values of the control are in the control's unit (``Link.unit``); a rotation in degrees.
"""

from setupfix.usecases.machine.plan import Plan, load_plan, plan_of
from setupfix.usecases.machine.reading import ControlRead, current_from_link, read_control, write_current_csv
from setupfix.usecases.machine.write import (
    OUTCOME_STATUS,
    ComponentWrite,
    Retry,
    WriteOutcome,
    WritePlan,
    apply_write,
    plan_write,
    report_plan,
    write_to_control,
)

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
    "report_plan",
    "OUTCOME_STATUS",
    "Retry",
]
