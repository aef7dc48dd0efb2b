"""Answers to a scaffold's questions, written into the model text (:mod:`setupfix.usecases.model_map`)."""

from __future__ import annotations

import csv
import fnmatch
import io
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from setupfix.core.atomic import check_target, write_text
from setupfix.core.errors import ModelError, ParseError, SourceLocation
from setupfix.model import model_from_dict, normalise_name
from setupfix.outputs.model_toml import QUESTION_KEY, toml_string
from setupfix.usecases.model_map.listing import (
    HEADER,
    QUESTION,
    TABLE_KEY,
    MapListing,
    Question,
    listing_of,
    model_document,
    read_model_text,
)

__all__ = ["Answer", "MapResult", "parse_answer", "read_answers", "answer_questions", "answer_text", "NONE_WORDS"]

_REGISTER = re.compile(r"^[A-Za-z][A-Za-z0-9.]{0,15}$")
_TOOL = re.compile(r"^[THDthd]?(\d{1,4})$")
#: Answers meaning "no work offset" / "no tool" (the feature is moved by none of them).
NONE_WORDS = frozenset({"none", "-", "no"})


@dataclass(frozen=True)
class Answer:
    """One answer: the questions ``selector`` picks were made on ``wks`` by ``tool``.

    ``wks`` / ``tool``: a register or ID (``G55``, ``W2``; ``T5``, ``H5``, ``5``), ``"none"``,
    or ``""`` (not given: allowed only where the question does not ask for it).
    ``where``: the CSV line or option it came from, for messages.
    """

    selector: str
    wks: str
    tool: str
    where: SourceLocation


@dataclass(frozen=True)
class MapResult:
    """What :func:`answer_questions` wrote."""

    text: str
    answered: tuple[tuple[str, str, str], ...]  # (question, WKS ID or "none", tool ID or "none")
    remaining: tuple[str, ...]
    added: tuple[str, ...]  # the register tables added, e.g. ("W2 G55", "T5 H5 D5")
    draft_lifted: bool
    draft: bool


def parse_answer(spec: str, where: SourceLocation) -> list[Answer]:
    """``SEL[,SEL…]=WKS,TOOL`` (an ``--answer`` option) as answers, one per selector."""
    head, sep, tail = spec.partition("=")
    parts = [p.strip() for p in tail.split(",")]
    if not sep or not head.strip() or len(parts) != 2:
        raise ParseError(
            f"answer {spec!r}: expected SELECTOR[,SELECTOR…]=WKS,TOOL, e.g. Q1,Q3=G54,T4 or DIAMETER5*=,T2",
            location=where,
        )
    return [Answer(s.strip(), parts[0], parts[1], where) for s in head.split(",") if s.strip()]


def read_answers(path: str | Path) -> list[Answer]:
    """The answers of a CSV file with the columns ``feature``, ``wks``, ``tool`` (a header line first).

    ``feature`` is any selector (question, feature ID, report feature or callout name, a
    pattern, ``group:P1``, ``*``).

    Raises
    ------
    ParseError
        If the file cannot be read or lacks a column, naming the file and line.
    """
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ParseError(f"cannot read the answers: {exc}", location=SourceLocation(str(path))) from None
    reader = csv.reader(io.StringIO(text))
    rows = list(reader)
    if not rows:
        raise ParseError("no header line (feature,wks,tool)", location=SourceLocation(str(path), line=1))
    header = [h.strip().lower() for h in rows[0]]
    missing = [c for c in ("feature", "wks", "tool") if c not in header]
    if missing:
        raise ParseError(
            f"missing column(s) {', '.join(missing)} (expected feature, wks, tool)",
            location=SourceLocation(str(path), line=1),
        )
    at = {c: header.index(c) for c in ("feature", "wks", "tool")}
    answers = []
    for n, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) < len(header):
            raise ParseError(f"{len(row)} field(s), expected {len(header)}", location=SourceLocation(str(path), line=n))
        answers.append(
            Answer(
                row[at["feature"]].strip(),
                row[at["wks"]].strip(),
                row[at["tool"]].strip(),
                SourceLocation(str(path), line=n),
            )
        )
    return answers


def _select(listing: MapListing, selector: str) -> list[Question]:
    """The open questions a selector picks."""
    key = normalise_name(selector)
    if key == "*":
        return list(listing.questions)
    if key.startswith(("group:", "station:")):
        group = normalise_name(key.split(":", 1)[1])
        return [q for q in listing.questions if any(group in map(normalise_name, f.groups) for f in q.features)]
    pattern = any(c in selector for c in "*?[")

    def hit(name: str) -> bool:
        name = normalise_name(name)
        return fnmatch.fnmatchcase(name, key) if pattern else name == key

    return [
        q
        for q in listing.questions
        if hit(q.name) or any(hit(f.id) or hit(f.label) or any(hit(c) for c in f.callouts) for f in q.features)
    ]


