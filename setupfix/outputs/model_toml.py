"""The text of a ``model init`` scaffold: one-axis or multi-axis TOML from the dimensions collected.

:mod:`setupfix.usecases.model_init` collects one :class:`ScaffoldDimension` per toleranced
characteristic (what it measures, its axis, measuring direction, size, feature and the
positions as the reports state them) and, for a multi-axis scaffold, one
:class:`ScaffoldFeature` per feature of the part; :func:`render_scaffold` writes the model
file (``../shared/spec/process-model.md``):

* **one axis** — every feature moved by W1 (G54) and, when the process axis is the spindle
  axis (Z), by T1 (H1) with the weight the report states (the component of its measuring
  direction along the axis: −1 for a normal facing −axis, 0.59 for an oblique one; +1
  where only an axis word or the name states it); a size is moved by no register here (only
  a tool radius moves it: a multi-axis model holds one); a distance between two features
  by none either (a work offset shifts both ends alike);
* **multi-axis** (``process.axes``: the axes the reports measure) — one model feature per
  feature of the part, at the report's nominal position; a location is that feature along
  the report's axis or direction; a distance the difference of its two features
  (``{ Fb = 1, Fa = -1 }``: a work offset shared by both cancels); a size (``kind =
  "size"``) a feature of its own moved only by a tool radius, and only where it is cut by
  interpolation (circle, cylinder, arc, slot: weight −2 for a bore's diameter, +2 for a
  boss's, ±1 for a radius); a position callout a circular zone (``kind = "position"``) in
  the plane across the feature's axis.  Which work offset and which tool made each
  feature no report says: each such feature carries a named question
  (:data:`QUESTION_KEY` ``= "question Qn: …"``) and no relation until ``setupfix model map``
  answers it (:mod:`setupfix.usecases.model_map`).

Every scaffold is ``[process] draft = true``: ``correct`` holds with the rule ``draft``
until the user has checked the physics and removed the key (``model map`` removes it when
it has answered the last question).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from parsers.geometry import INTERPOLATED

__all__ = [
    "ScaffoldDimension",
    "ScaffoldFeature",
    "render_scaffold",
    "SPINDLE",
    "toml_string",
    "comment",
    "QUESTION_KEY",
    "question_note",
    "MEASURES",
]

#: The spindle axis a scaffold assumes (a vertical machining centre); the file says so.
SPINDLE = "Z"
_AXES = ("X", "Y", "Z")
#: A component below this is no component (nominal vectors are exact to 1e-14 in every sample).
_ZERO = 1e-9
#: The free-text key of a feature table that holds its open question (``note``: every table may hold it).
QUESTION_KEY = "note"
#: What a characteristic measures: a feature's location along an axis or direction, a distance between
#: two features, a size of one (diameter, width …), or a position callout (a circular zone).
MEASURES = ("location", "distance", "size", "position")


def question_note(name: str, text: str, radius_weight: int | None = None) -> str:
    """The ``note`` of a feature with an open question: ``question Q3: which … made it?`` (and the radius weight
    its tool's radius offset gets once the tool is known, for a size cut by interpolation)."""
    tail = f" (radius weight {radius_weight})" if radius_weight is not None else ""
    return f"question {name}: {text}{tail}"


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
    #: What it measures, one of :data:`MEASURES` (set by the collection).
    measures: str = "location"
    #: The report's name of its feature ("" when it names none).
    feature_id: str = ""
    #: The report's names of the features a distance is measured between, in the report's order.
    between: tuple[str, ...] = ()
    #: The feature's own direction (a cylinder's axis, a plane's normal), unit vector, when the report states it.
    feature_axis: tuple[float, float, float] | None = None
    #: Multi-axis scaffold: the model features it enters with their weights (set by the planning).
    weights: dict[str, float] = field(default_factory=dict)
    #: A position zone: its two component characteristics and plane (set by the planning).
    components: tuple[str, str] = ("", "")
    plane: tuple[str, str] = ("X", "Y")
    #: Why the planning wrote what it wrote, for the dimension's comment.
    why: str = ""

    def axis_note(self) -> str:
        """The comment on the dimension's axis: which one, and from what."""
        if self.measures == "position":
            return "a position callout" + (f" of {self.feature_id}" if self.feature_id else "")
        if self.size:
            return f"a {self.size}" + (f" of a {self.feature}" if self.feature else "") + " stated by the report"
        lead = "a distance; " if self.measures == "distance" else ""
        if self.axis is None:
            if self.direction is not None:
                return lead + "oblique direction stated by the report"
            return lead + (f"no axis: {self.axis_from}" if self.axis_from else "no axis stated")
        if self.axis_from == "report":
            return (
                lead
                + f"axis {self.axis} stated by the report"
                + (f" (its name says {self.name_says}: the report's vector wins)" if self.name_says else "")
            )
        return lead + f"axis {self.axis} from the name"

    def vector(self) -> tuple[float, float, float] | None:
        """The measuring direction: the report's vector, else the unit vector of the axis; None without either."""
        if self.direction is not None:
            return self.direction
        return _unit_axis(self.axis) if self.axis in _AXES else None

    def measured_axes(self) -> set[str]:
        """The machine axes along which this dimension moves with its feature (none for a size; a position
        zone's plane)."""
        if self.measures == "position":
            return set(self.plane)
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


@dataclass
class ScaffoldFeature:
    """One model feature of a multi-axis scaffold: a feature of the part, or the size of one.

    ``role`` "location": once answered, the work offset that made it moves it in every axis and
    its tool's length along the spindle; "size": only its tool's radius moves it (by
    ``radius_weight``; None: by nothing, the report does not say it is interpolated).
    ``question``: the name of its open question (``Q3``; the size feature of a located one
    shares its question), "" when nothing is asked.
    """

    id: str
    label: str
    position: tuple[float, float, float] | None = None
    kind: str = ""
    role: str = "location"
    radius_weight: int | None = None
    question: str = ""
    callouts: list[str] = field(default_factory=list)
    comment: str = ""

    def ask(self) -> str:
        """The question's text: which work offset and tool made it (a size: which tool cut it)."""
        if self.role == "size":
            return "which tool cut it?"
        return "which work offset (WKS) and which tool made it?"

    def where(self) -> str:
        """``CYL3 (a cylinder at 5.5, 96.1, 5.4)``: what the report says about it, for comments and listings."""
        at = f" at {', '.join(f'{v:.6g}' for v in self.position)}" if self.position is not None else ""
        kind = f"a{'n' if self.kind[:1] in tuple('aeiou') else ''} {self.kind}" if self.kind else ""
        inner = ", ".join(x for x in (kind + at if kind else at.strip(),) if x)
        return comment(self.label) + (f" ({inner})" if inner else "")


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


def _dimension(i: int, d: ScaffoldDimension, lines: list[str], weights: dict[str, float] | None = None) -> list[str]:
    """A dimension table; ``weights``: the features it enters (default: its own ``F{i}``)."""
    out = [
        f"[dimensions.D{i}]  # {comment(d.source)}; {comment(d.axis_note())}",
        *([f"# {comment(d.why)}"] if d.why else []),
        f"name = {toml_string(d.name)}",
        f"features = {{ F{i} = 1 }}" if weights is None else f"features = {_table(weights)}",
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
    features: Sequence[ScaffoldFeature] = (),
) -> str:
    """The scaffold's TOML text: one-axis on ``axis`` when ``axes`` is empty, else multi-axis over ``axes``
    with the model ``features`` planned for it (the dimensions' ``weights`` name them)."""
    sources = ", ".join(Path(r).name for r in reports)
    title = name or f"Scaffold from {sources}"
    if axes:
        return _multi_axis(dims, features, skipped, sources, title, list(axes), resolution)
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
                if any(d.axis for d in dims)
                else f" (no dimension states an axis: the spindle axis {SPINDLE} assumed; use --axis)"
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
        elif d.measures == "distance":
            out += [
                f"[features.F{i}]  # a distance between two features: a work offset moves both ends alike, so "
                "none moves it; if its ends are in different setups or cut by different tools, give its "
                "dimension features = { Fa = 1, Fb = -1 } instead",
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
    features: Sequence[ScaffoldFeature],
    skipped: Sequence[tuple[str, str]],
    sources: str,
    title: str,
    axes: list[str],
    resolution: float,
) -> str:
    questions: dict[str, list[ScaffoldFeature]] = {}
    for f in features:
        if f.question:
            questions.setdefault(f.question, []).append(f)
    asked = [
        f"#   {q} {', '.join(f.id for f in fs)} {fs[0].where()}: {_lead(fs).ask()}"
        f" ({', '.join(comment(c) for c in dict.fromkeys(c for f in fs for c in f.callouts))})"
        for q, fs in questions.items()
    ]
    out = _head(
        sources,
        dims,
        skipped,
        [
            "#   1. the questions below: which work offset (WKS) and which tool made each feature; the reports",
            "#      do not say, so those features are moved by nothing until answered: `setupfix model map`",
            "#      lists them and writes the answers (one by one, by group, or from a CSV), adding the",
            "#      [wks.*] and [tools.*] registers they name;",
            f"#   2. tool lengths act along the spindle ({SPINDLE} assumed: set `spindle`); a work offset seen from",
            "#      another side needs a table {x = .., y = .., z = ..} per axis;",
            "#   3. [dimensions.*]: a location is its feature along the axis or direction the report states,",
            "#      a distance the difference of its two features { Fb = 1, Fa = -1 } (no work offset term",
            "#      unless the two sit in different setups), a size moves only with a tool radius where the",
            "#      report's feature type says it is interpolated (bore -2, boss 2), a position callout is a",
            "#      circular zone in the plane across its feature's axis;",
            '#   4. group = "P1" … where a fixture holds the part at several stations; rotation = true',
            "#      corrects each WKS's rotation about the spindle too (the positions below are the report's).",
            f"# {len(dims)} dimension(s), {len(features)} feature(s); axes {', '.join(axes)} (the ones the reports "
            "measure).",
            *(
                [f"# Questions ({len(questions)}; `correct` holds until each is answered):", *asked]
                if questions
                else []
            ),
        ],
    )
    out += _process(
        title,
        resolution,
        [
            f"axes = [{', '.join(toml_string(a) for a in axes)}]   # the axes the reports measure",
            f'spindle = "{SPINDLE}"          # assumed (a vertical machining centre): tool lengths act along it only',
        ],
    )
    for f in features:
        head = f"[features.{f.id}]  # {f.where()}" + (f"; {comment(f.comment)}" if f.comment else "")
        lines = [head]
        if f.role == "size":
            lines.append("radius = {}" if f.radius_weight is not None else "wks = {}")
        else:
            lines.append("wks = {}")
        if f.position is not None:
            lines.append(f"position = [{', '.join(_number(v) for v in f.position)}]")
        if f.question:
            note = question_note(f.question, f.ask(), f.radius_weight if f.role == "size" else None)
            lines.append(f"{QUESTION_KEY} = {toml_string(note)}")
        out += [*lines, ""]
    for i, d in enumerate(dims, start=1):
        out += _zone(i, d) if d.measures == "position" else _dimension(i, d, _dimension_lines(d), d.weights)
    return "\n".join(out)


def _lead(features: Sequence[ScaffoldFeature]) -> ScaffoldFeature:
    """The feature a question is asked of: its located one when it has one, else its first."""
    return next((f for f in features if f.role == "location"), features[0])


def _dimension_lines(d: ScaffoldDimension) -> list[str]:
    """The multi-axis keys of a length or a size: ``kind``, ``axis`` or ``direction``."""
    vec = d.vector()
    if d.size:
        return ['kind = "size"']
    if vec is None:
        return []
    if d.axis in _AXES and (d.direction is None or d.direction == _unit_axis(d.axis)):
        return [f'axis = "{d.axis}"']
    return [f"direction = [{', '.join(_weight(v + 0.0) for v in vec)}]"]


def _zone(i: int, d: ScaffoldDimension) -> list[str]:
    """A position callout as a circular zone: its components, plane and diameter (the report's tolerance)."""
    out = [
        f"[dimensions.D{i}]  # {comment(d.source)}; {comment(d.axis_note())}",
        *([f"# {comment(d.why)}"] if d.why else []),
        f"name = {toml_string(d.name)}",
        f"features = {_table(d.weights)}",
        'kind = "position"',
        f"components = [{', '.join(toml_string(c) for c in d.components)}]",
        f"axes = [{', '.join(toml_string(a) for a in d.plane)}]",
        f"diameter = {_number(d.upper)}",
    ]
    if d.group:
        out.append(f"group = {toml_string(d.group)}")
    return [*out, ""]


def _table(weights: dict[str, float]) -> str:
    if not weights:
        return "{}"
    return "{ " + ", ".join(f"{k} = {_weight(w)}" for k, w in weights.items()) + " }"
