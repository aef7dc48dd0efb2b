"""The text of a ``model init`` scaffold: one-axis or multi-axis TOML from the dimensions collected.

:mod:`setupfix.usecases.model_init` collects one :class:`ScaffoldDimension` per toleranced
characteristic (its axis, measuring direction, size and feature as the reports state
them); :func:`render_scaffold` writes the model file (``../shared/spec/process-model.md``):

* **one axis** — today's topology: every feature moved by W1 (G54) and, when the process
  axis is the spindle axis (Z), by T1 (H1) with the weight the report states (the
  component of its measuring direction along the axis: −1 for a normal facing −axis,
  0.59 for an oblique one; +1 where only an axis word or the name states it); a size is
  moved by no register here (only a tool radius moves it: a multi-axis model holds one);
* **multi-axis** (``process.axes``: the axes the reports measure) — every feature moved
  by W1 in every axis; each dimension measured along the ``axis`` or ``direction`` the
  report states; T1's length (H1) only where that direction has a component along the
  spindle; a size (``kind = "size"``) moved only by T1's radius (D1), and only where its
  feature is cut by interpolation (circle, cylinder, arc, slot), with weight −2 for a
  bore's diameter, +2 for a boss's (−1 / +1 for a radius); any other size is left
  uncorrectable and its comment says why.

Every scaffold is ``[process] draft = true``: ``correct`` holds with the rule ``draft``
until the user has checked the physics and removed the key.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from parsers.geometry import INTERPOLATED

__all__ = ["ScaffoldDimension", "render_scaffold", "SPINDLE", "toml_string", "comment"]

#: The spindle axis a scaffold assumes (a vertical machining centre); the file says so.
SPINDLE = "Z"
_AXES = ("X", "Y", "Z")
#: A component below this is no component (nominal vectors are exact to 1e-14 in every sample).
_ZERO = 1e-9


def _unit_axis(axis: str | None) -> tuple[float, float, float]:
    return (1.0 if axis == "X" else 0.0, 1.0 if axis == "Y" else 0.0, 1.0 if axis == "Z" else 0.0)


def toml_string(text: str) -> str:
    """A TOML basic string (JSON escapes are TOML escapes; DEL is escaped too)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def comment(text: str) -> str:
    """Text safe inside a TOML comment (one line, no control characters)."""
    return "".join(c if c.isprintable() else "?" for c in text)


def _number(value: float) -> str:
    text = f"{value:.12g}"
    return text if any(c in text for c in ".en") else text + ".0"


def _weight(value: float) -> str:
    """A relation weight: a whole number as an integer (``1``, ``-2``), else its 12 significant digits."""
    return str(int(value)) if value == int(value) else f"{value:.12g}"


@dataclass
class ScaffoldDimension:
    """One toleranced characteristic as the scaffold writes it (lengths in mm)."""

    name: str
    group: str | None
    nominal: float
    lower: float
    upper: float
    axis: str | None
    source: str
    #: Where ``axis`` came from: "report" (the axis column or the direction), "name", "" (neither
    #: states one), or why there is none although reports state one ("the reports state X and Y").
    axis_from: str = ""
    #: The axis the name states when it differs from the report's.
    name_says: str | None = None
    #: The measuring direction the report states (unit vector), else None.
    direction: tuple[float, float, float] | None = None
    #: "diameter", "radius", "width", "length" when the report says the value is a size, else "".
    size: str = ""
    #: The feature type the report states ("circle", "plane", …), else "".
    feature: str = ""
    #: "inner" / "outer" where the report says so, else "".
    side: str = ""
    #: The feature's nominal location, when the report gives all three coordinates.
    position: tuple[float, float, float] | None = None

    def axis_note(self) -> str:
        """The comment on the dimension's axis: which one, and from what."""
        if self.size:
            return f"a {self.size}" + (f" of a {self.feature}" if self.feature else "") + " stated by the report"
        if self.axis is None:
            if self.direction is not None:
                return "oblique direction stated by the report"
            return f"no axis: {self.axis_from}" if self.axis_from else "no axis stated"
        if self.axis_from == "report":
            return f"axis {self.axis} stated by the report" + (
                f" (its name says {self.name_says}: the report's vector wins)" if self.name_says else ""
            )
        return f"axis {self.axis} from the name"

    def vector(self) -> tuple[float, float, float] | None:
        """The measuring direction: the report's vector, else the unit vector of the axis; None without either."""
        if self.direction is not None:
            return self.direction
        return _unit_axis(self.axis) if self.axis in _AXES else None

    def measured_axes(self) -> set[str]:
        """The machine axes along which this dimension moves with its feature (none for a size)."""
        vec = self.vector()
        if self.size or vec is None:
            return set()
        return {a for a, v in zip(_AXES, vec, strict=True) if abs(v) > _ZERO}

    @property
    def interpolated(self) -> bool:
        """A size whose feature type the report states as cut by interpolation (a tool radius moves it)."""
        return bool(self.size) and self.feature in INTERPOLATED

    def radius_weight(self) -> int:
        """How a tool-radius offset change moves this size: −2 (bore diameter, slot width), +2 (boss), ±1 radius."""
        per_wall = 1 if self.side == "outer" else -1  # a bore when the report does not say
        return per_wall * (1 if self.size == "radius" else 2)