def _breadth(selector: str) -> int:
    """0 for one name, 1 for a station group, 2 for a pattern, 3 for ``*``: narrower answers win."""
    key = selector.strip()
    if key == "*":
        return 3
    if any(c in key for c in "*?["):
        return 2
    return 1 if normalise_name(key).startswith(("group:", "station:")) else 0


def _resolve_wks(value: str, known: dict[str, str], added: dict[str, str], where: SourceLocation) -> str:
    """The WKS ID an answer names (an ID or register of the model, else a new table), or "" for none."""
    if value.strip().lower() in NONE_WORDS:
        return ""
    for wid, register in {**known, **added}.items():
        if value == wid or normalise_name(value) == normalise_name(register):
            return wid
    if not _REGISTER.match(value):
        raise ParseError(
            f"work offset {value!r}: expected a register such as G54, G55, G54.1P7, or none", location=where
        )
    n = 1
    while f"W{n}" in known or f"W{n}" in added:
        n += 1
    added[f"W{n}"] = value.upper()
    return f"W{n}"


def _resolve_tool(value: str, known: dict[str, str], where: SourceLocation) -> str:
    """The tool ID an answer names (``T5``, ``H5``, ``5`` → ``T5``; a model ID as it is), or "" for none."""
    if value.strip().lower() in NONE_WORDS:
        return ""
    if value in known:
        return value
    for tid, register in known.items():
        if normalise_name(value) == normalise_name(register):
            return tid
    m = _TOOL.match(value.strip())
    if not m:
        raise ParseError(f"tool {value!r}: expected a tool such as T5 (H5, D5 or 5), or none", location=where)
    return f"T{int(m.group(1))}"


def answer_questions(
    model: str | Path,
    answers: Sequence[Answer],
    *,
    out: str | Path | None = None,
    keep_draft: bool = False,
) -> MapResult:
    """Write ``answers`` into the model (``out``, default the model itself, atomically).

    Every answer must select at least one open question and give what it asks (a work
    offset where a located feature asks for one, a tool always: ``none`` where none);
    two answers may not answer one question differently.  The new text must load.

    Raises
    ------
    ParseError
        An answer is malformed, selects nothing, lacks what its question asks, or two disagree
        (naming its CSV line or option).
    ModelError
        The model does not load, before or after (nothing is written).
    """
    if out is not None:
        check_target(out)
    result = answer_text(read_model_text(model), str(model), answers, keep_draft=keep_draft)
    write_text(out or model, result.text)
    return result


def answer_text(text: str, source: str, answers: Sequence[Answer], *, keep_draft: bool = False) -> MapResult:
    """:func:`answer_questions` on a model's text (``source`` names it in messages); nothing is written."""
    listing = listing_of(text, source)
    known_wks = dict(listing.wks)
    known_tools = dict(listing.tools)
    added_wks: dict[str, str] = {}
    chosen: dict[str, tuple[str, str, SourceLocation]] = {}
    for answer in sorted(answers, key=lambda a: _breadth(a.selector)):
        broad = _breadth(answer.selector) > 0
        picked = _select(listing, answer.selector)
        if broad:  # a group, pattern or * answers what no narrower answer did
            picked = [q for q in picked if q.name not in chosen] or picked
        if not picked:
            open_names = ", ".join(q.name for q in listing.questions[:6]) or "none is open"
            raise ParseError(
                f"{answer.selector!r} selects no open question (open: {open_names})",
                location=answer.where,
                hint="a question Q1, a feature F1, a report feature or callout name, a pattern DIAMETER5*, "
                "group:P1, or *",
            )
        for q in picked:
            if not answer.tool:
                raise ParseError(f"{q.name} ({q.label}): no tool given (a tool, or none)", location=answer.where)
            if q.needs_wks and not answer.wks:
                raise ParseError(
                    f"{q.name} ({q.label}): {q.text} — no work offset given (a register such as G54, or none)",
                    location=answer.where,
                )
            wks = _resolve_wks(answer.wks, known_wks, added_wks, answer.where) if q.needs_wks else ""
            tool = _resolve_tool(answer.tool, known_tools, answer.where)
            if broad and q.name in chosen:
                continue
            if q.name in chosen and chosen[q.name][:2] != (wks, tool):
                raise ParseError(
                    f"{q.name} ({q.label}) answered twice, differently (first at {chosen[q.name][2]})",
                    location=answer.where,
                )
            chosen[q.name] = (wks, tool, answer.where)
    by_question = {q.name: q for q in listing.questions}
    relations: dict[str, list[str]] = {}
    radius_tools: set[str] = set()
    used_tools: set[str] = set()
    for name, (wks, tool, _) in chosen.items():
        for f in by_question[name].features:
            if f.role == "size":
                weight = f.radius_weight if f.radius_weight is not None else 0.0
                relations[f.id] = [f"radius = {{ {tool} = {_weight(weight)} }}" if tool else "radius = {}"]
                if tool:
                    radius_tools.add(tool)
            else:
                lines = [f"wks = {{ {wks} = 1 }}" if wks else "wks = {}"]
                if tool and f.along_spindle:  # a tool length moves what is measured along the spindle only
                    lines.append(f"tools = {{ {tool} = 1 }}")
                relations[f.id] = lines
            if tool and (f.role == "size" or f.along_spindle):
                used_tools.add(tool)
    remaining = tuple(q.name for q in listing.questions if q.name not in chosen)
    lift = not remaining and listing.draft and not keep_draft
    new_text, added = _edit(text, relations, added_wks, used_tools, radius_tools, known_tools, lift)
    new_text = _head_questions(new_text, set(chosen), len(remaining))
    doc = model_document(new_text, source)
    loaded = model_from_dict(doc, source, new_text)
    for fid, lines in relations.items():
        note = doc["features"][fid].get(QUESTION_KEY)
        if isinstance(note, str) and QUESTION.match(note):
            raise ModelError(
                f"could not write the answer into feature {fid}: edit it by hand ({'; '.join(lines)})",
                location=SourceLocation(source, key=f"features.{fid}"),
            )
    if lift and loaded.draft:
        raise ModelError(
            "every question is answered but 'draft = true' is not a line of its own in [process]: remove it by hand",
            location=SourceLocation(source, key="process.draft"),
        )
    return MapResult(
        new_text,
        tuple((q, w or "none", t or "none") for q, (w, t, _) in chosen.items()),
        remaining,
        tuple(added),
        lift,
        loaded.draft,
    )


