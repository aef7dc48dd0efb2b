"""The control's values a decision was made with: recorded in the plan, checked before a write.

``correct --json`` with ``--link`` holds them under ``"link"``; ``machine write --apply`` re-reads
the control and refuses when any component moved by more than half an increment since
(``../shared/spec/machine-link.md``, step 1).

```json
"link": {"name": "opc.tcp://10.0.0.7:4840 (mc07.toml)", "machine": "mc-07", "unit": "mm",
         "increment": 0.001, "current": [{"register": "G54", "axis": "X", "value": -412.53}]}
```
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from setupfix.core.errors import ParseError, SourceLocation
from setupfix.links.base import Component

__all__ = ["ControlSnapshot"]


@dataclass(frozen=True)
class ControlSnapshot:
    """Values read from one control (control unit), with the link that read them (never a secret)."""

    link: str
    unit: str
    increment: float
    values: tuple[tuple[Component, float], ...]
    machine: str | None = None

    @property
    def as_dict(self) -> dict[Component, float]:
        return dict(self.values)

    @classmethod
    def of(
        cls, link: str, unit: str, increment: float, values: Mapping[Component, float], machine: str | None = None
    ) -> ControlSnapshot:
        return cls(link, unit, float(increment), tuple((c, float(v)) for c, v in values.items()), machine)

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.link,
            "machine": self.machine,
            "unit": self.unit,
            "increment": self.increment,
            "current": [{"register": c.register, "axis": c.axis, "value": v} for c, v in self.values],
        }

    @classmethod
    def from_json(cls, obj: Any, where: SourceLocation) -> ControlSnapshot:
        """The ``"link"`` object of a plan.

        Raises
        ------
        ParseError
            Naming the file and key: a missing or mistyped field, an unknown axis, a value that is not finite.
        """

        def bad(what: str, key: str = "link") -> ParseError:
            return ParseError(what, location=SourceLocation(where.path, key=key))

        if not isinstance(obj, dict):
            raise bad("expected an object")
        unit, increment, name = obj.get("unit"), obj.get("increment"), obj.get("name")
        if unit not in ("mm", "inch"):
            raise bad(f"expected mm or inch, found {unit!r}", "link.unit")
        if isinstance(increment, bool) or not isinstance(increment, int | float) or not increment > 0:
            raise bad(f"expected a number > 0, found {increment!r}", "link.increment")
        rows = obj.get("current")
        if not isinstance(rows, list) or not rows:
            raise bad("expected a list of {register, axis, value}", "link.current")
        values: list[tuple[Component, float]] = []
        for i, row in enumerate(rows):
            key = f"link.current[{i}]"
            if not isinstance(row, dict):
                raise bad("expected {register, axis, value}", key)
            value = row.get("value")
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise bad(f"expected a finite number, found {value!r}", f"{key}.value")
            try:
                comp = Component(str(row.get("register", "")), str(row.get("axis", "")))
            except ValueError as exc:
                raise bad(str(exc), key) from None
            values.append((comp, float(value)))
        machine = obj.get("machine")
        return cls(
            str(name or ""), str(unit), float(increment), tuple(values), str(machine) if machine is not None else None
        )