def _head(
    sources: str,
    dims: Sequence[ScaffoldDimension],
    skipped: Sequence[tuple[str, str]],
    lines: list[str],
) -> list[str]:
    out = [
        f"# Process model scaffold written by `setupfix model init` from: {comment(sources)}",
        "# DRAFT: its relations are a guess from the reports' geometry. `setupfix correct` holds with",
        '#   "edit the model (draft)" and recommends nothing until you have checked them and removed',
        "#   `draft = true` from [process]. Check",
        *lines,
        "# Then `setupfix model show` prints the matrices and `setupfix model check` the match table.",
    ]
    if skipped:
        out.append(f"# Left out ({len(skipped)}):")
        for char, reason in skipped[:200]:
            out.append(f"#   {comment(char)}: {reason}")
        if len(skipped) > 200:
            out.append(f"#   … and {len(skipped) - 200} more")
    return out


def _process(title: str, resolution: float, axes_line: list[str]) -> list[str]:
    return [
        "",
        "[process]",
        f"name = {toml_string(title)}",
        *axes_line,
        'unit = "mm"             # every length below is in mm (the reports were converted)',
        f"{'resolution = ' + _number(resolution):<24}# the controller's offset step",
        "limit = 0.1             # bound on |correction| of every register; per register: limit = …",
        "draft = true            # an unchecked scaffold: check the physics below, then remove this line",
        "",
        "[wks.W1]",
        'register = "G54"        # rename; add [wks.W2] register = "G55" … per work offset',
        "",
    ]


def _dimension(i: int, d: ScaffoldDimension, lines: list[str]) -> list[str]:
    out = [
        f"[dimensions.D{i}]  # {comment(d.source)}; {comment(d.axis_note())}",
        f"name = {toml_string(d.name)}",
        f"features = {{ F{i} = 1 }}",
        *lines,
        f"nominal = {_number(d.nominal)}",
        f"lower = {_number(d.lower)}",
        f"upper = {_number(d.upper)}",
    ]
    if d.group:
        out.append(f"group = {toml_string(d.group)}")
    return [*out, ""]


def _position(d: ScaffoldDimension) -> list[str]:
    if d.position is None:
        return []
    return [f"position = [{', '.join(_number(v) for v in d.position)}]"]


def render_scaffold(
    dims: Sequence[ScaffoldDimension],
    skipped: Sequence[tuple[str, str]],
    reports: Sequence[str | Path],
    *,
    axis: str,
    axes: Sequence[str],
    resolution: float,
    name: str | None,
    only_axis: str | None,
) -> str:
    """The scaffold's TOML text: one-axis on ``axis`` when ``axes`` is empty, else multi-axis over ``axes``."""
    sources = ", ".join(Path(r).name for r in reports)
    title = name or f"Scaffold from {sources}"
    if axes:
        return _multi_axis(dims, skipped, sources, title, list(axes), resolution)
    return _one_axis(dims, skipped, sources, title, axis, resolution, only_axis)


def _one_axis(
    dims: Sequence[ScaffoldDimension],
    skipped: Sequence[tuple[str, str]],
    sources: str,
    title: str,
    axis: str,
    resolution: float,
    only_axis: str | None,
) -> str:
    tools = axis == SPINDLE
    out = _head(
        sources,
        dims,
        skipped,
        [
            f"#   1. [wks.*]{' and [tools.*]' if tools else ''}: the registers your NC program really uses;",
            "#   2. [features.*]: which WKS and tools move each feature and with which weight (the weight",
            "#      written is the component of the report's measuring direction along the axis, +1 where",
            "#      only an axis word or the name states it), and remove features no offset moves;",
            "#   3. [dimensions.*] features: a distance between two features is { Fa = 1, Fb = -1 };",
            '#   4. group = "P1" … where a fixture holds the part at several stations.',
            f"# {len(dims)} dimension(s); axis {axis}"
            + (
                f" (kept: dimensions along {only_axis} or with no axis stated)"
                if only_axis
                else " (the one most dimensions state; other axes are kept: delete them or use --axis)"
            ),
            "# Each dimension's axis is the one the report states (CORTOL axis, QIF direction or vector,",
            "#   a plane or point normal), else the one its name states; its comment says which.",
        ],
    )
    out += _process(title, resolution, [f'axis = "{axis}"'])
    if tools:
        out += ["[tools.T1]", 'register = "H1"         # rename; add [tools.T2] … per tool length offset', ""]
    else:
        out += [
            f"# No tool length register: a tool length offset acts along the spindle ({SPINDLE} assumed), not",
            f'#   along {axis}. On a machine whose spindle is {axis}, add [tools.T1] register = "H1".',
            "",
        ]
    for i, d in enumerate(dims, start=1):
        vec = d.vector()
        k = _AXES.index(axis)
        if d.size:
            out += [
                f"[features.F{i}]  # a {d.size}: no WKS or tool length offset moves it (a tool radius does where "
                "it is interpolated: a multi-axis model holds radius registers)",
                "wks = {}",
                "tools = {}",
                *_position(d),
                "",
            ]
        elif d.axis not in (None, axis) or (vec is not None and abs(vec[k]) <= _ZERO):
            out += [
                f"[features.F{i}]  # axis {d.axis or 'oblique'}: no {axis} offset moves it (nothing to correct here)",
                "wks = {}",
                "tools = {}",
                *_position(d),
                "",
            ]
        else:
            w = _weight(vec[k]) if vec is not None else "1"
            out += [
                f"[features.F{i}]",
                f"wks = {{ W1 = {w} }}",
                f"tools = {{ T1 = {w} }}" if tools else "tools = {}",
                *_position(d),
                "",
            ]
    for i, d in enumerate(dims, start=1):
        out += _dimension(i, d, [])
    return "\n".join(out)