def _weight(value: float) -> str:
    return str(int(value)) if value == int(value) else f"{value:.12g}"


_ASKED = re.compile(r"^#\s+(Q\d+) ")
_ASKED_HEAD = re.compile(r"^# Questions \((\d+); ")


def _head_questions(text: str, answered: set[str], remaining: int) -> str:
    """The file head's list of questions without the ones answered (its count line updated, gone at none)."""
    out = []
    for line in text.splitlines(keepends=True):
        m = _ASKED.match(line)
        if m and m.group(1) in answered:
            continue
        head = _ASKED_HEAD.match(line)
        if head:
            if not remaining:
                continue
            line = line.replace(f"# Questions ({head.group(1)}; ", f"# Questions ({remaining}; ", 1)
        out.append(line)
    return "".join(out)


def _edit(
    text: str,
    relations: Mapping[str, list[str]],
    added_wks: Mapping[str, str],
    used_tools: set[str],
    radius_tools: set[str],
    known_tools: Mapping[str, str],
    lift: bool,
) -> tuple[str, list[str]]:
    """The model text with the relations written, the new register tables added and the draft line gone."""
    lines = text.splitlines()
    out: list[str] = []
    section: tuple[str, str] | None = None
    first_feature = -1
    tool_header: dict[str, int] = {}
    tool_radius: set[str] = set()
    for line in lines:
        m = HEADER.match(line)
        if m:
            section = (m.group(1), m.group(2) or m.group(3))
            if section[0] == "features" and first_feature < 0:
                first_feature = len(out)
            out.append(line)
            if section[0] == "features" and section[1] in relations:
                out.extend(relations[section[1]])
            if section[0] == "tools":
                tool_header[section[1]] = len(out)
            continue
        if line.lstrip().startswith("[") and not line.lstrip().startswith("[["):
            section = ("", "")  # a table of another form ([process], [safety] …)
            if line.strip().startswith("[process]"):
                section = ("process", "")
            out.append(line)
            continue
        key = TABLE_KEY.match(line)
        name = key.group(1) if key else ""
        if section and section[0] == "features" and section[1] in relations:
            if name in ("wks", "tools", "radius"):
                continue
            if name == QUESTION_KEY and "question Q" in line:
                continue
        if section and section[0] == "tools" and name == "radius":
            tool_radius.add(section[1])
        if section and section[0] == "process" and lift and re.match(r"^\s*draft\s*=\s*true\b", line):
            continue
        out.append(line)
    added: list[str] = []
    new_tables: list[str] = []
    for wid, register in added_wks.items():
        new_tables += [f"[wks.{wid}]", f"register = {toml_string(register)}", ""]
        added.append(f"{wid} {register}")
    for tid in sorted(used_tools - set(known_tools), key=lambda t: (len(t), t)):
        number = tid[1:]
        new_tables += [f"[tools.{tid}]", f'register = "H{number}"']
        if tid in radius_tools:
            new_tables.append(f'radius = "D{number}"')
        new_tables.append("")
        added.append(f"{tid} H{number}" + (f" D{number}" if tid in radius_tools else ""))
    # a declared tool that now moves a size needs its radius register
    inserts = sorted(
        ((tool_header[t], t) for t in radius_tools & set(known_tools) if t not in tool_radius and t in tool_header),
        reverse=True,
    )
    for at, tid in inserts:
        number = re.sub(r"\D", "", known_tools[tid]) or tid
        out.insert(at, f'radius = "D{number}"')
        added.append(f"{tid} D{number}")
        if first_feature >= at:
            first_feature += 1
    if new_tables:
        at = first_feature if first_feature >= 0 else len(out)
        out[at:at] = new_tables
    return "\n".join(out) + ("\n" if text.endswith("\n") else ""), added