def _multi_axis(
    dims: Sequence[ScaffoldDimension],
    skipped: Sequence[tuple[str, str]],
    sources: str,
    title: str,
    axes: list[str],
    resolution: float,
) -> str:
    length = any(SPINDLE in d.measured_axes() for d in dims)
    radius = any(d.interpolated for d in dims)
    out = _head(
        sources,
        dims,
        skipped,
        [
            "#   1. [wks.*] and [tools.*]: the registers your NC program really uses (W1 moves every feature",
            f"#      in {', '.join(axes)}; tool lengths act along the spindle, {SPINDLE} assumed: set `spindle`);",
            "#   2. [features.*]: which WKS and tools move each feature (a table {x = .., y = .., z = ..}",
            "#      per axis for a WKS seen from another side) and remove features no offset moves;",
            "#   3. [dimensions.*]: each is measured along the axis or direction the report states",
            "#      (a normal's components are its weights); a distance between two features is",
            "#      { Fa = 1, Fb = -1 }; sizes move only with a tool radius where the report's feature",
            "#      type says it is interpolated (bore -2, boss 2): a drilled hole's size moves with none;",
            '#   4. group = "P1" … where a fixture holds the part at several stations; rotation = true',
            "#      corrects each WKS's rotation about the spindle too (the positions below are the report's).",
            f"# {len(dims)} dimension(s); axes {', '.join(axes)} (the ones the reports measure).",
        ],
    )
    out += _process(
        title,
        resolution,
        [
            f"axes = [{', '.join(toml_string(a) for a in axes)}]"
            "   # the axes the reports measure: W1 is corrected in each",
            f'spindle = "{SPINDLE}"          # assumed (a vertical machining centre): tool lengths act along it only',
        ],
    )
    if length or radius:
        out += ["[tools.T1]", 'register = "H1"         # its length offset; rename, add [tools.T2] … per tool']
        if radius:
            out.append('radius = "D1"           # its radius offset: moves the interpolated sizes below')
        out.append("")
    for i, d in enumerate(dims, start=1):
        if d.size and d.interpolated:
            out += [
                f"[features.F{i}]  # a {d.size} of a{'n' if d.feature[0] in 'aeiou' else ''} {d.feature}"
                + (f" ({d.side})" if d.side else " (the report does not say bore or boss: a bore assumed)"),
                f"radius = {{ T1 = {d.radius_weight()} }}",
                *_position(d),
                "",
            ]
        elif d.size:
            what = f"a {d.feature}" if d.feature else "a feature of no stated type (drilled or reamed?)"
            out += [
                f"[features.F{i}]  # the {d.size} of {what}: moved by no offset register, uncorrectable",
                "wks = {}",
                *_position(d),
                "",
            ]
        elif d.vector() is None:
            out += [
                f"[features.F{i}]  # no axis or direction stated: give its dimension axis = … and its relations",
                "wks = {}",
                *_position(d),
                "",
            ]
        else:
            out += [f"[features.F{i}]", "wks = { W1 = 1 }"]
            out += ["tools = { T1 = 1 }"] if SPINDLE in d.measured_axes() else []
            out += [*_position(d), ""]
    for i, d in enumerate(dims, start=1):
        vec = d.vector()
        if d.size:
            lines = ['kind = "size"']
        elif vec is None:
            lines = []
        elif d.axis in _AXES and (d.direction is None or d.direction == _unit_axis(d.axis)):
            lines = [f'axis = "{d.axis}"']
        else:
            lines = [f"direction = [{', '.join(_weight(v + 0.0) for v in vec)}]"]
        out += _dimension(i, d, lines)
    return "\n".join(out)
